"""The staircase's pitch from its nosings' lines, anchored at its first riser's foot
(terrain/nosings/pitch.py): for a chain that stands on one riser plane."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.msac import Plane
from stereo_terrain.terrain import STAIRS, Step, TerrainConfig, build_terrain
from stereo_terrain.terrain.nosings import pitched_steps
from stereo_terrain.terrain.nosings.pitch import pitch_from_nosings
from stereo_terrain.terrain.nosings.view import StairView, inner_lateral, parallel_segments

from .test_terrain_continuation import _moved_samples
from .test_terrain_nosings import NO_SAMPLES, _lines, _planes, _stair_lines

LATERAL = (-0.5, 0.5)


def _view(segments: np.ndarray, yaw: float = 0.0) -> StairView:
    u = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    lines = _lines(segments)
    segs = parallel_segments(lines, v)
    assert segs is not None
    return StairView(lines, segs, u, v, inner_lateral(LATERAL))


def _first_step(rise: float, distance: float) -> Step:
    u = np.array([1.0, 0.0, 0.0])
    return Step(rise, None, distance, 1.0, rise, distance, Plane(-u, distance), None)


def test_the_pitch_is_the_one_that_puts_the_nosings_on_the_lines():
    rise, run, distance = 0.17, 0.29, 1.3
    pitch = pitch_from_nosings(_view(_stair_lines(5, rise, run, distance)), distance, 0.0, TerrainConfig())
    assert pitch is not None and pitch.nosings == 5
    assert pitch.rise_m == pytest.approx(rise, abs=0.004)
    assert pitch.run_m == pytest.approx(run, abs=0.01)
    # Looked for near a chain's own rise and run: found near the truth, none far from it.
    view = _view(_stair_lines(5, rise, run, distance))
    near = pitch_from_nosings(view, distance, 0.0, TerrainConfig(), near=(0.15, 0.3))
    assert near is not None and near.rise_m == pytest.approx(rise, abs=0.004)
    assert pitch_from_nosings(view, distance, 0.0, TerrainConfig(), near=(0.28, 0.3)) is None
    # Two nosings are not a pitch; nor lines that start elsewhere than the first nosing.
    assert (
        pitch_from_nosings(_view(_stair_lines(2, rise, run, distance)), distance, 0.0, TerrainConfig())
        is None
    )
    later = _stair_lines(5, rise, run, distance)[4:]  # from the third step's nosing on
    assert pitch_from_nosings(_view(later), distance, 0.0, TerrainConfig()) is None


def test_lines_without_the_risers_feet_behind_them_are_no_pitch():
    """Cameras above the treads see each riser's foot behind the nosing before it: a set
    of lines on a pitch without them (plank joints, grain) is not a staircase's."""
    rise, run, distance, height = 0.15, 0.30, 2.0, 0.9
    u, v = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    for feet, found in ((True, 5), (False, 0)):
        lines = _lines(_stair_lines(5, rise, run, distance, feet=feet, height=height), height)
        view = StairView(lines, parallel_segments(lines, v), u, v, inner_lateral(LATERAL))
        pitch = pitch_from_nosings(view, distance, 0.0, TerrainConfig())
        assert (0 if pitch is None else pitch.nosings) == found


@settings(max_examples=25, deadline=None)
@given(
    yaw=st.floats(-0.6, 0.6),
    rise=st.floats(0.12, 0.2),
    run=st.floats(0.24, 0.36),
    distance=st.floats(1.2, 1.8),  # nearer, the first nosing leaves the view (cameras 0.6 m up)
)
def test_a_pitch_found_is_the_staircases(yaw, rise, run, distance):
    """Where the lines give a pitch, it is the staircase's; where they fit another rise
    nearly as well (a short staircase's nosing and foot lines are a lattice), none."""
    lines = _stair_lines(4, rise, run, distance, yaw)
    a0 = distance * np.cos(yaw)
    pitch = pitch_from_nosings(_view(lines, yaw), a0, 0.0, TerrainConfig())
    if pitch is not None:
        assert pitch.nosings >= 3
        assert pitch.rise_m == pytest.approx(rise, abs=0.006)
        assert pitch.run_m == pytest.approx(run, abs=0.02)


def test_a_one_riser_chain_is_rebuilt_on_the_pitch_where_its_rise_agrees():
    rise, run, distance = 0.17, 0.29, 1.3
    u, v = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    lines = _lines(_stair_lines(5, rise, run, distance))
    planes = _planes(5, rise, run, distance, missing=4)  # the samples of the steps beyond: none
    samples = (planes, planes.samples.points.astype(np.float64))
    # The riser's top edge measured 4 cm high: the pitch still puts its steps on the nosings.
    steps, n = pitched_steps(
        [_first_step(0.21, distance)], *samples, u, v, LATERAL, 0.0, lines, TerrainConfig()
    )
    assert n == 4 and len(steps) == 5
    for k, s in enumerate(steps):
        assert s.axis_position_m == pytest.approx(distance + k * run, abs=0.02)
        assert s.rise_m == pytest.approx(rise, abs=0.004)
        assert s.top_z_m == pytest.approx((k + 1) * rise, abs=0.02)
    assert steps[0].measured_rise_m == 0.21 and not steps[0].rise_inferred
    assert all(s.rise_inferred and s.position_inferred for s in steps[1:])
    assert steps[-1].run_m is None and steps[0].run_m == pytest.approx(run, abs=0.01)
    # A rise more than half again the pitch's is another staircase's: left alone.
    first = _first_step(0.27, distance)
    assert pitched_steps([first], *samples, u, v, LATERAL, 0.0, lines, TerrainConfig()) == ([first], 0)
    # Nor with fewer nosings shown than the chain has steps.
    few = _lines(_stair_lines(3, rise, run, distance))
    chain = [_first_step(0.17, distance)] * 4
    assert pitched_steps(chain, *samples, u, v, LATERAL, 0.0, few, TerrainConfig()) == (chain, 0)


def test_a_staircase_of_one_riser_plane_with_a_high_top_is_counted_from_its_nosings():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _planes(5, rise, run, distance, missing=4)
    # The first tread's samples 4 cm high: its measured rise is 21 cm.
    tread = [s for s in planes.segments if s.kind == "horizontal" and abs(s.plane.offset + rise) < 0.01]
    assert len(tread) == 1
    mask = np.zeros(len(planes.samples.points), dtype=bool)
    mask[tread[0].indices] = True
    high = _moved_samples(planes, mask, np.array([0.0, 0.0, 0.04]))
    lines = _lines(_stair_lines(5, rise, run, distance))
    model = build_terrain(high, NO_SAMPLES, lines=lines)
    assert model.obstacle == STAIRS and len(model.steps) == 5
    assert "the image's nosings show the staircase's pitch" in model.note
    for k, s in enumerate(model.steps):
        assert s.distance_m == pytest.approx(distance + k * run, abs=0.02)
    off = build_terrain(high, TerrainConfig(continue_steps=False, nosing_steps=False), lines=lines)
    assert "pitch" not in off.note and len(off.steps) < 5


def test_a_chain_of_several_risers_on_the_pitch_gains_the_nosings_beyond():
    rise, run, distance = 0.17, 0.29, 1.3
    u, v = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    lines = _lines(_stair_lines(5, rise, run, distance))
    planes = _planes(5, rise, run, distance, missing=3)
    samples = (planes, planes.samples.points.astype(np.float64))

    def step(i: int, shift: float = 0.0) -> Step:
        a = distance + i * run + shift
        return Step(rise, run, a, 1.0, (i + 1) * rise, a, Plane(-u, a), None)

    chain = [step(0), step(1)]
    steps, n = pitched_steps(chain, *samples, u, v, LATERAL, 0.0, lines, TerrainConfig())
    assert n == 3 and steps[:2] == [chain[0], dataclasses.replace(chain[1], run_m=steps[1].run_m)]
    for k, s in enumerate(steps):
        assert s.axis_position_m == pytest.approx(distance + k * run, abs=0.02)
    assert all(s.position_inferred for s in steps[2:])
    # A second riser half a run off the pitch is another staircase's: left alone.
    off = [step(0), step(1, shift=0.5 * run)]
    assert pitched_steps(off, *samples, u, v, LATERAL, 0.0, lines, TerrainConfig()) == (off, 0)
