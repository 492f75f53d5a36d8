"""A staircase from its risers' ends alone (terrain/from_ends.py, TerrainConfig.ends_staircase,
the pipeline's staircase_of_ends)."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.msac import Plane
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.terrain import BOX, STAIRS, Polytope, StairModel, Step, TerrainConfig
from stereo_terrain.terrain.from_ends import (
    MIN_SIDE_STEPS,
    EndsProfile,
    _holds,
    _mends_rises,
    _outweighs,
    ends_profile,
)
from stereo_terrain.terrain.nosings.view import VerticalEdges

from .rounding import premise
from .test_line_frame import _realistic

CONFIG = TerrainConfig()


def _staircase_ends(
    n: int,
    rise: float,
    run: float,
    first: float,
    yaw: float,
    sides=(-0.4, 0.5),
    steps=None,
    noise: float = 0.0,
    seed: int = 0,
) -> VerticalEdges:
    """The ends of a straight staircase's risers (terrain frame, floor at z = 0): for each
    step ``k`` (1 the first) in ``steps`` (all ``n`` by default) and each side's lateral
    position in ``sides``, a vertical edge from ``(k - 1) * rise`` to ``k * rise`` at
    ``first + (k - 1) * run`` along the axis ``yaw``; the segments' ends a little inside
    the corners, and ``noise`` metres of it on each coordinate."""
    rng = np.random.default_rng(seed)
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    foot, top = [], []
    for k in steps or range(1, n + 1):
        for b in sides:
            base = (first + (k - 1) * run) * u + b * v
            foot.append(base + [0.0, 0.0, (k - 1) * rise + 0.01])
            top.append(base + [0.0, 0.0, k * rise - 0.005])
    foot_a, top_a = np.array(foot), np.array(top)
    if noise:
        foot_a += rng.normal(0.0, noise, foot_a.shape)
        top_a += rng.normal(0.0, noise, top_a.shape)
    return VerticalEdges(foot_a, top_a)


def _with(edges: VerticalEdges, more: VerticalEdges) -> VerticalEdges:
    return VerticalEdges(np.concatenate([edges.foot, more.foot]), np.concatenate([edges.top, more.top]))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(3, 7),
    rise=st.floats(0.11, 0.22),
    run=st.floats(0.22, 0.38),
    first=st.floats(0.6, 2.2),
    yaw_deg=st.floats(-45.0, 45.0),
    both=st.booleans(),
    seed=st.integers(0, 10_000),
)
def test_the_ends_give_the_staircase_its_pitch(n, rise, run, first, yaw_deg, both, seed):
    sides = (-0.45, 0.55) if both else (0.55,)
    edges = _staircase_ends(n, rise, run, first, math.radians(yaw_deg), sides, noise=0.005, seed=seed)
    profile = ends_profile(edges, 0.0, CONFIG)
    assert profile is not None
    assert profile.steps == n
    assert profile.seen == tuple(range(1, n + 1))
    assert profile.rise_m == pytest.approx(rise, abs=0.01)
    assert profile.run_m == pytest.approx(run, abs=0.02)
    assert profile.first_m == pytest.approx(first, abs=0.03)
    assert math.degrees(abs(math.remainder(profile.yaw_rad - math.radians(yaw_deg), 2 * math.pi))) < 3.0
    if both:
        assert profile.lateral[1] - profile.lateral[0] == pytest.approx(1.0, abs=0.05)


def test_a_first_step_whose_ends_are_hidden_is_counted_below_the_others():
    """The lowest riser's ends out of view (the image's bottom edge): the others' tops are
    2, 3, ... rises above the floor, so the staircase has a step below them."""
    edges = _staircase_ends(6, 0.2, 0.26, 0.95, 0.1, steps=[2, 3, 4, 5, 6])
    profile = ends_profile(edges, 0.0, CONFIG)
    assert profile is not None
    assert profile.steps == 6
    assert profile.seen == (2, 3, 4, 5, 6)
    assert profile.first_m == pytest.approx(0.95, abs=0.01)


@pytest.mark.parametrize(
    "kind",
    ["two steps a side", "scattered across", "too tall", "behind the cameras", "too far turned", "two below"],
)
def test_ends_that_are_no_staircase_side_make_none(kind):
    """A side needs MIN_SIDE_STEPS steps' ends on one line along the axis; ends that fit a
    pitch but stand across the room from each other (a plant pot's side, a chair's leg and
    a shelf's corner, as in the real OAK-D living room) make none, nor door frames, nor
    a pitch met from behind or beyond 60 deg, nor one missing two steps below its ends."""
    rise, run = 0.18, 0.28
    if kind == "two steps a side":
        assert MIN_SIDE_STEPS == 3
        edges = _staircase_ends(2, rise, run, 1.2, 0.0, sides=(-0.4, 0.5))
    elif kind == "scattered across":
        a = _staircase_ends(3, rise, run, 1.2, 0.0, sides=(0.2,), steps=[1, 2])
        b = _staircase_ends(3, rise, run, 1.2, 0.0, sides=(0.95,), steps=[3])
        edges = _with(a, b)
    elif kind == "too tall":
        edges = _staircase_ends(4, 0.6, run, 1.2, 0.0)
    elif kind == "behind the cameras":
        edges = _staircase_ends(4, rise, run, -1.5, 0.0)
    elif kind == "too far turned":
        edges = _staircase_ends(4, rise, run, 1.2, math.radians(75.0))
    else:
        edges = _staircase_ends(5, rise, run, 1.0, 0.0, steps=[3, 4, 5])
    assert ends_profile(edges, 0.0, CONFIG) is None


def test_clutter_beside_a_staircase_leaves_its_pitch():
    """Vertical edges of a room around the staircase (random heights and places) do not
    change its pitch."""
    rng = np.random.default_rng(5)
    stairs = _staircase_ends(5, 0.17, 0.29, 1.3, math.radians(20.0), sides=(0.5,))
    base = np.column_stack([rng.uniform(0.5, 3.5, 25), rng.uniform(-2.0, 2.0, 25), rng.uniform(0.0, 1.5, 25)])
    tall = rng.uniform(0.05, 0.4, 25)
    clutter = VerticalEdges(base, base + np.column_stack([np.zeros(25), np.zeros(25), tall]))
    profile = ends_profile(_with(stairs, clutter), 0.0, CONFIG)
    assert profile is not None
    assert profile.steps == 5
    assert profile.rise_m == pytest.approx(0.17, abs=0.01)
    assert profile.run_m == pytest.approx(0.29, abs=0.02)


def test_no_edges_make_no_profile():
    empty = VerticalEdges(np.empty((0, 3)), np.empty((0, 3)))
    assert ends_profile(empty, 0.0, CONFIG) is None


def test_a_painted_staircase_the_chain_starts_late_is_counted_by_its_ends():
    """Realistic render 48 of seed 57 (six painted steps of 21.8 cm, seen head-on with its
    rig): the matcher holds nothing on the faces and the chain of riser planes starts at the
    fifth riser (two steps); both sides show the ends of risers 2 to 6, a centimetre from
    their places."""
    scene = _realistic(48, seed=57)
    truth = [s["distance"] for s in scene.truth["steps"]]
    assert len(truth) == 6
    config = PipelineConfig()
    result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == STAIRS
    assert len(result.terrain.steps) == 6
    assert "risers' ends both images place" in result.terrain.note
    assert [s.distance_m for s in result.terrain.steps] == pytest.approx(truth, abs=0.03)
    assert [s.rise_m for s in result.terrain.steps] == pytest.approx([0.218] * 6, abs=0.01)
    assert "ends_staircase" in result.timing_ms
    off = dataclasses.replace(config, terrain=dataclasses.replace(config.terrain, ends_staircase=False))
    before = Pipeline(scene.calibration, scene.rig, off, warm_up=False).run(scene.left, scene.right)
    assert len(before.terrain.steps) == 2


def _kept(steps: list, yaw: float = 0.0) -> StairModel:
    return StairModel(
        STAIRS if len(steps) > 1 else BOX, tuple(steps), yaw, 0.0, Polytope(np.empty((0, 3))), "yaw", ""
    )


def _step(a: float, top: float, tread: bool, inferred: bool = False) -> Step:
    u = np.array([1.0, 0.0, 0.0])
    riser = Plane(-u, a)
    return Step(
        top,
        None,
        a,
        1.0,
        top,
        a,
        riser,
        Plane(np.array([0.0, 0.0, 1.0]), -top) if tread else None,
        rise_inferred=inferred,
        position_inferred=inferred,
    )


@pytest.mark.parametrize(
    ("a", "top", "tread", "inferred", "held"),
    [
        (1.38, 0.612, True, False, True),  # the third riser, its tread at 3 rises
        (1.38, 0.556, True, False, False),  # a tread 5.6 cm low is another surface
        (1.38, 0.556, False, False, True),  # a riser's top edge found low: its place alone
        (1.25, 0.556, False, False, False),  # half a run off
        (1.38, 0.612, True, True, False),  # an inferred step measured nothing
        (2.40, 1.02, True, False, False),  # beyond the profile's last step
    ],
)
def test_a_profile_holds_a_riser_the_planes_measured(a, top, tread, inferred, held):
    """Realistic 57 scene 27's profile (three steps of 20.4 cm, 25.8 cm runs from 0.86 m)
    and a result whose one riser is its third (``staircase_from_ends`` asks this)."""
    profile = EndsProfile(0.0, 0.204, 0.258, 0.86, 3, (1, 2, 3), (-0.5, 0.6))
    assert _holds(profile, _kept([_step(a, top, tread, inferred)]), 0.0) is held
    turned = _kept([_step(a, top, tread, inferred)], yaw=math.radians(15.0))
    assert _holds(profile, turned, 0.0) is False


def _measured_steps(tops: list[float], reported: float, first: float = 1.0, run: float = 0.28) -> list[Step]:
    """A result's steps whose treads measured ``tops`` (m above the floor), each riser a
    ``run`` on from ``first``, all reporting the common rise ``reported``."""
    u = np.array([1.0, 0.0, 0.0])
    steps, below = [], 0.0
    for k, top in enumerate(tops):
        a = first + k * run
        steps.append(
            Step(
                reported,
                run,
                a,
                1.0,
                top,
                a,
                Plane(-u, a),
                Plane(np.array([0.0, 0.0, 1.0]), -top),
                measured_rise_m=top - below,
            )
        )
        below = top
    return steps


@pytest.mark.parametrize(
    ("tops", "reported", "ends_rise", "first", "mended"),
    [
        # realistic 57 scene 23 without a rig: measured rises 14.5 and 17.9 cm disagree,
        # the reported 15.9 is 2.2 cm off the ends' 18.1 (truth 18.6)
        ([0.145, 0.324, 0.505], 0.159, 0.181, 1.0, True),
        # the treads lie on the ends' pitch; only the reported rise (from elsewhere) is off
        ([0.18, 0.365, 0.545], 0.155, 0.181, 1.0, True),
        # treads that agree with each other at 17 cm, ends at 15.3 (a side wall's): kept
        ([0.17, 0.34, 0.51], 0.17, 0.153, 1.0, False),
        # rises within 2 cm of the ends': nothing to mend
        ([0.145, 0.324, 0.505], 0.168, 0.181, 1.0, False),
        # the profile starts a riser away from the result's first
        ([0.145, 0.324, 0.505], 0.159, 0.181, 1.28, False),
    ],
)
def test_a_profile_of_as_many_steps_mends_rises_the_treads_do_not_hold(
    tops, reported, ends_rise, first, mended
):
    """``staircase_from_ends`` keeps a profile of as many steps as the result where it
    mends the result's rises (``_mends_rises``)."""
    profile = EndsProfile(0.0, ends_rise, 0.28, first, 3, (1, 2, 3), (-0.5, 0.5))
    assert _mends_rises(profile, _kept(_measured_steps(tops, reported)), 0.0, CONFIG) is mended


def test_a_staircase_whose_rises_its_treads_do_not_agree_on_takes_the_ends_rise():
    """Realistic render 43 of seed 23 (six steps of 20.4 cm, with its rig): the chain's
    measured rises are 24.6, 20.0 and 19.3 cm; the ends of its risers give the staircase's
    rise to half a centimetre, for as many steps from the same first riser (or, where the
    grey levels show all six risers' ends, ``TerrainConfig.plumb_edges``, the chain's side
    profile gives it)."""
    scene = _realistic(43, seed=23)
    truth = [s["rise"] for s in scene.truth["steps"]]
    assert len(truth) == 6
    result = Pipeline(scene.calibration, scene.rig, PipelineConfig(), warm_up=False).run(
        scene.left, scene.right
    )
    assert result.terrain.obstacle == STAIRS
    assert "risers' ends" in result.terrain.note
    assert [s.rise_m for s in result.terrain.steps] == pytest.approx(truth, abs=0.01)


@pytest.mark.parametrize(
    ("kept_steps", "seen", "steps", "outweighs"),
    [
        (3, (1, 2, 3), 3, True),  # its first step's ends seen
        (4, (2, 3, 4), 4, False),  # as many steps, its first inferred: the planes' stays
        (2, (2, 3, 4, 5), 5, True),  # more steps than the planes' staircase
        (1, (1, 2, 3), 3, False),  # a box stays a box (a piano's bench)
    ],
)
def test_a_profile_that_holds_none_of_the_risers_outweighs_a_staircase(kept_steps, seen, steps, outweighs):
    """Where the ends' profile holds none of the planes' measured risers, it replaces their
    staircase (not a box) where it shows its own first step's ends or has more steps."""
    profile = EndsProfile(0.0, 0.18, 0.28, 1.0, steps, seen, (-0.5, 0.5))
    kept = _kept([_step(0.7 + 0.3 * k, 0.2 * (k + 1), True) for k in range(kept_steps)], yaw=0.5)
    assert _holds(profile, kept, 0.0) is False
    assert _outweighs(profile, kept) is outweighs


def test_a_staircase_the_planes_put_off_its_axis_is_found_by_its_ends():
    """Realistic render 35 of seed 23 without a rig (six painted steps of 12.7 cm, 38 deg
    off the cameras' axis): the far planes' staircase is two steps of 27 cm at 31 deg, on
    the other side of the axis; the ends of risers 2 to 5 give all six steps within a
    centimetre of their places and the axis within a degree."""
    scene = _realistic(35, seed=23)
    truth = scene.truth["steps"]
    assert len(truth) == 6
    config = PipelineConfig()
    result = Pipeline(scene.calibration, None, config, warm_up=False).run(scene.left, scene.right)
    terrain = result.terrain
    assert terrain.obstacle == STAIRS
    assert "held none of the ends" in terrain.note
    assert abs(math.degrees(terrain.yaw_rad - scene.truth["yaw"])) < 1.0
    assert [s.distance_m for s in terrain.steps] == pytest.approx([s["distance"] for s in truth], abs=0.03)
    assert [s.rise_m for s in terrain.steps] == pytest.approx([s["rise"] for s in truth], abs=0.01)
    off = dataclasses.replace(config, terrain=dataclasses.replace(config.terrain, ends_over_planes=False))
    before = Pipeline(scene.calibration, None, off, warm_up=False).run(scene.left, scene.right)
    premise(
        len(before.terrain.steps) == 2, "without the ends over the planes, the planes' two steps are kept"
    )


def test_the_top_risers_short_ends_count_its_last_step():
    """Realistic render 47 of seed 41 with its rig (five white steps of 12.8 cm between two
    walls, cameras 0.70 m up): the fifth riser's ends, 3.1 m away, are 20-25 px tall in
    the image; with the segments gravity takes (20 px and more) the ends show four steps,
    with the terrain's shorter ones (``vanishing.terrain_min_length_px``) all five."""
    scene = _realistic(47, seed=41)
    truth = scene.truth["steps"]
    assert len(truth) == 5
    config = PipelineConfig()
    result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    assert "risers' ends both images place" in result.terrain.note
    assert [s.distance_m for s in result.terrain.steps] == pytest.approx(
        [s["distance"] for s in truth], abs=0.03
    )
    long_only = dataclasses.replace(config.vanishing, terrain_min_length_px=config.vanishing.min_length_px)
    before = Pipeline(
        scene.calibration, scene.rig, dataclasses.replace(config, vanishing=long_only), warm_up=False
    )
    assert len(before.run(scene.left, scene.right).terrain.steps) == 4
