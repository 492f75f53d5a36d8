"""Per-frame vertical alignment (stereo/vertical.py) and the full-height rectification."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.evaluation import score_result
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import RectifiedPair, compute_rectification, rectify, rectify_points
from stereo_terrain.stereo import make_backend
from stereo_terrain.stereo.vertical import VerticalAlignConfig, align_vertical, estimate_vertical_offset
from stereo_terrain.synthetic import CameraIntrinsics, default_scene_spec, render_scene

#: Phase correlation on rendered tiles: error median 0.05, p95 0.14, max 0.19 px over dy in
#: [-2, 2] px by 0.025 px; hypothesis found 0.205 px at one offset (its sub-pixel bias).
OFFSET_TOL_PX = 0.25
RISE_TOL_M = 0.01


def _shift_down(image: np.ndarray, dy: float) -> np.ndarray:
    M = np.float32([[1, 0, 0], [0, 1, dy]])
    return cv2.warpAffine(
        image, M, image.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    )


@pytest.fixture(scope="module")
def demo():
    return render_scene(default_scene_spec())


@pytest.fixture(scope="module")
def demo_pair(demo):
    return rectify(demo.left, demo.right, compute_rectification(demo.calibration))


def test_config_checks():
    with pytest.raises(ConfigError, match="min_tiles"):
        VerticalAlignConfig(min_tiles=20)
    with pytest.raises(ConfigError, match="min_response"):
        VerticalAlignConfig(min_response=1.5)
    with pytest.raises(ConfigError, match="max_spread_px"):
        VerticalAlignConfig(max_spread_px=0.0)
    with pytest.raises(ConfigError, match="rectify_fov"):
        PipelineConfig(rectify_fov="wide")
    assert PipelineConfig.from_dict({"vertical": {"enabled": False}}).vertical.enabled is False


@settings(max_examples=6, deadline=None)
@given(dy=st.floats(-2.0, 2.0))
def test_offset_measured(demo_pair, dy):
    """A right image moved down by dy (rectified pixels) is measured as dy."""
    right = _shift_down(demo_pair.right, dy)
    est = estimate_vertical_offset(demo_pair.left, right)
    assert est.tiles_used >= 4
    assert abs(est.offset_px - dy) < OFFSET_TOL_PX, est
    assert est.largest_px(640) - abs(est.offset_px) < OFFSET_TOL_PX


def test_well_rectified_pair_left_alone(demo_pair):
    out, est = align_vertical(demo_pair)
    assert not est.applied and out is demo_pair
    flat = RectifiedPair(
        np.full((480, 640), 128, np.uint8), np.full((480, 640), 128, np.uint8), demo_pair.rectification
    )
    out, est = align_vertical(flat)
    assert out is flat and est.tiles_used == 0
    out, est = align_vertical(demo_pair, VerticalAlignConfig(enabled=False))
    assert out is demo_pair and est.reason == "disabled"


def test_shift_of_one_and_a_half_px_corrected(demo, demo_pair):
    """The raw right image moved 1.5 px down: disparity and terrain close to the unmoved pair."""
    right = _shift_down(demo.right, 1.5)
    moved = rectify(demo.left, right, demo_pair.rectification)
    aligned, est = align_vertical(moved)
    assert (
        est.applied
        and abs(est.offset_px - 1.5 * demo_pair.rectification.focal_px / demo.calibration.K2[1, 1]) < 0.25
    )
    sgm = make_backend("sgm")
    ref = sgm.compute(demo_pair, 64).disparity
    raw = sgm.compute(moved, 64).disparity
    fixed = sgm.compute(aligned, 64).disparity

    def agree(d):
        both = np.isfinite(ref) & np.isfinite(d)
        return float(np.mean(np.abs(d[both] - ref[both]) < 1.0) * both.sum() / np.isfinite(ref).sum())

    assert agree(fixed) > 0.9 and agree(fixed) > agree(raw) + 0.1
    truth = demo.truth
    for left_img, right_img in ((demo.left, right),):
        score = score_result(
            Pipeline(demo.calibration, demo.rig).run(left_img, right_img).to_json_dict(), truth
        )
        assert score.count_right and max(score.rise_errors_m) < RISE_TOL_M


def test_full_height_keeps_the_bottom_rows(demo):
    rect = compute_rectification(demo.calibration, fov="full-height")
    old = compute_rectification(demo.calibration)
    w, h = rect.image_size
    bottom = np.array([[w / 2, h - 1.5], [w / 4, h - 1.5], [3 * w / 4, h - 1.5], [w / 2, 0.5]])
    for side in ("left", "right"):
        uv = rectify_points(bottom, rect, side)
        assert np.all((uv[:, 1] >= 0) & (uv[:, 1] <= h - 1)), uv
    assert rectify_points(bottom[:1], old, "left")[0, 1] > h - 1  # alpha 0 cropped it
    # Consistent geometry: square pixels, Q and P1 agree, the ROI has sources only.
    assert rect.fov == "full-height" and np.isclose(rect.P1[1, 1], rect.focal_px)
    assert np.allclose(rect.Q[:2, 3], [-rect.cx, -rect.cy]) and np.isclose(rect.Q[2, 3], rect.focal_px)
    assert np.isclose(1.0 / rect.Q[3, 2], rect.baseline_m)
    x, y, rw, rh = rect.valid_roi
    assert rect.valid_left is not None and rect.valid_left[y : y + rh, x : x + rw].all()
    assert rw * rh > 0.6 * w * h


def test_sourceless_pixels_give_nan(demo):
    rect = compute_rectification(demo.calibration, fov="all")
    pair = rectify(demo.left, demo.right, rect)
    assert rect.valid_left is not None and not rect.valid_left.all()
    for name in ("opencv", "sgm"):
        d = make_backend(name).compute(pair, 64).disparity
        assert not np.isfinite(d[~rect.valid_left]).any(), name
        ys, xs = np.nonzero(np.isfinite(d))
        xr = np.rint(xs - d[ys, xs]).astype(int)
        assert rect.valid_right[ys, xr].all(), name
    res = Pipeline(demo.calibration, demo.rig, PipelineConfig(rectify_fov="all")).run(demo.left, demo.right)
    assert not np.isfinite(res.disparity.disparity[~rect.valid_left]).any()  # the fill stays out too


def test_fy_not_fx_rectifies_and_reconstructs():
    """fy / fx = 0.93: square rectified pixels, and the staircase measured right."""
    spec = default_scene_spec()
    w, h = spec.image_size
    cam = CameraIntrinsics(0.85 * w, 0.93 * 0.85 * w, (w - 1) / 2, (h - 1) / 2, (-0.1, 0.01, 0.0, 0.0, 0.0))
    spec = dataclasses.replace(spec, left_camera=cam, right_camera=cam)
    scene = render_scene(spec)
    rect = compute_rectification(scene.calibration, fov="full-height")
    assert np.isclose(rect.P1[0, 0], rect.P1[1, 1])
    uv = rectify_points(np.array([[w / 2, h - 1.5]]), rect, "left")
    assert 0 <= uv[0, 1] <= h - 1
    score = score_result(
        Pipeline(scene.calibration, scene.rig, PipelineConfig(rectify_fov="full-height"))
        .run(scene.left, scene.right)
        .to_json_dict(),
        scene.truth,
    )
    assert score.count_right and max(score.rise_errors_m) < RISE_TOL_M
    assert abs(score.first_distance_error_m) < 0.03
