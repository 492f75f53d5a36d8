"""Sloped lines (a handrail, a stair's string) left out of the scene's horizontal direction
where the disparity shows them sloped (stereo_terrain.gravity.from_lines.sloped_segments,
``VerticalLinesConfig.horizontal_max_slope_deg``; issue 11)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.gravity import VerticalLinesConfig, horizontal_direction
from stereo_terrain.gravity.from_lines import level_turn_deg, sloped_segments

from .test_manhattan import B, F, H, W, _angle_mod_90, _camera_R, _rectification

#: The default slope above which a segment is left out, degrees.
MAX_SLOPE_DEG = VerticalLinesConfig().horizontal_max_slope_deg


def _project(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Pixel of the world point ``p`` in the level left camera at the origin."""
    c = R @ p
    return np.array([F * c[0] / c[2] + W / 2, F * c[1] / c[2] + H / 2])


def _scene(R: np.ndarray, lines: list[tuple[np.ndarray, np.ndarray]], doffs: float):
    """Image segments of the world segments ``lines`` (start, end) and a disparity map that
    holds each one's exact disparity in a 5-pixel band along it (NaN elsewhere: unmatched).
    Along the image of a 3D line the disparity is an affine function of the position."""
    disparity = np.full((H, W), np.nan, np.float32)
    segments = []
    for a, b in lines:
        ua, ub = _project(R, a), _project(R, b)
        da, db = F * B / (R @ a)[2] - doffs, F * B / (R @ b)[2] - doffs
        n = int(np.ceil(np.hypot(*(ub - ua)))) + 1
        for t in np.linspace(0.0, 1.0, n):
            x, y = ua + t * (ub - ua)
            xi, yi = int(round(x)), int(round(y))
            disparity[max(yi - 2, 0) : yi + 3, max(xi - 2, 0) : xi + 3] = da + t * (db - da)
        segments.append([*ua, *ub])
    return np.array(segments), disparity


@settings(max_examples=80, deadline=None, derandomize=True)
@given(
    slope=st.floats(0.0, 60.0).filter(lambda s: abs(s - MAX_SLOPE_DEG) > 3.0),
    heading=st.floats(-1.2, 1.2),
    distance=st.floats(1.0, 4.0),
    length=st.floats(0.5, 1.5),
    pitch=st.floats(-30.0, 30.0),
    doffs=st.sampled_from([0.0, 8.0, -8.0]),
)
def test_a_segment_is_sloped_where_its_3d_line_rises_more_than_the_limit(
    slope, heading, distance, length, pitch, doffs
):
    # A pitched camera (up is not the image's vertical) and a pair rectified with a
    # principal point shift between its images (disparity = f B / Z - doffs).
    rect = dataclasses.replace(_rectification(), doffs_px=doffs)
    R = _camera_R(0.0, pitch)
    up = R @ np.array([0.0, 0.0, 1.0])
    s = math.radians(slope)
    direction = np.array([-math.sin(heading) * math.cos(s), math.cos(heading) * math.cos(s), math.sin(s)])
    # in front of the camera, on its optical axis
    centre = distance * (R.T @ np.array([0.0, 0.0, 1.0]))
    a, b = centre - 0.5 * length * direction, centre + 0.5 * length * direction
    segments, disparity = _scene(R, [(a, b)], rect.doffs_px)
    sloped = sloped_segments(segments, rect, disparity, up, MAX_SLOPE_DEG)
    assert bool(sloped[0]) == (slope > MAX_SLOPE_DEG)


def test_unmatched_segments_are_not_called_sloped():
    rect = _rectification()
    up = _camera_R(0.0, 0.0) @ np.array([0.0, 0.0, 1.0])
    segments = np.array([[100.0, 300.0, 400.0, 100.0]])
    assert not sloped_segments(segments, rect, np.full((H, W), np.nan, np.float32), up, MAX_SLOPE_DEG)[0]
    assert not sloped_segments(segments, rect, np.zeros((H, W), np.float32), up, MAX_SLOPE_DEG)[0]


def _nosings_and_a_handrail(R: np.ndarray):
    """Eight short nosings (0.5 m, 2-3.1 m away, below the cameras) of a staircase turned
    40 deg and, beside them, four long lines rising 35 deg along its axis (a handrail's
    edges and mouldings, 1.6 m each): segments and the exact disparity along them."""
    yaw = math.radians(40.0)
    along = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    across = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    lines = []
    for k in range(8):
        start = np.array([2.0, -0.1, -0.7]) + 0.18 * k * along + np.array([0.0, 0.0, 0.05 * k])
        lines.append((start, start + 0.5 * across))
    pitch = math.radians(35.0)
    slope = math.cos(pitch) * along + math.sin(pitch) * np.array([0.0, 0.0, 1.0])
    for dz in (0.0, 0.03, 0.06, 0.09):
        start = np.array([1.8, -0.6, -0.2 + dz])
        lines.append((start, start + 1.6 * slope))
    return along, lines


def test_a_long_handrail_no_longer_turns_the_horizontal_direction():
    rect = _rectification()
    R = _camera_R(0.0, 0.0)
    up = R @ np.array([0.0, 0.0, 1.0])
    along, lines = _nosings_and_a_handrail(R)
    segments, disparity = _scene(R, lines, rect.doffs_px)
    truth = R @ along
    config = VerticalLinesConfig()
    blind = horizontal_direction(segments, rect, up, config)
    assert blind is not None and _angle_mod_90(blind, truth, up) > 10.0  # the handrail won
    seen = horizontal_direction(segments, rect, up, config, disparity=disparity)
    assert seen is not None and _angle_mod_90(seen, truth, up) < 1.0
    # The check off: as blind.
    off = VerticalLinesConfig(horizontal_max_slope_deg=0.0)
    again = horizontal_direction(segments, rect, up, off, disparity=disparity)
    assert again is not None and _angle_mod_90(again, blind, up) < 1e-6


@settings(max_examples=60, deadline=None)
@given(heading=st.floats(-math.pi, math.pi), turn=st.floats(-180.0, 180.0))
def test_level_turn_is_the_angle_modulo_90_deg(heading, turn):
    a = np.array([math.cos(heading), math.sin(heading), 0.0])
    t = heading + math.radians(turn)
    b = 2.0 * np.array([math.cos(t), math.sin(t), 0.0])  # any length
    folded = abs(turn) % 90.0
    assert level_turn_deg(a, b) == pytest.approx(min(folded, 90.0 - folded), abs=1e-6)


@pytest.mark.parametrize("bad", [-1.0, 90.0])
def test_max_slope_is_checked(bad):
    with pytest.raises(ConfigError):
        VerticalLinesConfig(horizontal_max_slope_deg=bad)
