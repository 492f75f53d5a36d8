"""Issue 11, the step count on realistic stairs: where the first step stands when the floor
before it formed no plane, or when a strip of that floor was fitted as a vertical plane.
Each rule on hand-made planes (the realistic renderer's scenes it fixed are in
docs/benchmarks.md)."""

import dataclasses

import numpy as np
import pytest

from stereo_terrain.msac import Plane
from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSegment, PlaneSet
from stereo_terrain.terrain import STAIRS, build_terrain

from .test_terrain import MID_ROW, SPACING_M, _stairs

RISE_M = 0.17


def _foot_in_view(full: PlaneSet) -> PlaneSet:
    """``full`` with one floor sample at the image's bottom row: the risers' feet (mid-image)
    are in view."""
    rows = full.samples.rows.copy()
    ground = next(s for s in full.segments if s.kind == HORIZONTAL and abs(s.plane.offset) < 1e-9)
    rows[ground.indices[0]] = 479
    return dataclasses.replace(full, samples=dataclasses.replace(full.samples, rows=rows))


def _with_strip(full: PlaneSet, s_m: float, z_inliers, z_more=()) -> PlaneSet:
    """``full`` with a vertical plane facing the camera at ``s_m`` along the x axis, 1 m
    wide: a segment of samples at the heights ``z_inliers`` and samples on the same plane
    but in no segment at ``z_more``."""
    lat = np.arange(-0.5, 0.5, SPACING_M)
    rows = []
    for zs in (z_inliers, z_more):
        z = np.asarray(zs, dtype=float)
        g = np.array(np.meshgrid(lat, z, indexing="ij")).reshape(2, -1).T
        rows.append(np.column_stack([np.full(len(g), s_m), g[:, 0], g[:, 1]]))
    extra = np.vstack(rows)
    s0 = full.samples
    n0, n = len(s0.points), len(s0.points) + len(extra)
    nrm = np.tile(np.float32([-1.0, 0.0, 0.0]), (len(extra), 1))
    samples = dataclasses.replace(
        s0,
        points=np.vstack([s0.points, extra]).astype(np.float32),
        normals=np.vstack([s0.normals, nrm]),
        sigma_m=np.full(n, 0.005, np.float32),
        rows=np.concatenate([s0.rows, np.full(len(extra), MID_ROW * 5, np.int32)]),
        cols=np.concatenate([s0.cols, np.full(len(extra), 300, np.int32)]),
        grid_index=np.concatenate([s0.grid_index, np.full(len(extra), MID_ROW * s0.grid_shape[1], np.int32)]),
    )
    strip = PlaneSegment(Plane([-1.0, 0.0, 0.0], s_m), VERTICAL, np.arange(n0, n0 + len(rows[0])), 0.0)
    return dataclasses.replace(full, segments=(*full.segments, strip), samples=samples)


def _without_floor_plane(full: PlaneSet) -> PlaneSet:
    """The floor's samples are there but formed no plane (a texture-poor floor)."""
    keep = tuple(s for s in full.segments if not (s.kind == HORIZONTAL and abs(s.plane.offset) < 1e-9))
    return dataclasses.replace(full, segments=keep)


def test_a_first_riser_whose_top_is_the_lowest_plane_stands_on_the_floor_at_its_foot():
    """The floor formed no plane, so the first tread is the lowest horizontal plane. The
    first riser in front of it, its foot in view, tops out at that level: it is the first
    step, its rise measured from its bottom edge (the floor), not dropped as below the
    ground (issue 11: realistic seed 11 scene 036)."""
    planes = _without_floor_plane(_foot_in_view(_stairs(n_steps=3, rise=RISE_M)))
    model = build_terrain(planes)
    assert model.obstacle == STAIRS and len(model.steps) == 3, model.note
    assert model.ground_z_m == pytest.approx(0.0, abs=0.02)
    for i, s in enumerate(model.steps):
        assert s.rise_m == pytest.approx(RISE_M, abs=0.02)
        assert s.distance_m == pytest.approx(1.3 + 0.29 * i, abs=1e-6)
        assert s.rise_inferred is False


def test_a_strip_of_floor_in_front_of_the_stairs_is_not_a_first_step_cut_off_by_the_image():
    """A strip of the floor fitted as a vertical plane (a few cm either side of the floor),
    in front of stairs whose first riser reaches the image's bottom rows: its top is the
    floor's level, like a first riser's whose foot is out of view and whose tread was taken
    for the ground. But the floor is seen in front of it: it is the ground, not a tread,
    and no step is inferred (issue 11: realistic seed 11 scene 004)."""
    full = _stairs(n_steps=2, rise=RISE_M)
    assert len(build_terrain(full).steps) == 2
    planes = _with_strip(full, 1.0, np.arange(-0.04, 0.021, SPACING_M))
    model = build_terrain(planes)
    assert model.obstacle == STAIRS and len(model.steps) == 2, model.note
    assert not any(s.rise_inferred for s in model.steps)
    assert model.steps[0].distance_m == pytest.approx(1.3, abs=1e-6)


def test_a_vertical_plane_on_the_floor_is_no_step_below_it():
    """The guard of the first rule: a vertical plane in front of the stairs whose samples
    (not only its edge band) lie within a few cm of the floor is a strip of the floor, not
    a riser standing a step below it, even where the samples on its plane reach lower."""
    full = _foot_in_view(_stairs(n_steps=2, rise=RISE_M))
    planes = _with_strip(full, 0.85, [-0.01, 0.01], np.arange(-0.07, -0.02, SPACING_M))
    model = build_terrain(planes)
    assert model.obstacle == STAIRS and len(model.steps) == 2, model.note
    assert model.ground_z_m == pytest.approx(0.0, abs=0.02)


def test_with_the_floor_known_a_riser_on_it_is_a_step_when_only_its_tread_formed_a_plane():
    """A rig puts the frame's origin on the floor. Where the floor before a step formed no
    plane and its tread did, that tread is the lowest horizontal plane; with nothing
    chained beyond it, it was taken for the ground and the step was lost ("risers found
    but no step rises above the ground": realistic seed 11 scene 008). The riser's foot on
    the floor makes the floor the ground."""
    planes = _without_floor_plane(_stairs(n_steps=1, rise=RISE_M))
    model = build_terrain(planes, floor_known=True)
    assert model.obstacle != "none", model.note
    assert model.ground_z_m == pytest.approx(0.0, abs=1e-9)
    assert model.steps[0].rise_m == pytest.approx(RISE_M, abs=0.01)
    assert model.steps[0].distance_m == pytest.approx(1.3, abs=1e-6)
    # Without a floor of the frame's own (no rig, none found), the lowest plane is the
    # ground: nothing is claimed below it.
    assert build_terrain(planes, floor_known=False).obstacle == "none"
