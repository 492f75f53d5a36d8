"""The contour method (paper 3.2.1): regions, IoU deduplication, ordering rules, planes."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereo_terrain.cloud import (
    CloudConfig,
    GridSample,
    disparity_to_cloud,
    sample_disparity,
    transform_cloud,
)
from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.evaluation import score_result
from stereo_terrain.msac import Plane
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.planes.auto import combine_plane_sets
from stereo_terrain.planes.contour import (
    ContourConfig,
    apply_ordering_rules,
    dedup_by_iou,
    extract_planes_contour,
    find_regions,
)
from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSegment, extract_planes_orientation
from stereo_terrain.synthetic import random_scene_spec, render_scene

from .analytic import step_scene

NORMAL_TOL_DEG = 1.0
OFFSET_TOL_M = 0.005
RISE_TOL_M = 0.01
DISTANCE_TOL_M = 0.03


def _angle(a, b):
    return np.degrees(np.arccos(np.clip(abs(np.dot(a, b)), 0, 1)))


def _step_scene_with_image():
    """Grid sample of the analytic step scene and an image shading each face differently
    (ground 100, riser 170, tread 60 grey), as a lit staircase would be."""
    disp, T = step_scene()
    s = sample_disparity(disp, T, CloudConfig(max_depth_m=10))
    cloud = transform_cloud(disparity_to_cloud(disp, CloudConfig(max_depth_m=10)), T)
    p = np.nan_to_num(cloud.points, nan=-1.0)
    img = np.full(cloud.shape, 200, np.uint8)  # sky
    img[np.abs(p[..., 2]) < 0.005] = 100
    img[np.abs(p[..., 0] - 1.4) < 0.005] = 170
    img[np.abs(p[..., 2] - 0.18) < 0.005] = 60
    return s, img


def _subset(s: GridSample, keep: np.ndarray) -> GridSample:
    fields = ("points", "normals", "sigma_m", "rows", "cols", "grid_index", "normal_sigma_rad")
    return dataclasses.replace(s, **{k: getattr(s, k)[keep] for k in fields})


def test_finds_ground_riser_and_tread_on_shaded_faces():
    s, img = _step_scene_with_image()
    ps = extract_planes_contour(s, img)
    assert ps.method == "contour"
    horiz = sorted((seg for seg in ps.segments if seg.kind == HORIZONTAL), key=lambda g: -g.plane.offset)
    vert = [seg for seg in ps.segments if seg.kind == VERTICAL]
    assert len(horiz) == 2 and len(vert) == 1, [(g.kind, g.plane.normal) for g in ps.segments]
    ground, tread = horiz
    assert -ground.plane.offset == pytest.approx(0.0, abs=OFFSET_TOL_M)
    assert -tread.plane.offset == pytest.approx(0.18, abs=OFFSET_TOL_M)
    riser = vert[0]
    assert _angle(riser.plane.normal, [1, 0, 0]) < NORMAL_TOL_DEG and riser.plane.normal[0] < 0
    assert -riser.plane.offset / riser.plane.normal[0] == pytest.approx(1.4, abs=OFFSET_TOL_M)
    # The values chosen from the data are reported.
    p = ps.parameters
    assert p["regions_after_iou"] <= p["regions"] and len(p["grey_levels"]) >= 3
    assert p["msac_trials"]["max"] >= ContourConfig().min_hypotheses
    assert all(
        ContourConfig().min_angle_tol_deg <= t <= ContourConfig().max_angle_tol_deg
        for t in p["angle_tol_deg"]
    )


def test_planes_of_any_orientation():
    """A 30-degree ramp is one plane of kind 'other' with the right normal."""
    s, img = _step_scene_with_image()
    s = _subset(s, np.abs(s.points[:, 0] - 1.4) > 1e-3)  # riser samples: one x, a line on the ramp
    tilt = np.radians(30.0)
    n = np.array([-np.sin(tilt), 0.0, np.cos(tilt)])
    P = s.points.astype(np.float64)
    # Put every sample on the ramp plane n . x = 0.1 along the vertical, keep the normals.
    z = (0.1 - n[0] * P[:, 0] - n[1] * P[:, 1]) / n[2]
    pts = np.column_stack([P[:, :2], z]).astype(np.float32)
    ramp = dataclasses.replace(s, points=pts, normals=np.tile(n, (len(s), 1)).astype(np.float32))
    ps = extract_planes_contour(ramp, img)
    assert len(ps.segments) == 1
    seg = ps.segments[0]
    assert seg.kind == "other" and _angle(seg.plane.normal, n) < NORMAL_TOL_DEG
    assert seg.count > 0.9 * len(s)


def test_iou_dedup_keeps_the_larger_of_each_overlapping_pair():
    big = np.zeros((20, 20), bool)
    big[2:12, 2:12] = True  # 100 cells
    overlap = np.zeros_like(big)
    overlap[4:13, 3:12] = True  # IoU with big = 72 / 109 > 0.3
    apart = np.zeros_like(big)
    apart[14:18, 14:18] = True
    nested = np.zeros_like(big)
    nested[2:5, 2:5] = True  # inside big, IoU 0.09
    assert dedup_by_iou([big, overlap, apart, nested], 0.3) == [0, 2, 3]
    assert dedup_by_iou([big, np.zeros_like(big)], 0.3) == [0]  # empty regions never kept
    assert dedup_by_iou([], 0.3) == []


@given(
    st.lists(
        st.tuples(st.integers(0, 15), st.integers(0, 15), st.integers(1, 8), st.integers(1, 8)), max_size=12
    )
)
def test_iou_dedup_property(rects):
    masks = []
    for r, c, h, w in rects:
        m = np.zeros((24, 24), bool)
        m[r : r + h, c : c + w] = True
        masks.append(m)
    masks.sort(key=lambda m: -m.sum())
    kept = dedup_by_iou(masks, 0.3)
    if masks:
        assert kept[0] == 0  # the largest always survives
    for i in kept:
        for j in kept:
            if i < j:
                inter = (masks[i] & masks[j]).sum()
                assert inter / (masks[i] | masks[j]).sum() <= 0.3
    for j in set(range(len(masks))) - set(kept):  # each dropped one overlaps a larger kept one
        assert any(i < j and (masks[i] & masks[j]).sum() / (masks[i] | masks[j]).sum() > 0.3 for i in kept)


def _fake_segment(s, rows_lo, rows_hi, kind, value):
    """A segment made of the samples between two image rows, its points moved to height
    ``value`` (horizontal) or depth ``value`` along x (vertical)."""
    idx = np.flatnonzero((s.rows >= rows_lo) & (s.rows < rows_hi))
    n = [0.0, 0.0, 1.0] if kind == HORIZONTAL else [-1.0, 0.0, 0.0]
    return PlaneSegment(Plane(np.array(n), -value if kind == HORIZONTAL else value), kind, idx, 0.0), idx


def test_ordering_rules_drop_planes_that_break_the_image_order():
    s, _ = _step_scene_with_image()
    P = s.points.copy()
    segs = []
    # Horizontal planes from the bottom of the image up: 0.0, 0.15, 0.05 (breaks), 0.30.
    for (lo, hi), z in zip(
        [(400, 480), (300, 400), (200, 300), (100, 200)], [0.0, 0.15, 0.05, 0.30], strict=True
    ):
        seg, idx = _fake_segment(s, lo, hi, HORIZONTAL, z)
        P[idx, 2] = z
        segs.append(seg)
    s2 = dataclasses.replace(s, points=P)
    kept, dropped = apply_ordering_rules(segs, s2, np.array([0, 0, 1.0]), s.camera_position)
    assert dropped == 1
    assert [float(-k.plane.offset) for k in kept] == [0.0, 0.15, 0.30]


def test_ordering_rules_vertical_planes_deeper_higher_in_the_image():
    s, _ = _step_scene_with_image()
    P = s.points.copy()
    segs = []
    for (lo, hi), x in zip([(300, 400), (200, 300), (100, 200)], [1.2, 1.5, 1.35], strict=True):
        seg, idx = _fake_segment(s, lo, hi, VERTICAL, x)
        P[idx, 0] = x
        segs.append(seg)
    s2 = dataclasses.replace(s, points=P)
    kept, dropped = apply_ordering_rules(segs, s2, np.array([0, 0, 1.0]), np.zeros(3))
    assert dropped == 1 and len(kept) == 2


def test_no_contours_in_a_uniform_image():
    s, img = _step_scene_with_image()
    ps = extract_planes_contour(s, np.full_like(img, 128))
    assert ps.segments == () and "contour" in ps.stop_reason
    regions, _ = find_regions(np.full_like(img, 128), s.grid_shape, s.stride_px)
    assert all(r.mask.all() for r in regions)  # at most the whole image


def test_all_points_on_one_plane_give_one_plane():
    s, img = _step_scene_with_image()
    ground = np.abs(s.points[:, 2]) < 1e-3
    only = _subset(s, ground)
    ps = extract_planes_contour(only, img)
    assert len(ps.segments) == 1 and ps.segments[0].kind == HORIZONTAL
    assert ps.segments[0].count > 0.9 * len(only)


def test_tiny_cloud_and_wrong_image():
    s, img = _step_scene_with_image()
    ps = extract_planes_contour(_subset(s, np.arange(10)), img)
    assert ps.segments == () and "too small" in ps.stop_reason
    with pytest.raises(InputError, match="rectified left image"):
        extract_planes_contour(s, img[:100, :100])
    with pytest.raises(InputError, match="grey"):
        find_regions(np.zeros((10, 10, 2), np.uint8), s.grid_shape, s.stride_px)


def test_confidence_filters_and_is_reported():
    s, img = _step_scene_with_image()
    conf = np.ones(len(s), np.float32)
    conf[::2] = 0.0
    ps = extract_planes_contour(dataclasses.replace(s, confidence=conf), img)
    assert ps.parameters["confidence_weighting"] is True
    assert ps.parameters["points_below_min_confidence"] == int((conf < ContourConfig().min_confidence).sum())
    for seg in ps.segments:
        assert np.all(conf[seg.indices] >= ContourConfig().min_confidence)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"iou_threshold": 1.5},
        {"levels": 0},
        {"confidence": 1.0},
        {"min_hypotheses": 300},
        {"min_angle_tol_deg": 20},
    ],
)
def test_config_checks(kwargs):
    with pytest.raises(ConfigError):
        ContourConfig(**kwargs)
    with pytest.raises(ConfigError):
        PipelineConfig.from_dict({"contour": kwargs})


def test_unknown_method_is_a_config_error():
    with pytest.raises(ConfigError, match="orientation, contour, auto"):
        PipelineConfig(method="hough")


def test_combine_adds_only_new_planes():
    s, img = _step_scene_with_image()
    po = extract_planes_orientation(s)
    pc = extract_planes_contour(s, img)
    same, added = combine_plane_sets(po, pc)
    assert added == 0 and same.method == "combined" and len(same.segments) == len(po.segments)
    # Without the riser in the orientation set, the contour riser is added.
    no_riser = dataclasses.replace(po, segments=tuple(g for g in po.segments if g.kind != VERTICAL))
    more, added = combine_plane_sets(no_riser, pc)
    assert added >= 1 and any(g.kind == VERTICAL for g in more.segments)


# A rendered textured staircase (seed 5, fourth draw: 4 steps) where the faces' shades differ.
RENDER_SEED, RENDER_INDEX = 5, 3


@pytest.fixture(scope="module")
def rendered():
    rng = np.random.default_rng(RENDER_SEED)
    specs = [
        random_scene_spec(rng, kind="stairs" if i % 4 else "box", weak_texture=i % 3 == 2)
        for i in range(RENDER_INDEX + 1)
    ]
    return render_scene(specs[RENDER_INDEX])


@pytest.mark.parametrize("method", ["orientation", "contour", "auto"])
def test_methods_on_a_rendered_staircase(rendered, method):
    result = Pipeline(rendered.calibration, rendered.rig, PipelineConfig(method=method)).run(
        rendered.left, rendered.right
    )
    data = result.to_json_dict()
    score = score_result(data, rendered.truth)
    assert score.detected and score.count_right, data["steps"]
    assert max(score.rise_errors_m) <= RISE_TOL_M
    assert score.first_distance_error_m <= DISTANCE_TOL_M
    assert data["plane_stage"]["method_requested"] == method


def test_region_msac_kernel_finds_the_plane_among_outliers():
    """The compiled per-region MSAC: a region of one plane with 30% gross outliers gives
    that plane, and stops early (adaptive trials) when the inlier ratio is high."""
    from stereo_terrain.planes._kernels import region_msac
    from stereo_terrain.planes.orientation import grid_lookup

    s, _ = _step_scene_with_image()
    rng = np.random.default_rng(0)
    ground = np.abs(s.points[:, 2]) < 1e-3
    P = s.points.astype(np.float64)
    bad = ground & (rng.random(len(s)) < 0.3)
    P[bad, 2] += rng.uniform(0.1, 0.5, bad.sum())
    lut, gr, gc = grid_lookup(s)
    idx = np.flatnonzero(ground)
    score = rng.choice(idx, 300, replace=False)
    args = (P, s.normals.astype(np.float64), np.full(len(s), 1 / 0.01), lut, gr, gc, ground, idx, score, 4)
    n, d, cost, trials = region_msac(*args, 16, 256, 0.99, 0.9, rng.random((256, 5)))
    assert _angle(n, [0, 0, 1]) < NORMAL_TOL_DEG and abs(d) < OFFSET_TOL_M
    assert trials < 256
    clean = np.flatnonzero(ground & ~bad)
    args2 = (P, s.normals.astype(np.float64), np.full(len(s), 1 / 0.01), lut, gr, gc, ground & ~bad, clean)
    _, _, _, few = region_msac(*args2, clean[:300], 4, 16, 256, 0.99, 0.9, rng.random((256, 5)))
    assert few == 16  # all-inlier region: one batch is enough


def test_auto_takes_the_contour_planes_when_they_add_steps(rendered):
    """With the orientation method cut short (two planes), the contour planes complete the
    staircase and auto says so. (The risers moved to where both images put them are off:
    with them the far planes' one riser, moved, carries on to the whole staircase by its
    nosings, and the short orientation method alone finds all four steps;
    tests/test_photometric.py. The band fill is off too: with it a second opinion's one
    riser carries on to all four steps by its nosings.)"""
    from stereo_terrain.planes.orientation import OrientationConfig
    from stereo_terrain.stereo.bands import BandFillConfig
    from stereo_terrain.terrain import TerrainConfig

    cut = OrientationConfig(max_planes=2)
    still = TerrainConfig(photometric_risers=False)
    no_bands = BandFillConfig(enabled=False)
    short = Pipeline(
        rendered.calibration, rendered.rig, PipelineConfig(orientation=cut, terrain=still, bands=no_bands)
    )
    auto = Pipeline(
        rendered.calibration,
        rendered.rig,
        PipelineConfig(method="auto", orientation=cut, terrain=still, bands=no_bands),
    )
    n_short = len(short.run(rendered.left, rendered.right).terrain.steps)
    data = auto.run(rendered.left, rendered.right).to_json_dict()
    assert len(data["steps"]) > n_short
    assert data["plane_stage"]["method_used"] == "combined"
    assert "added" in data["plane_stage"]["reason"]
    assert data["plane_stage"]["parameters"]["contour_planes_added"] >= 1


def test_method_and_contour_section_from_config_mapping():
    cfg = PipelineConfig.from_dict({"method": "contour", "contour": {"levels": 8, "iou_threshold": 0.4}})
    assert cfg.method == "contour" and cfg.contour.levels == 8 and cfg.contour.iou_threshold == 0.4
    with pytest.raises(ConfigError, match="unknown keys"):
        PipelineConfig.from_dict({"contour": {"levles": 8}})


@given(
    st.floats(-np.pi, np.pi),
    st.floats(0.5, 3.0),
    st.floats(-3.0, 3.0),
    st.integers(0, 2**16),
)
def test_snap_to_gravity_property(yaw, distance, tilt_deg, seed):
    """Points of a vertical plane (any yaw and distance) with a slightly tilted free fit
    snap to that exact vertical plane; horizontal ones to their height."""
    from stereo_terrain.planes.contour import snap_to_gravity

    rng = np.random.default_rng(seed)
    up = np.array([0.0, 0.0, 1.0])
    n = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    lateral = np.array([-n[1], n[0], 0.0])
    pts = distance * n + rng.uniform(-0.5, 0.5, (60, 1)) * lateral + rng.uniform(0, 0.2, (60, 1)) * up
    t = np.radians(tilt_deg)
    free = Plane(np.cos(t) * n + np.sin(t) * up, -distance)
    snapped = snap_to_gravity(free, pts, up, VERTICAL)
    assert abs(snapped.normal @ up) < 1e-9
    assert np.max(snapped.residuals(pts)) < 1e-6
    flat = snap_to_gravity(Plane(up + 0.01 * n, 0.0), pts * [1, 1, 0] + [0, 0, 0.3], up, HORIZONTAL)
    assert np.allclose(flat.normal, up) and flat.offset == pytest.approx(-0.3)
