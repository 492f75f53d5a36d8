"""Steps beyond the last riser plane, found from their samples' positions
(terrain/continuation.py): a far riser whose normals were too noisy to form a plane."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.cloud import GridSample
from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSegment, PlaneSet
from stereo_terrain.terrain import STAIRS, TerrainConfig, build_terrain, estimate_step_sigmas
from stereo_terrain.terrain.continuation import riser_band

from .test_terrain import _stairs
from .test_terrain_clutter import _add_samples

OFF = TerrainConfig(continue_steps=False)
CONFIG = TerrainConfig()


def _last_riser_unplaned(full: PlaneSet, n_steps: int, rise: float, run: float, yaw: float, distance: float):
    """``full`` without the plane segments of its last riser and the landing on it: their
    samples stay in the cloud, taken by no plane (as when their normals were too noisy)."""
    s_last = distance * np.cos(yaw) + (n_steps - 1) * run
    keep = []
    for seg in full.segments:
        d = seg.plane.offset
        last_riser = seg.kind == VERTICAL and abs(d - s_last) < 1e-6
        landing = seg.kind == HORIZONTAL and abs(d + n_steps * rise) < 1e-6
        if not (last_riser or landing):
            keep.append(seg)
    assert len(keep) == len(full.segments) - 2
    return dataclasses.replace(full, segments=tuple(keep))


def _unplaned(n_steps: int, rise=0.17, run=0.29, distance=1.3, yaw=0.0, last: int = 1) -> PlaneSet:
    """``_stairs`` whose ``last`` risers (and the treads on them) formed no plane."""
    planes = _stairs(n_steps=n_steps, rise=rise, run=run, yaw=yaw, distance=distance)
    for k in range(last):
        planes = _last_riser_unplaned(planes, n_steps - k, rise, run, yaw, distance)
    return planes


def _moved_samples(planes: PlaneSet, mask: np.ndarray, shift: np.ndarray) -> PlaneSet:
    pts = planes.samples.points.copy()
    pts[mask] += shift.astype(np.float32)
    return dataclasses.replace(planes, samples=GridSample(**{**planes.samples.__dict__, "points": pts}))


def _leftovers_moved(planes: PlaneSet, dx: float) -> PlaneSet:
    """``planes`` with the samples no plane took moved ``dx`` along the frame's x axis."""
    used = np.zeros(len(planes.samples.points), dtype=bool)
    for seg in planes.segments:
        used[seg.indices] = True
    return _moved_samples(planes, ~used, np.array([dx, 0.0, 0.0]))


def test_a_far_riser_without_a_plane_continues_the_staircase():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _unplaned(4, rise, run, distance)
    before = build_terrain(planes, OFF)
    assert before.obstacle == STAIRS and len(before.steps) == 3
    model = build_terrain(planes)
    assert model.obstacle == STAIRS and len(model.steps) == 4
    last = model.steps[-1]
    assert last.rise_inferred and last.tread is None and last.run_m is None
    assert last.rise_m == pytest.approx(float(np.median([s.rise_m for s in before.steps])), abs=1e-9)
    assert last.distance_m == pytest.approx(distance + 3 * run, abs=0.005)
    assert model.steps[-2].run_m == pytest.approx(run, abs=0.005)
    assert [s.rise_m for s in model.steps[:3]] == [s.rise_m for s in before.steps]
    assert "more beyond the last riser plane" in model.note
    assert len(model.polytope.faces) > len(before.polytope.faces)
    # Its rise's sigma is that of a median of the measured rises, not of its own edges.
    sig = estimate_step_sigmas(model, planes, focal_px=500.0, baseline_m=0.1).steps
    assert all(np.isfinite(s.rise_sigma_m) for s in sig)
    assert sig[-1].rise_sigma_m >= TerrainConfig().min_rise_m / 2


def test_a_band_off_the_steps_spacing_is_not_a_step():
    rise, run, distance = 0.17, 0.29, 1.3
    # The leftover samples (the last riser and the landing) pushed 15 cm further: the band
    # now stands 44 cm behind the last riser plane, 50% more than the steps' run.
    moved = _leftovers_moved(_unplaned(4, rise, run, distance), 0.15)
    assert len(build_terrain(moved).steps) == 3


def test_off_by_config():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _unplaned(4, rise, run, distance)
    assert len(build_terrain(planes, OFF).steps) == 3
    assert len(build_terrain(planes, TerrainConfig(max_continued_steps=0)).steps) == 3
    assert len(build_terrain(_unplaned(2, rise, run, distance), OFF).steps) == 1


def test_one_step_continues_where_ordinary_stairs_put_the_next_riser():
    rise, run, distance = 0.17, 0.29, 1.3
    # One riser plane, and the next riser's samples beyond it in no plane: no run is known
    # yet, so the next riser is sought 20-45 cm beyond (ordinary stairs).
    model = build_terrain(_unplaned(2, rise, run, distance))
    assert model.obstacle == STAIRS and len(model.steps) == 2
    first, second = model.steps
    assert not first.rise_inferred and second.rise_inferred
    assert first.run_m == pytest.approx(run, abs=0.005)
    assert second.distance_m == pytest.approx(distance + run, abs=0.005)
    assert second.rise_m == pytest.approx(first.rise_m, abs=1e-9)
    # Two unplaned risers: the first found sets the spacing the second is sought at.
    three = build_terrain(_unplaned(3, rise, run, distance, last=2))
    assert len(three.steps) == 3
    assert three.steps[1].run_m == pytest.approx(run, abs=0.005)
    assert three.steps[2].distance_m == pytest.approx(distance + 2 * run, abs=0.005)
    # ... and only there: the third riser's samples 12 cm further (41 cm behind the second,
    # inside the ordinary 20-45 cm but 41% off the 29 cm spacing) are no step.
    planes = _unplaned(3, rise, run, distance, last=2)
    third = np.abs(planes.samples.points[:, 0] - (distance + 2 * run)) < 0.01
    moved = _moved_samples(planes, third, np.array([0.12, 0.0, 0.0]))
    assert len(build_terrain(moved).steps) == 2


def test_a_lone_riser_whose_top_formed_no_plane_is_not_continued():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _unplaned(2, rise, run, distance)
    # Its tread's plane gone too (its samples stay, taken by no plane): a riser alone, any
    # vertical face of a step's height, is too weak a witness of stairs to extend.
    tread = [s for s in planes.segments if s.kind == HORIZONTAL and abs(s.plane.offset + rise) < 1e-6]
    assert len(tread) == 1
    lone = dataclasses.replace(planes, segments=tuple(s for s in planes.segments if s is not tread[0]))
    model = build_terrain(lone)
    assert len(model.steps) == 1 and model.steps[0].tread is None


def _with_unplaned_face(planes: PlaneSet, s: float, z0: float, z1: float, half_width=0.5) -> PlaneSet:
    """``planes`` with a face across the axis at ``s`` from ``z0`` to ``z1`` whose samples
    formed no plane."""
    lat, z = np.meshgrid(np.arange(-half_width, half_width, 0.02), np.arange(z0, z1, 0.02), indexing="xy")
    face = np.stack([np.full(lat.size, s), lat.ravel(), z.ravel()], axis=1)
    samples, _ = _add_samples(planes, face, np.array([-1.0, 0.0, 0.0]))
    return dataclasses.replace(planes, samples=samples)


@pytest.mark.parametrize(
    "scene",
    [
        # a cabinet's front standing on the floor 10 cm behind a 25 cm deep box
        lambda: _with_unplaned_face(_stairs(n_steps=1, rise=0.2, box_depth=0.25), 1.3 + 0.35, 0.01, 0.9),
        # a door on the landing of a single step, from the landing up to 2 m
        lambda: _with_unplaned_face(_stairs(n_steps=1, rise=0.17, landing=1.0), 1.3 + 0.35, 0.18, 2.0),
        # a 12 cm object on a 60 cm deep box's top, 30 cm behind its front
        lambda: _with_unplaned_face(_stairs(n_steps=1, rise=0.2, box_depth=0.6), 1.3 + 0.30, 0.21, 0.33, 0.2),
    ],
    ids=["cabinet-behind-a-box", "door-on-a-landing", "object-on-a-box"],
)
def test_a_face_that_is_no_riser_does_not_continue_a_single_step(scene):
    """Found in review: each of these became a two-step staircase. A riser stops at the
    tread it stands on and where the next tread starts (the cabinet and the door go on
    below or above), and stands where its tread ends (the object stands on the top)."""
    planes = scene()
    before, model = build_terrain(planes, OFF), build_terrain(planes)
    assert len(model.steps) == 1 and model.obstacle == before.obstacle


def test_one_step_with_a_band_beyond_ordinary_runs_stays_one_step():
    rise, run, distance = 0.17, 0.29, 1.3
    # The leftover riser band pushed 25 cm further: 54 cm beyond the riser plane.
    moved = _leftovers_moved(_unplaned(2, rise, run, distance), 0.25)
    assert len(build_terrain(moved).steps) == 1
    # ... which a config that allows such runs takes.
    wide = TerrainConfig(continue_max_run_m=0.6)
    assert len(build_terrain(moved, wide).steps) == 2


@settings(max_examples=20, deadline=None)
@given(rise=st.floats(0.12, 0.21), run=st.floats(0.22, 0.40), yaw_deg=st.floats(-30.0, 30.0))
def test_one_step_continued_at_its_run(rise, run, yaw_deg):
    yaw, distance = np.radians(yaw_deg), 1.2
    model = build_terrain(_unplaned(2, rise, run, distance, yaw))
    assert len(model.steps) == 2 and model.steps[1].rise_inferred
    assert model.steps[0].run_m == pytest.approx(run, abs=0.01)
    assert model.steps[1].distance_m == pytest.approx(distance + run / np.cos(yaw), abs=0.01)


@pytest.mark.parametrize("bad", [0.0, 1.0, -0.1])
def test_continuation_tolerance_is_checked(bad):
    with pytest.raises(ConfigError, match="continue_run_tolerance"):
        TerrainConfig(continue_run_tolerance=bad)
    with pytest.raises(ConfigError):
        TerrainConfig(max_continued_steps=-1)
    with pytest.raises(ConfigError, match="continue_min_run_m"):
        TerrainConfig(continue_min_run_m=0.5, continue_max_run_m=0.4)
    with pytest.raises(ConfigError, match="continue_min_run_m"):
        TerrainConfig(continue_min_run_m=0.0)


@settings(max_examples=25, deadline=None)
@given(
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.24, 0.34),
    yaw_deg=st.floats(-30.0, 30.0),
    distance=st.floats(1.0, 1.8),
)
def test_the_continued_riser_stands_where_the_stairs_put_it(rise, run, yaw_deg, distance):
    yaw = np.radians(yaw_deg)
    planes = _unplaned(4, rise, run, distance, yaw)
    model = build_terrain(planes)
    assert len(model.steps) == 4 and model.steps[-1].rise_inferred
    # Where the frame's x axis meets the fourth riser.
    assert model.steps[-1].distance_m == pytest.approx(distance + 3 * run / np.cos(yaw), abs=0.01)
    assert model.steps[-1].rise_m == pytest.approx(rise, abs=0.005)


def test_two_far_risers_without_planes_continue_one_after_the_other():
    model = build_terrain(_unplaned(5, last=2))
    assert len(model.steps) == 5
    assert [s.rise_inferred for s in model.steps] == [False, False, False, True, True]
    assert [s.distance_m for s in model.steps[3:]] == pytest.approx(
        [1.3 + 3 * 0.29, 1.3 + 4 * 0.29], abs=0.005
    )
    assert model.steps[3].run_m == pytest.approx(0.29, abs=0.005)


def test_a_step_too_tall_to_climb_is_still_reported():
    """The safety net (build_terrain's retry with max_obstacle_rise_m) runs without the
    continuation: a step continued at the median of tall rises has no top seen, which the
    net refuses, so with the continuation it would hide the tall steps."""
    model = build_terrain(_unplaned(3, rise=0.40))
    off = build_terrain(_unplaned(3, rise=0.40), OFF)
    assert off.obstacle == STAIRS and "taller than a stair rise" in off.note
    assert model.obstacle == STAIRS and "taller than a stair rise" in model.note
    assert [s.rise_m for s in model.steps] == [s.rise_m for s in off.steps]


def test_a_sample_without_a_sigma_does_not_stop_the_continuation():
    planes = _unplaned(4)
    sigma = planes.samples.sigma_m.copy()
    used = np.zeros(len(sigma), dtype=bool)
    for seg in planes.segments:
        used[seg.indices] = True
    sigma[np.flatnonzero(~used)[0]] = np.nan
    samples = GridSample(**{**planes.samples.__dict__, "sigma_m": sigma})
    assert len(build_terrain(dataclasses.replace(planes, samples=samples)).steps) == 4


def test_the_patch_must_be_one_connected_face_in_the_image():
    """The leftover samples scattered over the sample grid, none next to another, form no
    patch: nothing is continued."""
    planes = _unplaned(4)
    used = np.zeros(len(planes.samples.points), dtype=bool)
    for seg in planes.segments:
        used[seg.indices] = True
    gi = planes.samples.grid_index.copy()
    gh, gw = planes.samples.grid_shape
    free = np.flatnonzero(~used)
    # Each leftover sample alone, 4 cells from the next (more than the one-cell gap the
    # patch bridges).
    k = np.arange(len(free))
    per_col = gh // 4
    gi[free] = 4 * (k % per_col) * gw + (4 * (k // per_col)) % gw
    scattered_samples = GridSample(**{**planes.samples.__dict__, "grid_index": gi})
    scattered = dataclasses.replace(planes, samples=scattered_samples)
    assert len(build_terrain(planes).steps) == 4
    assert len(build_terrain(scattered).steps) == 3


def test_the_foot_of_a_wall_where_the_next_riser_would_stand_is_not_a_step():
    """The last tread ends at a wall (a plane too tall for a riser, across the stairs): the
    samples at its foot that the wall's plane left are not a fourth riser."""
    planes = _unplaned(4)
    s3 = 1.3 + 3 * 0.29
    lat, z = np.meshgrid(np.arange(-0.5, 0.5, 0.02), np.arange(0.55, 2.0, 0.02), indexing="ij")
    wall = np.stack([np.full(lat.size, s3), lat.ravel(), z.ravel()], axis=1)
    samples, idx = _add_samples(planes, wall, np.array([-1.0, 0.0, 0.0]))
    segment = PlaneSegment(Plane(np.array([-1.0, 0.0, 0.0]), s3), VERTICAL, idx, 0.0)
    walled = dataclasses.replace(planes, samples=samples, segments=(*planes.segments, segment))
    assert len(build_terrain(planes).steps) == 4
    assert len(build_terrain(walled).steps) == 3


def _face_samples(s_face: float, spread: float, rise: float, seed: int = 0):
    """A riser's face across the axis (the x axis) around ``s_face``, each sample moved by up
    to ``spread`` along it, laid out as one connected patch of the sample grid (lateral
    positions the columns, heights the rows); every sample free, with a 5 cm inlier
    threshold (that of far samples)."""
    rng = np.random.default_rng(seed)
    lat = np.arange(-0.5, 0.5, 0.02)
    z = np.arange(0.01, rise - 0.01, 0.01)
    gw, gh = len(lat), len(z)
    vv, zz = np.meshgrid(lat, z, indexing="xy")  # (gh, gw)
    n = gh * gw
    pts = np.stack([s_face + rng.uniform(-spread, spread, n), vv.ravel(), zz.ravel()], axis=1)
    rows, cols = np.divmod(np.arange(n, dtype=np.int32), gw)
    samples = GridSample(
        points=pts.astype(np.float32),
        normals=np.tile(np.float32([-1.0, 0.0, 0.0]), (n, 1)),
        sigma_m=np.full(n, 0.005, np.float32),
        rows=(5 * rows).astype(np.int32),
        cols=(5 * cols).astype(np.int32),
        grid_index=np.arange(n, dtype=np.int32),
        grid_shape=(gh, gw),
        stride_px=5,
        frame="yaw",
    )
    P = pts.astype(np.float64)
    return samples, P[:, 0], P[:, 1], P[:, 2], np.ones(n, dtype=bool), np.full(n, 0.05)


@settings(max_examples=40, deadline=None)
@given(
    offset=st.floats(-0.08, 0.08),
    spread=st.floats(0.0, 0.04),
    width=st.floats(0.05, 0.2),
    seed=st.integers(0, 1000),
)
def test_a_riser_band_stands_within_the_span_it_was_sought_in(offset, spread, width, seed):
    """Whatever the face's place and spread about the span's near end, the band found is
    at a position within the span (the steps' spacing), or none."""
    rise, lo = 0.17, 2.0
    samples, s_all, v_all, z_all, free, thr = _face_samples(lo + offset, spread, rise, seed)
    found = riser_band(
        free, s_all, v_all, z_all, thr, samples, (lo, lo + width), (0.0, rise), rise, (-0.5, 0.5), CONFIG
    )
    if found is not None:
        assert lo <= found[1] <= lo + width
        assert len(found[0]) >= CONFIG.min_riser_points


def test_the_last_risers_leftovers_short_of_the_span_are_no_next_riser():
    """Realistic render: the last riser's own samples that its plane left out, 1-3 cm
    short of where the steps' spacing puts the next riser. Seeded at their far edge,
    within the span, the patch's median stood short of it and was taken for the next
    riser (landings 5 scenes 7 and 17 with a rig: a step too many)."""
    rise, lo, hi = 0.17, 2.0, 2.15
    short = _face_samples(lo - 0.02, 0.035, rise)
    samples, s_all, v_all, z_all, free, thr = short
    assert np.any((s_all >= lo) & (s_all <= hi)) and np.median(s_all) < lo
    assert (
        riser_band(free, s_all, v_all, z_all, thr, samples, (lo, hi), (0.0, rise), rise, (-0.5, 0.5), CONFIG)
        is None
    )
    # The same face within the span is a riser, at its place.
    samples, s_all, v_all, z_all, free, thr = _face_samples(lo + 0.05, 0.035, rise)
    found = riser_band(
        free, s_all, v_all, z_all, thr, samples, (lo, hi), (0.0, rise), rise, (-0.5, 0.5), CONFIG
    )
    assert found is not None and found[1] == pytest.approx(lo + 0.05, abs=0.01)
