"""The stair axis the image's nosings show (terrain/nosings/axis.py)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.msac import Plane
from stereo_terrain.terrain import Step
from stereo_terrain.terrain.nosings import axis_from_nosings

from .test_terrain_nosings import _lines, _segment, _stair_lines

HEIGHT = 0.5


def _steps(n_steps: int, rise: float, run: float, distance: float, yaw: float) -> list[Step]:
    """The chain's steps along ``yaw`` (their positions along that axis)."""
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    out = []
    for i in range(n_steps):
        s = distance * math.cos(yaw) + i * run
        out.append(Step(rise, run, s, 1.0, (i + 1) * rise, s, Plane(-u, s), None))
    return out


@settings(max_examples=40, deadline=None)
@given(
    yaw=st.floats(-40.0, 40.0),
    error=st.floats(1.0, 10.0),
    sign=st.sampled_from([-1.0, 1.0]),
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.22, 0.35),
    distance=st.floats(1.2, 2.2),
    n_steps=st.integers(2, 4),
)
def test_the_nosings_turn_a_wrong_axis_to_theirs(yaw, error, sign, rise, run, distance, n_steps):
    true_yaw = math.radians(yaw)
    segments = _stair_lines(n_steps, rise, run, distance, true_yaw, height=HEIGHT)
    lines = _lines(segments, HEIGHT)
    wrong = true_yaw + sign * math.radians(error)
    found = axis_from_nosings(lines, wrong, _steps(n_steps, rise, run, distance, wrong), (-0.5, 0.5))
    assert found is not None
    assert math.degrees(found - true_yaw) == pytest.approx(0.0, abs=0.3)


def test_an_axis_the_nosings_agree_with_is_kept():
    yaw = math.radians(20.0)
    lines = _lines(_stair_lines(3, 0.17, 0.29, 1.5, yaw, height=HEIGHT), HEIGHT)
    assert axis_from_nosings(lines, yaw, _steps(3, 0.17, 0.29, 1.5, yaw), (-0.5, 0.5)) is None


def test_one_short_segment_does_not_turn_the_axis():
    """A plank joint a few centimetres long across a tread is no witness."""
    yaw, wrong = math.radians(10.0), math.radians(16.0)
    blank = _lines(np.empty((0, 4)), HEIGHT)
    short = _segment(blank, 1.5 * math.cos(yaw), 0.17, yaw, lateral=(-0.05, 0.05))
    assert np.hypot(short[2] - short[0], short[3] - short[1]) >= 20.0  # it votes, alone
    lines = _lines(short[None], HEIGHT)
    assert axis_from_nosings(lines, wrong, _steps(1, 0.17, 0.29, 1.5, wrong), (-0.5, 0.5)) is None


def test_lines_off_the_staircase_do_not_vote():
    """The floor's plank joints in front of the stairs, at another direction, are longer
    in the image than the nosings: they are not on a step's nosing or foot, so the
    nosings' direction wins."""
    true_yaw, wrong = math.radians(-15.0), math.radians(-9.0)
    blank = _lines(np.empty((0, 4)), HEIGHT)
    floor_yaw = math.radians(-3.0)
    floor = [
        _segment(blank, s, 0.0, floor_yaw, lateral=(-1.5, 1.5)) for s in (0.9, 1.0, 1.1)
    ]  # the first riser stands at 1.45 along the axis
    segments = np.vstack([_stair_lines(3, 0.17, 0.29, 1.5, true_yaw, height=HEIGHT), floor])
    lines = _lines(segments, HEIGHT)
    found = axis_from_nosings(lines, wrong, _steps(3, 0.17, 0.29, 1.5, wrong), (-0.5, 0.5))
    assert found is not None
    assert math.degrees(found - true_yaw) == pytest.approx(0.0, abs=0.3)
