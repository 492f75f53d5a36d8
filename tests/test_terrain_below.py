"""Steps below a chain that starts above a known floor (terrain/below.py, issue 11), and
without a rig the floor put a rise lower under a first tread taken for it (the pipeline's
floor_a_step_below)."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.frames import Transform
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSet, transform_planes
from stereo_terrain.terrain import (
    STAIRS,
    TerrainConfig,
    build_terrain,
    floor_to_view_bottom,
    nosing_under_floor,
    samples_below_floor,
)

from .rounding import premise
from .test_line_frame import _realistic
from .test_terrain import CAM, _stairs
from .test_terrain_nosings import _lines, _segment


def _without(planes: PlaneSet, *, floor=True, risers=(), treads=()) -> PlaneSet:
    """``planes`` less the floor plane, the riser planes at ``risers`` (positions along x)
    and the tread planes at ``treads`` (heights); their samples stay, in no plane."""

    def dropped(seg) -> bool:
        if seg.kind == HORIZONTAL:
            z = -seg.plane.offset
            return (floor and abs(z) < 1e-6) or any(abs(z - t) < 1e-6 for t in treads)
        return seg.kind == VERTICAL and any(abs(seg.plane.offset - r) < 1e-6 for r in risers)

    keep = tuple(seg for seg in planes.segments if not dropped(seg))
    assert len(keep) == len(planes.segments) - int(floor) - len(risers) - len(treads)
    return dataclasses.replace(planes, segments=keep)


def test_the_first_tread_is_no_floor_when_the_floor_is_known():
    """The first riser and the floor formed no plane: the chain starts from the first tread.
    With a rig the floor is at the origin, so that tread is a step up, its riser at the
    tread's front edge."""
    planes = _without(_stairs(n_steps=4, rise=0.17, run=0.29, distance=1.3), risers=[1.3])
    unknown = build_terrain(planes, floor_known=False)
    # without the floor the tread is taken for the ground: the first step is the second
    assert len(unknown.steps) == 3 and unknown.steps[0].distance_m == pytest.approx(1.59, abs=0.01)
    model = build_terrain(planes, floor_known=True)
    assert model.obstacle == STAIRS and len(model.steps) == 4, model.note
    assert [s.distance_m for s in model.steps] == pytest.approx([1.3, 1.59, 1.88, 2.17], abs=0.01)
    assert [s.top_z_m for s in model.steps] == pytest.approx([0.17, 0.34, 0.51, 0.68], abs=0.01)
    assert model.steps[0].rise_m == pytest.approx(0.17, abs=0.01)
    assert not model.steps[0].rise_inferred  # one step: its rise is the tread's height
    assert model.steps[0].run_m == pytest.approx(0.29, abs=0.01)


def test_two_steps_below_the_chain_split_its_height():
    """Two steps formed no riser and the first tread no plane: the second tread is two
    rises above the floor, the two steps below it split that height and stand a run apart."""
    planes = _without(
        _stairs(n_steps=5, rise=0.16, run=0.28, distance=1.2), risers=[1.2, 1.48], treads=[0.16]
    )
    model = build_terrain(planes, floor_known=True)
    assert len(model.steps) == 5, model.note
    # (the synthetic tread starts 1 cm behind its riser)
    assert [s.distance_m for s in model.steps[:3]] == pytest.approx([1.2, 1.48, 1.76], abs=0.025)
    assert [s.rise_m for s in model.steps[:2]] == pytest.approx([0.16, 0.16], abs=0.01)
    assert model.steps[0].rise_inferred and model.steps[1].rise_inferred
    assert "below the lowest riser plane" in model.note


def test_a_riser_below_the_chain_from_its_samples():
    """No horizontal plane at all below the second riser: the chain starts at that riser's
    foot, and the first riser is found from its samples a run before it."""
    planes = _without(
        _stairs(n_steps=4, rise=0.17, run=0.29, distance=1.3), risers=[1.3], treads=[0.17, 0.34, 0.51, 0.68]
    )
    model = build_terrain(planes, floor_known=True)
    assert len(model.steps) == 4, model.note
    assert model.steps[0].distance_m == pytest.approx(1.3, abs=0.03)
    assert model.steps[0].top_z_m == pytest.approx(0.17, abs=0.02)
    # and its samples removed: nothing shows where it stands, so nothing is added
    samples = planes.samples
    keep = ~((np.abs(samples.points[:, 0] - 1.3) < 0.02) & (samples.points[:, 2] < 0.17))
    bare = PlaneSet(
        tuple(dataclasses.replace(s, indices=_reindex(s.indices, keep)) for s in planes.segments),
        dataclasses.replace(samples, **_subset(samples, keep)),
        planes.up,
        planes.stop_reason,
        planes.camera_position,
    )
    assert len(build_terrain(bare, floor_known=True).steps) == 3


def _reindex(indices: np.ndarray, keep: np.ndarray) -> np.ndarray:
    new = np.cumsum(keep) - 1
    return new[indices[keep[indices]]]


def _subset(samples, keep: np.ndarray) -> dict:
    n = len(keep)
    return {
        f.name: getattr(samples, f.name)[keep]
        for f in dataclasses.fields(samples)
        if isinstance(getattr(samples, f.name), np.ndarray) and getattr(samples, f.name).shape[:1] == (n,)
    }


def test_a_raised_floor_before_the_stairs_is_no_step_a_run_before_them():
    """A platform a step high that reaches a metre before the stairs is not the tread of a
    step below them: its front edge is no run before the first riser."""
    planes = _without(_stairs(n_steps=3, rise=0.17, run=0.29, distance=1.3), risers=[1.3])
    # the first tread made 1.2 m deep toward the robot
    pts = planes.samples.points.copy()
    tread = next(s for s in planes.segments if s.kind == HORIZONTAL and abs(s.plane.offset + 0.17) < 1e-6)
    on = tread.indices
    pts[on, 0] = 0.39 + (pts[on, 0] - 1.31) * (1.2 / 0.27)
    planes = dataclasses.replace(planes, samples=dataclasses.replace(planes.samples, points=pts))
    model = build_terrain(planes, floor_known=True)
    assert model.steps and model.steps[0].distance_m == pytest.approx(1.59, abs=0.01), model.note
    # (what refuses it: a stair's run is at most continue_max_run_m)
    wide = build_terrain(planes, TerrainConfig(continue_max_run_m=1.5), floor_known=True)
    assert wide.steps[0].distance_m == pytest.approx(0.39, abs=0.02), wide.note


@settings(max_examples=15, deadline=None)
@given(
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.24, 0.36),
    distance=st.floats(0.9, 1.8),
    n_steps=st.integers(2, 5),
)
def test_a_first_step_without_riser_or_floor_is_found_where_its_tread_starts(rise, run, distance, n_steps):
    planes = _without(_stairs(n_steps=n_steps, rise=rise, run=run, distance=distance), risers=[distance])
    model = build_terrain(planes, floor_known=True)
    assert len(model.steps) == n_steps, model.note
    assert model.steps[0].distance_m == pytest.approx(distance, abs=0.02)
    assert model.steps[0].rise_m == pytest.approx(rise, abs=0.01)
    assert [s.top_z_m for s in model.steps] == pytest.approx(
        [rise * (k + 1) for k in range(n_steps)], abs=0.02
    )


def test_off_without_steps_below():
    planes = _without(_stairs(n_steps=4), risers=[1.3])
    model = build_terrain(planes, TerrainConfig(max_steps_below_chain=0), floor_known=True)
    assert len(model.steps) == 3


def _on_first_tread(planes: PlaneSet, rise: float) -> PlaneSet:
    """``planes`` without the floor's and the first riser's planes (their samples stay, in
    none), in a frame whose floor is the first tread: as a frame without a rig puts its
    origin where the floor before the stairs formed no plane."""
    first = min(s.plane.offset for s in planes.segments if s.kind == VERTICAL)
    dropped = _without(planes, risers=[first])
    shift = Transform.from_rt(np.eye(3), [0.0, 0.0, -rise], dropped.frame, dropped.frame)
    return transform_planes(dropped, shift)


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(2, 5),
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.24, 0.36),
    yaw_deg=st.floats(-40.0, 40.0),
    distance=st.floats(1.0, 1.8),
)
def test_a_first_tread_taken_for_the_floor_has_its_riser_under_it(n, rise, run, yaw_deg, distance):
    """A floor has nothing under it; a first tread taken for the floor has its riser's
    samples under it, in front of the chain (``samples_below_floor``), a riser's worth."""
    config = TerrainConfig()
    full = _stairs(n_steps=n, rise=rise, run=run, yaw=np.radians(yaw_deg), distance=distance)
    model = build_terrain(full, config, floor_known=True)
    assert len(model.steps) == n
    assert samples_below_floor(full, model, config)[0] == 0
    on_tread = _on_first_tread(full, rise)
    late = build_terrain(on_tread, config, floor_known=True)
    assert late.obstacle != "none" and len(late.steps) == n - 1
    count, position = samples_below_floor(on_tread, late, config)
    assert count >= config.min_riser_points
    # the first riser's samples (and the floor's before it), a run or more in front of the chain
    assert late.steps[0].axis_position_m - position >= config.min_run_m


def test_without_a_rig_a_staircase_on_its_first_tread_is_found_again_a_rise_lower():
    """Realistic render 54 of seed 41 without a rig (six steps of 19.5 cm, no floor plane
    before them): the lowest horizontal plane is the first tread, and the chain counted
    five steps from the second riser. The first riser's samples under that "floor" put
    it a rise lower (``PipelineConfig.floor_a_step_below``): six steps, the first where
    the truth has it."""
    scene = _realistic(54, seed=41)
    truth = scene.truth["steps"]
    assert len(truth) == 6
    config = PipelineConfig()
    result = Pipeline(scene.calibration, None, config, warm_up=False).run(scene.left, scene.right)
    assert result.gravity_source == "scene"
    assert "floor_a_step_below" in result.terrain.note and "floor_below" in result.timing_ms
    assert len(result.terrain.steps) == 6
    assert result.terrain.steps[0].distance_m == pytest.approx(truth[0]["distance"], abs=0.08)
    assert [s.rise_m for s in result.terrain.steps] == pytest.approx([truth[0]["rise"]] * 6, abs=0.015)
    off = dataclasses.replace(config, floor_a_step_below=False)
    before = Pipeline(scene.calibration, None, off, warm_up=False).run(scene.left, scene.right)
    assert len(before.terrain.steps) == 5
    assert "floor_below" not in before.timing_ms


def test_without_a_floor_plane_a_staircase_on_its_first_tread_is_found_again_a_rise_lower():
    """Realistic render 32 of seed 41 without a rig (five steps of 16.9 cm, the first riser
    0.95 m ahead of a level camera 0.4 m up): the view's bottom falls on the first tread, no
    floor plane is found below the cameras, and the chain counted three steps from that
    tread. Its first riser's samples under it put it a rise lower too
    (``PipelineConfig.floor_below_floorless``): five steps, the first where the truth has it."""
    scene = _realistic(32, seed=41)
    truth = scene.truth["steps"]
    assert len(truth) == 5
    config = PipelineConfig()
    off = dataclasses.replace(config, floor_below_floorless=False)
    before = Pipeline(scene.calibration, None, off, warm_up=False).run(scene.left, scene.right)
    premise(
        not before.floor_known and len(before.terrain.steps) == 3,
        "no floor plane is found, and the chain counts three steps from the first tread",
    )
    assert "floor_below" not in before.timing_ms
    result = Pipeline(scene.calibration, None, config, warm_up=False).run(scene.left, scene.right)
    assert "no floor plane found" in result.terrain.note and result.floor_known
    assert len(result.terrain.steps) == 5
    assert result.terrain.steps[0].distance_m == pytest.approx(truth[0]["distance"], abs=0.08)
    assert [s.rise_m for s in result.terrain.steps] == pytest.approx([truth[0]["rise"]] * 5, abs=0.025)


def _rows_by_height(planes: PlaneSet) -> PlaneSet:
    """``planes`` with each sample's image row from its height (a level camera above the
    floor: lower is further down the image, 5 px grid rows)."""
    z = planes.samples.points[:, 2]
    rows = (5 * np.round((400.0 - 300.0 * z) / 5)).astype(np.int32)
    return dataclasses.replace(planes, samples=dataclasses.replace(planes.samples, rows=rows))


@settings(max_examples=15, deadline=None)
@given(n=st.integers(2, 5), rise=st.floats(0.12, 0.21), yaw_deg=st.floats(-40.0, 40.0))
def test_a_floor_runs_to_the_view_bottom_a_first_tread_ends_above_its_riser(n, rise, yaw_deg):
    """``floor_to_view_bottom``: the floor under the cameras is the lowest thing in view; a
    first tread taken for it has its riser on the image rows below it."""
    config = TerrainConfig()
    full = _rows_by_height(_stairs(n_steps=n, rise=rise, yaw=np.radians(yaw_deg)))
    assert floor_to_view_bottom(full, config)
    assert not floor_to_view_bottom(_on_first_tread(full, rise), config)
    no_floor = _without(full)  # no floor plane at all: nothing runs to the bottom
    assert not floor_to_view_bottom(no_floor, config)


def _nosings_and_feet(
    n: int, rise: float, run: float, distance: float, yaw: float, floor_z: float, first=True
):
    """The image's segments of every nosing and riser foot of the staircase of ``_stairs``,
    in a frame whose floor is ``floor_z`` above the true one (the cameras that much lower);
    without the first riser's nosing unless ``first``."""
    height = float(CAM[2]) - floor_z
    blank = _lines(np.empty((0, 4)), height)
    segs = []
    for i in range(n):
        s_i = distance * np.cos(yaw) + i * run
        if first or i > 0:
            segs.append(_segment(blank, s_i, (i + 1) * rise - floor_z, yaw))
        segs.append(_segment(blank, s_i, i * rise - floor_z, yaw))
    return _lines(np.array(segs), height)


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(3, 5),
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.24, 0.36),
    yaw_deg=st.floats(-40.0, 40.0),
    distance=st.floats(1.3, 1.8),  # the first nosing well inside the view's bottom
)
def test_a_first_tread_taken_for_the_floor_has_its_nosing_on_it(n, rise, run, yaw_deg, distance):
    """``nosing_under_floor``: on a first tread taken for the floor, the image's segments
    show its nosing a run in front of the chain; on the true floor they show the first
    riser's foot at the chain, and no nosing a run in front."""
    config = TerrainConfig()
    yaw = np.radians(yaw_deg)
    full = _stairs(n_steps=n, rise=rise, run=run, yaw=yaw, distance=distance)
    model = build_terrain(full, config, floor_known=True)
    assert len(model.steps) == n
    assert not nosing_under_floor(model, _nosings_and_feet(n, rise, run, distance, yaw, 0.0), config)
    late = build_terrain(_on_first_tread(full, rise), config, floor_known=True)
    assert late.obstacle == STAIRS and len(late.steps) == n - 1
    assert nosing_under_floor(late, _nosings_and_feet(n, rise, run, distance, yaw, rise), config)
    # the first nosing not in the image: nothing shows that the floor is a tread
    bare = _nosings_and_feet(n, rise, run, distance, yaw, rise, first=False)
    assert not nosing_under_floor(late, bare, config)


def test_without_a_rig_the_first_treads_nosing_puts_the_floor_a_rise_lower():
    """Realistic render 2 of seed 57 without a rig (five painted steps of 21.3 cm, the
    first riser 0.91 m ahead of a camera 0.43 m up): no floor in view, the first tread
    taken for it, and the first riser's strip under its nosing holds no samples. The
    nosing itself, a dark strip across the staircase a run in front of the chain, puts
    the floor a rise lower (``PipelineConfig.floor_below_nosing``): five steps, the first
    where the truth has it."""
    scene = _realistic(2, seed=57)
    truth = scene.truth["steps"]
    assert len(truth) == 5
    config = PipelineConfig()
    result = Pipeline(scene.calibration, None, config, warm_up=False).run(scene.left, scene.right)
    assert "floor_below_nosing" in result.terrain.note
    assert len(result.terrain.steps) == 5
    assert result.terrain.steps[0].distance_m == pytest.approx(truth[0]["distance"], abs=0.08)
    off = dataclasses.replace(config, floor_below_nosing=False)
    before = Pipeline(scene.calibration, None, off, warm_up=False).run(scene.left, scene.right)
    assert len(before.terrain.steps) == 4
