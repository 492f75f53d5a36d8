"""Issue 11: stairs set in an opening of a wall whose face is flush with the first riser.
The riser and the wall are one plane, as tall as the wall; the riser is the part of it that
stands a step high in the opening (terrain/risers.py ``_riser_beside_wall``)."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSet
from stereo_terrain.terrain import NONE, STAIRS, build_terrain

from .test_terrain import SPACING_M, _stairs

RISE_M, RUN_M, DISTANCE_M = 0.17, 0.29, 1.3


def _with_wall_in_line(full: PlaneSet, lateral: tuple[float, float], height_m: float) -> PlaneSet:
    """``full`` (stairs along x, first riser at ``DISTANCE_M``) with a wall on the first
    riser's plane over ``lateral`` (y, metres), from the floor up to ``height_m``, its
    samples in the first riser's plane segment."""
    ys = np.arange(lateral[0], lateral[1], SPACING_M)
    zs = np.arange(0.01, height_m, SPACING_M)
    g = np.array(np.meshgrid(ys, zs, indexing="ij")).reshape(2, -1).T
    wall = np.column_stack([np.full(len(g), DISTANCE_M), g[:, 0], g[:, 1]]).astype(np.float32)
    s0 = full.samples
    n0, n = len(s0.points), len(s0.points) + len(wall)
    samples = dataclasses.replace(
        s0,
        points=np.vstack([s0.points, wall]),
        normals=np.vstack([s0.normals, np.tile(np.float32([-1.0, 0.0, 0.0]), (len(wall), 1))]),
        sigma_m=np.full(n, 0.005, np.float32),
        rows=np.concatenate([s0.rows, np.full(len(wall), s0.rows[0], np.int32)]),
        cols=np.concatenate([s0.cols, np.full(len(wall), 300, np.int32)]),
        grid_index=np.concatenate([s0.grid_index, np.arange(n0, n, dtype=np.int32)]),
        grid_shape=(s0.grid_shape[0], n),
    )
    segments = []
    for seg in full.segments:
        if seg.kind == VERTICAL and abs(seg.plane.offset - DISTANCE_M) < 1e-6:
            seg = dataclasses.replace(seg, indices=np.concatenate([seg.indices, np.arange(n0, n)]))
        segments.append(seg)
    return dataclasses.replace(full, segments=tuple(segments), samples=samples)


def _no_treads(full: PlaneSet) -> PlaneSet:
    """The treads formed no plane (seen edge-on by a level camera close to the stairs);
    the floor did."""
    keep = tuple(s for s in full.segments if not (s.kind == HORIZONTAL and abs(s.plane.offset) > 1e-9))
    return dataclasses.replace(full, segments=keep)


@settings(max_examples=20, deadline=None)
@given(
    side=st.sampled_from([-1.0, 1.0]),
    wall_width=st.floats(0.4, 1.2),
    wall_height=st.floats(0.7, 2.0),
    n_steps=st.integers(2, 4),
)
def test_a_first_riser_flush_with_a_wall_is_a_step(side, wall_width, wall_height, n_steps):
    """Stairs 1 m wide, their treads no planes, a wall on one side in the first riser's
    plane: every step, the first one measured (not inferred below the others), its rise
    and distance right, its width the opening's."""
    full = _no_treads(_stairs(n_steps=n_steps, rise=RISE_M, run=RUN_M, distance=DISTANCE_M))
    lateral = (0.5, 0.5 + wall_width) if side > 0 else (-0.5 - wall_width, -0.5)
    model = build_terrain(_with_wall_in_line(full, lateral, wall_height), floor_known=True)
    assert model.obstacle == STAIRS and len(model.steps) == n_steps, model.note
    first = model.steps[0]
    assert not first.rise_inferred
    assert first.rise_m == pytest.approx(RISE_M, abs=0.01)
    assert first.distance_m == pytest.approx(DISTANCE_M, abs=1e-6)
    assert first.width_m is None or first.width_m <= 1.05


def test_the_split_needs_the_floor_and_changes_nothing_without_a_wall():
    """The plain staircase is the same with the rule; without a floor of the frame's own
    (no rig, none found) a plane as tall as the wall is not split: the first step is then
    at best inferred below the others (a wall's low band, standing on a landing or in a
    frame without a floor, is not taken for a first riser)."""
    full = _no_treads(_stairs(n_steps=3, rise=RISE_M, run=RUN_M, distance=DISTANCE_M))
    plain = build_terrain(full, floor_known=True)
    assert len(plain.steps) == 3 and not plain.steps[0].rise_inferred
    walled = _with_wall_in_line(full, (0.5, 1.5), 1.5)
    model = build_terrain(walled, floor_known=False)
    assert (
        model.obstacle == NONE or model.steps[0].rise_inferred or model.steps[0].distance_m > DISTANCE_M + 0.1
    )


def test_a_narrow_low_part_of_a_tall_face_is_no_opening():
    """A low part narrower than a staircase (a chair's seat front beside its back, a
    shelf) is not split off as a riser."""
    full = _no_treads(_stairs(n_steps=2, rise=RISE_M, run=RUN_M, distance=DISTANCE_M, width=0.45))
    walled = _with_wall_in_line(full, (0.225, 0.6), 0.8)
    model = build_terrain(walled, floor_known=True)
    measured_first = [s for s in model.steps if not s.rise_inferred and abs(s.distance_m - DISTANCE_M) < 0.05]
    assert not measured_first, model.note


def test_a_lone_low_band_in_line_with_a_wall_needs_the_staircase_behind_it():
    """Split off a taller plane, a riser is a staircase's first step only with the
    staircase behind it: alone and with its top not seen it is as likely a wall's low band
    (a false 34 cm step 1.1 m before far stairs, bench_far_stairs.py scene 9). With its
    tread seen it stays."""
    alone = _with_wall_in_line(
        _no_treads(_stairs(n_steps=1, rise=RISE_M, run=RUN_M, distance=DISTANCE_M)), (0.5, 1.5), 1.2
    )
    assert build_terrain(alone, floor_known=True).obstacle == NONE
    with_tread = _with_wall_in_line(
        _stairs(n_steps=1, rise=RISE_M, run=RUN_M, distance=DISTANCE_M), (0.5, 1.5), 1.2
    )
    model = build_terrain(with_tread, floor_known=True)
    assert model.obstacle != NONE and model.steps[0].rise_m == pytest.approx(RISE_M, abs=0.01)
