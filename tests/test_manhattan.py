"""The Manhattan fill (stereo_terrain.stereo.manhattan) and the scene's horizontal direction
(stereo_terrain.gravity.horizontal_direction)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.calibration import StereoCalibration
from stereo_terrain.errors import ConfigError
from stereo_terrain.frames import rotation_from_rpy
from stereo_terrain.gravity import VerticalLinesConfig, horizontal_direction
from stereo_terrain.rectify import compute_rectification
from stereo_terrain.stereo.fill import PlanarFillConfig, fill_planar_regions, find_flat_regions
from stereo_terrain.stereo.manhattan import _repeats_a_neighbour, _stacked, fill_manhattan_faces

W, H, F, B = 640, 480, 500.0, 0.08
#: Horizontal direction from exact segments: within this of the truth, modulo 90 deg
#: (the circular mean of exact directions; what remains is rounding).
DIRECTION_TOL_DEG = 0.2
#: A filled riser's disparity against its plane's: the support is exact here, so the fill
#: is exact up to float32.
FILL_TOL_PX = 0.05


def _rectification():
    K = np.array([[F, 0.0, W / 2], [0.0, F, H / 2], [0.0, 0.0, 1.0]])
    calib = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-B, 0.0, 0.0]), (W, H))
    return compute_rectification(calib)


def _camera_R(roll_deg: float, pitch_deg: float) -> np.ndarray:
    """Camera (optical) <- world (x forward, y left, z up)."""
    R_opt = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    return R_opt @ rotation_from_rpy(math.radians(roll_deg), math.radians(pitch_deg), 0.0).T


def _segments(R: np.ndarray, yaw: float, rng: np.random.Generator, count: int) -> np.ndarray:
    """Image segments of horizontal 3D lines along ``yaw`` and ``yaw + 90 deg`` (world), and
    of a few vertical and sloped ones, all inside the image."""
    along = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    across = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    steps = [along] * count + [across] * (count // 2) + [np.array([0.0, 0.0, 1.0])] * 4
    steps += [np.array([0.6, 0.2, 0.5])] * 3  # a handrail's slope
    out = []
    for step in steps:
        for _ in range(1000):
            ray = np.array([(rng.uniform(0, W) - W / 2) / F, (rng.uniform(0, H) - H / 2) / F, 1.0])
            a = R.T @ (ray * rng.uniform(1.0, 4.0))
            b = a + step * rng.uniform(0.4, 1.2)
            pa, pb = R @ a, R @ b
            if pb[2] < 0.5:
                continue
            ua = np.array([F * pa[0] / pa[2] + W / 2, F * pa[1] / pa[2] + H / 2])
            ub = np.array([F * pb[0] / pb[2] + W / 2, F * pb[1] / pb[2] + H / 2])
            if all(0 <= p[0] < W and 0 <= p[1] < H for p in (ua, ub)) and np.hypot(*(ub - ua)) > 25:
                out.append([*ua, *ub])
                break
    return np.array(out)


def _angle_mod_90(a: np.ndarray, b: np.ndarray, up: np.ndarray) -> float:
    """Angle between two horizontal directions, modulo 90 deg (deg)."""
    e1 = np.cross(up, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    da = math.atan2(a @ e2, a @ e1) - math.atan2(b @ e2, b @ e1)
    return abs(math.degrees(math.atan2(math.sin(4 * da), math.cos(4 * da)))) / 4.0


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    yaw=st.floats(-math.pi / 2, math.pi / 2),
    pitch=st.floats(-20.0, 20.0),
    roll=st.floats(-8.0, 8.0),
    seed=st.integers(0, 2**16),
)
def test_horizontal_direction_is_the_scene_direction_modulo_90_deg(yaw, pitch, roll, seed):
    rect = _rectification()
    R = _camera_R(roll, pitch)
    up = R @ np.array([0.0, 0.0, 1.0])
    segments = _segments(R, yaw, np.random.default_rng(seed), 10)
    h = horizontal_direction(segments, rect, up, VerticalLinesConfig())
    assert h is not None
    assert abs(h @ up) < 1e-9  # horizontal
    truth = R @ np.array([math.cos(yaw), math.sin(yaw), 0.0])
    assert _angle_mod_90(h, truth, up) < DIRECTION_TOL_DEG


def test_horizontal_direction_needs_agreeing_segments():
    rect = _rectification()
    up = np.array([0.0, -1.0, 0.0])
    assert horizontal_direction(np.empty((0, 4)), rect, up, VerticalLinesConfig()) is None
    # Only vertical segments: no horizontal direction.
    vertical = np.array([[100.0 + 40 * i, 100.0, 100.0 + 40 * i, 300.0] for i in range(8)])
    assert horizontal_direction(vertical, rect, up, VerticalLinesConfig()) is None


def _one_ended_riser(rng: np.random.Generator):
    """A head-on painted riser (a band of rows below the horizon, 1.4 m away) whose left
    end is in view and whose right end leaves the image, above and below it horizontal
    grain (no vertical edge), left of it a textured wall at another depth. The matcher's
    disparity is exact on the textured wall and at the riser's end, noise on the riser.
    Returns the left image, that disparity, the riser's mask and its true disparity."""
    rect = _rectification()
    img = np.empty((H, W), np.float32)
    rows = np.arange(H)[:, None]
    img[:] = 90.0 + 30.0 * np.sin(rows / 1.7)  # horizontal grain
    top, bottom, left = 330, 400, 150
    riser = np.zeros((H, W), bool)
    riser[top:bottom, left:] = True
    img[riser] = 200.0
    wall = np.zeros((H, W), bool)
    wall[:, :left] = True
    img[:, :left] = rng.uniform(20.0, 160.0, (H, left))  # texture with vertical edges
    img = np.clip(img + rng.normal(0.0, 0.5, img.shape), 0, 255).astype(np.uint8)
    d_riser = F * B / 1.4 - rect.doffs_px
    truth = np.full((H, W), d_riser, np.float32)
    disparity = rng.uniform(0.0, 60.0, (H, W)).astype(np.float32)  # noise where nothing matches
    disparity[wall] = 14.0  # the wall, farther
    disparity[top:bottom, left - 6 : left + 6] = d_riser  # the riser's end, in front
    return rect, img, disparity, riser, truth


def _both_fills(img, disparity, rect, **kw):
    """The planar fill's output and mask, then the Manhattan fill's, for a head-on scene
    (up = -y, the riser's horizontal lines along x)."""
    config = PlanarFillConfig()
    regions = find_flat_regions(img, config)
    planar, planar_mask = fill_planar_regions(disparity, img, config, regions=regions)
    up, along = np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0])
    out, mask = fill_manhattan_faces(
        disparity, planar, planar_mask, regions, img, rect, up, along, config, **kw
    )
    return planar_mask, out, mask


def test_a_riser_with_one_end_in_view_takes_its_plane_from_that_end():
    rng = np.random.default_rng(3)
    rect, img, disparity, riser, truth = _one_ended_riser(rng)
    planar_mask, out, mask = _both_fills(img, disparity, rect, max_disparity_px=64)
    # The free plane cannot be fitted from one vertical segment: the riser is left as noise.
    assert planar_mask[riser].mean() < 0.1
    inner = riser.copy()
    inner[:, : 150 + 10] = False
    assert mask[inner].mean() > 0.9
    err = np.abs(out - truth)[inner & mask]
    assert np.max(err) < FILL_TOL_PX
    # Nothing else is touched: the textured wall keeps the matcher's values.
    assert not mask[:, :140].any()
    assert np.array_equal(out[:, :140], disparity[:, :140])


def test_without_a_horizontal_outline_the_face_is_left_alone():
    """A face whose outline has no non-vertical edge (a uniform face over every row, one end
    in view) could be of either vertical family: it is not filled."""
    rng = np.random.default_rng(4)
    rect, img, disparity, _, _ = _one_ended_riser(rng)
    img[:, 150:] = np.clip(200 + rng.normal(0.0, 0.5, (H, W - 150)), 0, 255).astype(np.uint8)
    disparity[:, 144:156] = disparity[335, 150]
    planar_mask, _, mask = _both_fills(img, disparity, rect)
    assert not planar_mask[:, 200:].any()
    assert np.array_equal(mask, planar_mask)


@pytest.mark.parametrize(
    "kw",
    [
        {"manhattan_max_planes": 0},
        {"manhattan_min_support": 2},
        {"manhattan_edge_deg": 0.0},
        {"manhattan_reach_px": -1},
    ],
)
def test_bad_manhattan_config_raises(kw):
    with pytest.raises(ConfigError):
        PlanarFillConfig(**kw)


@pytest.mark.parametrize("kw", [{"horizontal_scale": 0.0}, {"horizontal_window_deg": 50.0}])
def test_bad_horizontal_config_raises(kw):
    with pytest.raises(ConfigError):
        VerticalLinesConfig(**kw)


def test_a_uniform_side_wall_whose_support_is_the_ends_of_steps_is_one_wall():
    """A painted side wall to the right of a staircase's ends: its only support is the
    steps' ends (concave corners, on the wall and on each riser alike). It is one plane of
    the wall's family, never a stack of riser planes at the steps' depths."""
    rect = _rectification()
    f, cx, cy = rect.focal_px, rect.cx, rect.cy
    rng = np.random.default_rng(5)
    wall_x, cam_h, rise, run, first = 0.5, 0.5, 0.17, 0.3, 1.2  # metres
    depths = [first + i * run for i in range(4)]
    boundary = np.full(H, -1.0)  # the wall's left edge in each row
    for i, z in enumerate(depths):  # riser i's end: a vertical segment on the wall
        top = cy + f * (cam_h - (i + 1) * rise) / z
        bottom = cy + f * (cam_h - i * rise) / z
        rows = np.arange(max(0, int(np.ceil(top))), min(H, int(bottom) + 1))
        boundary[rows] = cx + f * wall_x / z
    boundary[: int(np.argmax(boundary >= 0))] = boundary[boundary >= 0][0]
    boundary[boundary < 0] = cx + f * wall_x / depths[0]
    cols = np.arange(W)[None, :]
    wall = cols > boundary[:, None] + 0.5
    img = rng.uniform(20.0, 120.0, (H, W)).astype(np.float32)  # textured steps
    img[wall] = 180.0
    img = np.clip(img + rng.normal(0.0, 0.5, img.shape), 0, 255).astype(np.uint8)
    truth = (B * (cols - cx) / wall_x).astype(np.float32) * np.ones((H, 1), np.float32)
    disparity = rng.uniform(0.0, 60.0, (H, W)).astype(np.float32)
    band = np.abs(cols - boundary[:, None]) <= 8
    disparity[band] = truth[band]  # the steps' ends: right on the wall (and the risers)
    config = PlanarFillConfig()
    regions = find_flat_regions(img, config)
    planar, planar_mask = fill_planar_regions(disparity, img, config, regions=regions)
    up, along = np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0])  # risers along x
    out, mask = fill_manhattan_faces(
        disparity, planar, planar_mask, regions, img, rect, up, along, config, max_disparity_px=96
    )
    new = mask & ~planar_mask & wall
    assert new.sum() > 1000  # the wall is filled ...
    assert np.max(np.abs(out - truth)[new]) < FILL_TOL_PX  # ... as the wall


def test_risers_of_one_shade_merged_into_one_region_are_split_at_their_ends():
    """Head-on risers above the cameras, painted alike, are one region (each riser's foot
    hides behind the nosing below it); their ends on a side wall are vertical segments at
    three depths. Each riser takes its own plane, split at its end's rows."""
    rect = _rectification()
    f, cx, cy = rect.focal_px, rect.cx, rect.cy
    rng = np.random.default_rng(6)
    wall_x, rise, run, first = 0.4, 0.17, 0.3, 1.2  # metres; the cameras at the floor
    depths = [first + i * run for i in range(3)]
    truth = np.full((H, W), np.nan, np.float32)
    risers = np.zeros((H, W), bool)
    boundary = np.full(H, np.nan)
    for i, z in enumerate(depths):  # above the cameras: riser i+1's foot is behind riser i
        top = int(np.ceil(cy - f * (i + 1) * rise / z))
        bottom = int(cy - f * i * rise / z) if i == 0 else int(np.ceil(cy - f * i * rise / depths[i - 1])) - 1
        end = cx + f * wall_x / z
        boundary[top : bottom + 1] = end
        risers[top : bottom + 1, : int(end) + 1] = True  # the far ends leave the image
        truth[top : bottom + 1, : int(end) + 1] = f * B / z
    boundary[np.isnan(boundary)] = cx + f * wall_x / depths[0]
    cols = np.arange(W)[None, :]
    wall = cols > boundary[:, None] + 0.5
    wall_truth = (B * (cols - cx) / wall_x).astype(np.float32) * np.ones((H, 1), np.float32)
    truth = np.where(wall, wall_truth, truth)
    img = rng.uniform(20.0, 120.0, (H, W)).astype(np.float32)  # textured elsewhere
    img[risers] = 150.0
    img[wall] = 90.0
    img = np.clip(img + rng.normal(0.0, 0.5, img.shape), 0, 255).astype(np.uint8)
    disparity = rng.uniform(0.0, 60.0, (H, W)).astype(np.float32)
    band = (np.abs(cols - boundary[:, None]) <= 8) & np.isfinite(truth)
    disparity[band] = truth[band]  # the risers' ends, on the wall
    config = PlanarFillConfig()
    regions = find_flat_regions(img, config)
    planar, planar_mask = fill_planar_regions(disparity, img, config, regions=regions)
    up, along = np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0])
    out, mask = fill_manhattan_faces(
        disparity, planar, planar_mask, regions, img, rect, up, along, config, max_disparity_px=96
    )
    inner = risers & (cols < boundary[:, None] - 12)
    filled_risers = mask & ~planar_mask & inner
    assert filled_risers.sum() > 0.6 * inner.sum()
    err = np.abs(out - truth)[filled_risers]
    assert np.median(err) < FILL_TOL_PX
    assert np.mean(err < 0.5) > 0.75  # one plane for all would be 2-5 px off on two of them


def test_a_face_does_not_take_the_plane_of_a_differently_shaded_neighbour():
    """The neighbour rule: a candidate plane that is a neighbouring face's plane (same
    normal, same distance) is refused when the two are shaded differently (a riser against
    its side wall), allowed when they are shaded alike (one wall split by a door frame)."""
    wall = (np.array([1.0, 0.0, 0.0]), 40.0, 90.0)  # normal, s, grey level
    same_plane = [(40.3, 0.0, 10.0)]
    x, tol = np.array([1.0, 0.0, 0.0]), 1.0
    assert _repeats_a_neighbour(x, same_plane, 150.0, {0}, [wall], tol)
    assert not _repeats_a_neighbour(x, same_plane, 92.0, {0}, [wall], tol)
    assert not _repeats_a_neighbour(np.array([0.0, 0.0, 1.0]), same_plane, 150.0, {0}, [wall], tol)
    assert not _repeats_a_neighbour(x, [(45.0, 0.0, 10.0)], 150.0, {0}, [wall], tol)
    assert not _repeats_a_neighbour(x, same_plane, 150.0, set(), [wall], tol)


def test_planes_that_claim_the_same_lines_at_two_distances_contradict():
    """One face has one plane along each of its horizontal lines: stacked intervals are a
    face's risers; overlapping ones at two distances are no Manhattan face; near-equal
    planes (their disparities within the merge tolerance) are one."""
    stack = [(-30.0, 100.0, 140.0), (-35.0, 150.0, 200.0)]
    assert _stacked(stack, 0.5) == sorted(stack)
    assert _stacked([(-30.0, 100.0, 190.0), (-35.0, 120.0, 200.0)], 0.5) == []
    assert _stacked([(70.0, 66.0, 379.0), (70.3, 74.0, 367.0)], 0.5) == [(70.0, 66.0, 379.0)]
