"""Up from the vanishing point of the image's vertical lines (stereo_terrain.gravity.from_lines)."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.calibration import StereoCalibration
from stereo_terrain.errors import ConfigError
from stereo_terrain.frames import rotation_from_rpy
from stereo_terrain.gravity import (
    GravityEstimate,
    VerticalLinesConfig,
    angle_deg,
    combine_with_lines,
    up_from_vertical_lines,
)
from stereo_terrain.gravity.from_lines import scene_lines
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import compute_rectification
from stereo_terrain.synthetic import random_scene_spec, render_scene

#: Up from clean drawn lines (anti-aliased, 2 px wide) must be within this many of its
#: reported sigmas of the truth. Measured over 150 random attitudes: error median 0.04,
#: p95 0.17, max 0.41 deg, sigma at its 0.3 deg floor; hypothesis found 0.51 deg for a
#: nearly level camera, whose vertical lines are nearly parallel in the image and fix its
#: pitch least.
DRAWN_SIGMAS = 2.0
#: ... and clean lines must give a tight estimate.
DRAWN_MAX_SIGMA_DEG = 0.5
#: Bound on gravity from a rendered realistic scene with the lines (measured 0.5 deg).
RENDERED_TOL_DEG = 2.0

W, H, F = 640, 480, 500.0


def _rectification():
    K = np.array([[F, 0.0, W / 2], [0.0, F, H / 2], [0.0, 0.0, 1.0]])
    calib = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.08, 0.0, 0.0]), (W, H))
    return compute_rectification(calib)


def _camera_R(roll_deg: float, pitch_deg: float) -> np.ndarray:
    """Camera (optical: x right, y down, z forward) <- world (x forward, y left, z up) for a
    camera pitched down by ``pitch_deg`` and rolled by ``roll_deg``."""
    R_opt = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])  # optical <- level body
    return R_opt @ rotation_from_rpy(math.radians(roll_deg), math.radians(pitch_deg), 0.0).T


def _draw_vertical_lines(R: np.ndarray, rng, count: int = 14, distractors: int = 0) -> np.ndarray:
    """Vertical 3D segments (0.3-1.2 m tall, from points 1.5-4 m along rays through the
    image) drawn into a noisy grey image; ``distractors``: horizontal 3D segments (step
    edges) as well. Segments that leave the image are drawn again."""
    img = rng.normal(120.0, 3.0, (H, W))
    drawn = 0
    for _ in range(1000 * (count + distractors)):
        if drawn == count + distractors:
            break
        ray = np.array([(rng.uniform(0, W) - W / 2) / F, (rng.uniform(0, H) - H / 2) / F, 1.0])
        a = R.T @ (ray * rng.uniform(1.5, 4.0))  # world
        step = [0.0, 0.0, rng.uniform(0.3, 1.2)] if drawn < count else [0.0, rng.uniform(0.5, 1.5), 0.0]
        pa, pb = R @ a, R @ (a + np.array(step))
        if pb[2] < 0.5:
            continue
        ua = (F * pa[0] / pa[2] + W / 2, F * pa[1] / pa[2] + H / 2)
        ub = (F * pb[0] / pb[2] + W / 2, F * pb[1] / pb[2] + H / 2)
        if not all(0 <= u[0] < W and 0 <= u[1] < H for u in (ua, ub)):
            continue
        shift = 4  # sub-pixel ends
        cv2.line(
            img,
            tuple(int(round(c * 2**shift)) for c in ua),
            tuple(int(round(c * 2**shift)) for c in ub),
            40.0,
            2,
            cv2.LINE_AA,
            shift,
        )
        drawn += 1
    assert drawn == count + distractors, "could not place the segments in the image"
    return np.clip(img, 0, 255).astype(np.uint8)


def _true_up(R: np.ndarray) -> np.ndarray:
    return R @ np.array([0.0, 0.0, 1.0])


@settings(max_examples=15, deadline=None, derandomize=True)  # same examples in every run
@given(roll=st.floats(-10.0, 10.0), pitch=st.floats(-5.0, 30.0), seed=st.integers(0, 2**16))
def test_drawn_vertical_lines_give_up(roll, pitch, seed):
    R = _camera_R(roll, pitch)
    img = _draw_vertical_lines(R, np.random.default_rng(seed), distractors=4)
    est = up_from_vertical_lines(img, _rectification())
    assert est.ok, est.reason
    assert est.frame == "camera_rect"
    assert est.sigma_deg <= DRAWN_MAX_SIGMA_DEG
    assert angle_deg(est.up, _true_up(R)) < DRAWN_SIGMAS * est.sigma_deg
    assert est.up[1] < 0  # up, not down (camera y points down)
    assert est.sigma_deg >= VerticalLinesConfig().structure_sigma_deg


def test_without_vertical_lines_it_says_so():
    rng = np.random.default_rng(0)
    blank = rng.normal(120.0, 3.0, (H, W)).clip(0, 255).astype(np.uint8)
    est = up_from_vertical_lines(blank, _rectification())
    assert not est.ok and np.isnan(est.up).all() and not math.isfinite(est.sigma_deg)
    assert "segment" in est.reason
    # Horizontal 3D edges only (step edges seen head-on): no vertical vanishing point.
    edges = _draw_vertical_lines(_camera_R(0.0, 10.0), rng, count=0, distractors=12)
    assert not up_from_vertical_lines(edges, _rectification()).ok


def test_lines_outside_the_prior_cone_are_refused():
    R = _camera_R(0.0, 40.0)  # pitched down 40 deg: up is 40 deg from the camera's up
    img = _draw_vertical_lines(R, np.random.default_rng(3))
    assert up_from_vertical_lines(img, _rectification(), prior_cone_deg=60.0).ok
    est = up_from_vertical_lines(img, _rectification(), prior_cone_deg=30.0)
    assert not est.ok and "from the camera's up" in est.reason


def _estimate(up, sigma, ok=True, frame="yaw") -> GravityEstimate:
    u = np.asarray(up, dtype=float)
    return GravityEstimate(u / np.linalg.norm(u), frame, sigma, ok, reason="test")


def test_combine_agreeing_estimates_weights_them_by_their_variances():
    a = _estimate([0.0, 0.0, 1.0], 1.0)
    tilt = math.radians(1.0)
    b = _estimate([math.sin(tilt), 0.0, math.cos(tilt)], 0.5)
    c = combine_with_lines(a, b)
    assert c.ok and c.sigma_deg == pytest.approx((1.0 + 4.0) ** -0.5)
    # Inverse-variance weights 1 and 4: 0.8 deg toward the lines.
    assert angle_deg(c.up, a.up) == pytest.approx(0.8, abs=0.01)


def test_combine_the_lines_overrule_a_conflicting_planes_estimate_unless_told_not_to():
    planes = _estimate([0.0, 0.0, 1.0], 1.0)
    tilt = math.radians(8.0)
    lines = _estimate([0.0, math.sin(tilt), math.cos(tilt)], 0.5)
    c = combine_with_lines(planes, lines)
    assert np.allclose(c.up, lines.up) and c.sigma_deg == lines.sigma_deg and "overrules" in c.reason
    assert combine_with_lines(planes, lines, overrule=False) is planes
    # One that does not count gives way to the other.
    assert combine_with_lines(_estimate([0, 0, 1], math.inf), lines) is lines
    assert combine_with_lines(planes, dataclasses.replace(lines, ok=False)) is planes
    with pytest.raises(ConfigError):
        combine_with_lines(planes, dataclasses.replace(lines, frame="camera_rect"))


@pytest.mark.parametrize(
    "kw",
    [
        {"max_tilt_deg": 0.0},
        {"max_tilt_deg": 95.0},
        {"min_inliers": 1},
        {"inlier_deg": 0.0},
        {"detect_scale": 0.0},
        {"detect_scale": 1.5},
        {"structure_sigma_deg": -0.1},
        {"hypotheses": 0},
        {"terrain_min_length_px": 0.0},
        {"terrain_min_length_px": 25.0},
    ],
)
def test_bad_config_raises(kw):
    with pytest.raises(ConfigError):
        VerticalLinesConfig(**kw)


def test_pipeline_config_section():
    assert not PipelineConfig.from_dict({"vanishing": {"enabled": False}}).vanishing.enabled
    with pytest.raises(ConfigError):
        PipelineConfig.from_dict({"vanishing": {"nope": 1}})


def test_realistic_render_where_the_planes_alone_go_wrong():
    """Realistic scene 22 of seed 11 (`render --profile realistic --seed 11`): wooden
    stairs seen head-on whose disparity is a smooth ramp; the planes alone put up 30 deg
    off (measured), the vertical lines (stair ends, wall corners) fix it."""
    rng = np.random.default_rng(11)
    for _ in range(22):
        random_scene_spec(rng, profile="realistic")
    scene = render_scene(random_scene_spec(rng, profile="realistic"))
    pipeline = Pipeline(scene.calibration)
    result = pipeline.run(scene.left, scene.right)
    true_up = (
        (scene.rig.T_yaw_camera @ pipeline.rectification.T_camera_rect)
        .inverse()
        .apply_vectors(np.array([0.0, 0.0, 1.0]))
    )
    assert result.gravity_source == "scene"
    assert "vanishing point" in result.gravity.note
    assert angle_deg(result.gravity.up_camera, true_up) < RENDERED_TOL_DEG


def _bar_image(lines: list[tuple[float, float, float, float]]) -> np.ndarray:
    """Dark 3-px lines (x1, y1, x2, y2, ends may lie outside) on a noisy grey image."""
    img = np.random.default_rng(0).normal(150.0, 2.0, (H, W))
    for x1, y1, x2, y2 in lines:
        cv2.line(img, (int(round(x1)), int(round(y1))), (int(round(x2)), int(round(y2))), 30.0, 3)
    return np.clip(img, 0, 255).astype(np.uint8)


def test_segments_reaching_the_border_are_clipped_for_the_nosings_only():
    """A line that runs out of the view comes back clipped at the border band, apart from
    the whole segments the estimates use (issue 11: a staircase wider than the view)."""
    img = _bar_image([(150, 200, 2 * W, 200), (100, 250, 100, 400)])
    found = scene_lines(img, _rectification(), VerticalLinesConfig(), known_up=np.array([0.0, -1.0, 0.0]))
    whole, border = found.segments, found.at_border
    assert len(border) >= 1 and len(whole) >= 1
    # The horizontal bar: clipped, from its start to within the 6-px band of the right edge.
    assert np.all(np.abs(border[:, [1, 3]] - 200) < 4)
    assert border[:, [0, 2]].max() == pytest.approx(W - 7, abs=1.5)
    assert border[:, [0, 2]].min() == pytest.approx(150, abs=4)
    # The vertical bar is whole, and only there.
    assert np.all(np.abs(whole[:, [0, 2]] - 100) < 4)


def test_segments_shorter_than_gravity_takes_go_to_the_terrain_alone():
    """A 16-px bar (a riser's end at the top of a staircase 3 m away) is among the short
    segments the terrain's vertical edges take, not among those gravity, the horizontal
    direction and the nosings use; a bar 40 px long is among those, as with the terrain's
    own length at gravity's."""
    img = _bar_image([(300, 200, 300, 216), (100, 250, 100, 290)])
    found = scene_lines(img, _rectification(), VerticalLinesConfig())  # at detect_scale 1
    assert len(found.short) >= 1 and np.all(np.abs(found.short[:, [0, 2]] - 300) < 4)
    assert len(found.segments) >= 1 and np.all(np.abs(found.segments[:, [0, 2]] - 100) < 4)
    same = VerticalLinesConfig(terrain_min_length_px=20.0)
    alone = scene_lines(img, _rectification(), same)
    assert len(alone.short) == 0
    assert np.array_equal(alone.segments, found.segments)


@settings(max_examples=25, deadline=None)
@given(
    x=st.floats(-200.0, W + 200.0),
    y=st.floats(-200.0, H + 200.0),
    angle=st.floats(0.0, math.pi),
)
def test_clipped_segments_stay_off_the_border_and_on_their_line(x, y, angle):
    """Whatever line is drawn, every segment returned lies inside the border band, and a
    clipped one lies on the drawn line."""
    c, s = math.cos(angle), math.sin(angle)
    line = (x - 2000 * c, y - 2000 * s, x + 2000 * c, y + 2000 * s)
    found = scene_lines(
        _bar_image([line]), _rectification(), VerticalLinesConfig(), known_up=np.array([0.0, -1.0, 0.0])
    )
    for seg in np.concatenate([found.segments, found.at_border]):
        ends = seg.reshape(2, 2)
        assert np.all(ends >= 5.5) and np.all(ends[:, 0] <= W - 6.5) and np.all(ends[:, 1] <= H - 6.5)
    # The line as drawn (its ends rounded to pixels) and the distance of each clipped end
    # from its centre line (the bar's edges about 2 px off, and the drawing's own rounding).
    a, b = np.round(line[:2]), np.round(line[2:])
    normal = np.array([a[1] - b[1], b[0] - a[0]]) / np.hypot(*(b - a))
    for seg in found.at_border:
        assert np.all(np.abs((seg.reshape(2, 2) - a) @ normal) < 5.0)
