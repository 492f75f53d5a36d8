"""A staircase's common rise (terrain/uniform.py) and the least run of a step
(``TerrainConfig.min_run_m``), issue 11."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.terrain import STAIRS, Step, TerrainConfig, build_terrain, estimate_step_sigmas
from stereo_terrain.terrain.sigmas import _STEP_VARIATION_M
from stereo_terrain.terrain.uniform import common_steps

from .test_terrain import _stairs

CONFIG = TerrainConfig()
RISES_ONLY = TerrainConfig(common_run_tolerance_m=0.0)


def common_rise(steps, ground, config=RISES_ONLY):
    """:func:`common_steps` on the rises alone: (steps, rises replaced)."""
    out, n_rises, n_runs, _ = common_steps(steps, ground, config)
    assert n_runs == 0
    return out, n_rises


def _steps(rises, inferred=(), ground=0.0, runs=None) -> list[Step]:
    """Steps of ``rises`` and ``runs`` (0.29 m each, the last not seen, by default)."""
    runs = [0.29] * (len(rises) - 1) + [None] if runs is None else runs
    out, top, s = [], ground, 1.3
    for i, (r, g) in enumerate(zip(rises, runs, strict=True)):
        top += r
        out.append(
            Step(r, g, s, 1.0, top, s, Plane(np.array([-1.0, 0.0, 0.0]), s), rise_inferred=i in inferred)
        )
        s += g or 0.0
    return out


@settings(max_examples=40, deadline=None)
@given(
    rise=st.floats(0.12, 0.21),
    noise=st.lists(st.floats(-0.012, 0.012), min_size=3, max_size=7),
    ground=st.floats(-0.2, 0.2),
)
def test_agreeing_rises_report_their_median(rise, noise, ground):
    measured = [rise + e for e in noise]
    steps, n = common_rise(_steps(measured, ground=ground), ground)
    assert n == len(measured)
    common = float(np.median(measured))
    assert [s.rise_m for s in steps] == pytest.approx([common] * len(measured), abs=1e-12)
    assert [s.measured_rise_m for s in steps] == pytest.approx(measured, abs=1e-12)
    # The treads stand their rises above each other, the first above the ground.
    assert [s.top_z_m for s in steps] == pytest.approx(
        [ground + (k + 1) * common for k in range(len(measured))], abs=1e-9
    )


def test_a_step_that_does_not_agree_keeps_its_own_rise():
    measured = [0.17, 0.175, 0.23, 0.165]  # the third is 6 cm off: a landing, or wrong
    steps, n = common_rise(_steps(measured), 0.0)
    assert n == 3
    common = float(np.median(measured))  # 0.1725: the odd one's pull on a median is small
    assert [s.rise_m for s in steps] == pytest.approx([common, common, 0.23, common])
    assert steps[2].measured_rise_m is None and steps[0].measured_rise_m == pytest.approx(0.17)
    assert steps[-1].top_z_m == pytest.approx(common * 3 + 0.23)


def test_two_steps_or_no_agreeing_majority_are_left_alone():
    two = _steps([0.17, 0.12])
    assert common_rise(two, 0.0) == (two, 0)
    scattered = _steps([0.10, 0.17, 0.24])  # each 7 cm from the median: no two agree with it
    assert common_rise(scattered, 0.0) == (scattered, 0)
    off = TerrainConfig(common_rise_tolerance_m=0.0, common_run_tolerance_m=0.0)
    steps = _steps([0.17, 0.18, 0.16])
    assert common_steps(steps, 0.0, off) == (steps, 0, 0, None)


def test_an_inferred_rise_takes_the_common_rise_and_is_no_measurement():
    measured = [0.17, 0.18, 0.16, 0.15]
    steps, n = common_rise(_steps(measured + [0.16], inferred={4}), 0.0)
    assert n == 4
    assert steps[4].rise_inferred and steps[4].measured_rise_m is None
    assert steps[4].rise_m == pytest.approx(float(np.median(measured)))


def test_the_staircase_reports_one_rise_and_its_sigma_is_a_median_s():
    planes = _stairs(n_steps=4, rise=0.17, run=0.29)
    model = build_terrain(planes)
    assert model.obstacle == STAIRS and len(model.steps) == 4
    assert len({s.rise_m for s in model.steps}) == 1
    assert all(s.measured_rise_m == pytest.approx(0.17, abs=0.01) for s in model.steps)
    assert "measured rises agree" in model.note
    own = build_terrain(planes, TerrainConfig(common_rise_tolerance_m=0.0))
    assert all(s.measured_rise_m is None for s in own.steps)
    sig = estimate_step_sigmas(model, planes, focal_px=500.0, baseline_m=0.1).steps
    sig_own = estimate_step_sigmas(own, planes, focal_px=500.0, baseline_m=0.1).steps
    # A step's true rise may differ from the staircase's by a few millimetres (building
    # codes), so the common rise's sigma is at least that, however well it is measured;
    # here (noise-free faces, own sigmas about a millimetre) it is little more.
    assert all(s.rise_sigma_m >= _STEP_VARIATION_M for s in sig)
    assert all(s.rise_sigma_m < _STEP_VARIATION_M + max(o.rise_sigma_m for o in sig_own) for s in sig)


@pytest.mark.parametrize(
    "bad",
    [
        {"common_rise_tolerance_m": -0.01},
        {"common_min_steps": 1},
        {"common_min_runs": 1},
        {"common_run_tolerance_m": -0.01},
        {"min_run_m": -0.1},
    ],
)
def test_config_is_checked(bad):
    with pytest.raises(ConfigError):
        TerrainConfig(**bad)


def test_a_riser_too_near_the_one_before_is_not_the_next_step():
    """Two faces 10 cm apart along the axis (a plant's leaves, a shelf's edge) are no
    staircase's steps: a step's run is at least ``min_run_m``."""
    planes = _stairs(n_steps=2, rise=0.15, run=0.10)
    near = build_terrain(planes, TerrainConfig(min_run_m=0.05))
    assert len(near.steps) == 2 and near.steps[0].run_m == pytest.approx(0.10, abs=0.01)
    model = build_terrain(planes)
    assert len(model.steps) == 1, model.note  # the first face alone (here a box's front)


@settings(max_examples=40, deadline=None)
# Noise within +-4.9 cm: no run is then more than 9.8 cm from the median, inside the 10 cm
# tolerance (+-6 cm could put one 12 cm off, which rightly keeps its own run). Two runs are
# enough (common_min_runs).
@given(run=st.floats(0.22, 0.36), noise=st.lists(st.floats(-0.049, 0.049), min_size=2, max_size=6))
def test_agreeing_runs_report_their_median_and_the_risers_stay(run, noise):
    runs = [run + e for e in noise] + [None]
    given_steps = _steps([0.17] * len(runs), runs=runs)
    steps, n_rises, n_runs, _ = common_steps(given_steps, 0.0, CONFIG)
    assert n_runs == len(noise) and n_rises == len(runs)
    common = float(np.median(runs[:-1]))
    assert [s.run_m for s in steps[:-1]] == pytest.approx([common] * len(noise), abs=1e-12)
    assert [s.measured_run_m for s in steps[:-1]] == pytest.approx(runs[:-1], abs=1e-12)
    assert steps[-1].run_m is None and steps[-1].measured_run_m is None
    # Where the risers are (their distances and planes) is as measured.
    assert [s.distance_m for s in steps] == [s.distance_m for s in given_steps]
    assert [s.riser for s in steps] == [s.riser for s in given_steps]


def test_a_run_that_does_not_agree_keeps_its_own():
    # the second run is two treads (a riser not found): 10 cm or more off is not averaged
    steps, _, n_runs, _ = common_steps(_steps([0.17] * 5, runs=[0.28, 0.57, 0.29, 0.27, None]), 0.0, CONFIG)
    assert n_runs == 3
    assert [s.run_m for s in steps] == pytest.approx([0.285, 0.57, 0.285, 0.285, None])
    assert steps[1].measured_run_m is None


def test_two_runs_of_a_three_step_staircase_report_their_mean():
    # The lab's stairs: three risers, two runs, 20 cm rises and 31 cm treads. The two runs
    # share the middle riser's error with opposite signs; their mean is half the span from
    # the first riser to the third.
    given_steps = _steps([0.20] * 3, runs=[0.27, 0.35, None])
    steps, _, n_runs, _ = common_steps(given_steps, 0.0, CONFIG)
    assert n_runs == 2
    assert [s.run_m for s in steps] == pytest.approx([0.31, 0.31, None])
    assert [s.measured_run_m for s in steps] == pytest.approx([0.27, 0.35, None])
    assert [s.distance_m for s in steps] == [s.distance_m for s in given_steps]
    # Two runs more than twice the tolerance apart are no common run: each keeps its own.
    apart = _steps([0.20] * 3, runs=[0.24, 0.45, None])
    assert common_steps(apart, 0.0, CONFIG)[2] == 0
    # Three needed (the setting): two runs keep their own.
    three = TerrainConfig(common_min_runs=3)
    assert [s.run_m for s in common_steps(given_steps, 0.0, three)[0]] == pytest.approx([0.27, 0.35, None])


def test_the_staircase_reports_one_run_and_keeps_the_measured_ones():
    planes = _stairs(n_steps=4, rise=0.17, run=0.29)
    model = build_terrain(planes)
    runs = [s.run_m for s in model.steps if s.run_m is not None]
    assert len(runs) == 3 and len(set(runs)) == 1
    assert all(s.measured_run_m == pytest.approx(0.29, abs=0.01) for s in model.steps[:3])
    assert "measured runs agree" in model.note
    sig = estimate_step_sigmas(model, planes, focal_px=500.0, baseline_m=0.1).steps
    assert all(s.run_sigma_m >= _STEP_VARIATION_M for s in sig[:3])


def test_the_swing_clears_the_larger_of_a_steps_common_and_measured_rise():
    """Pooled rises may differ by up to twice the tolerance: a 20 cm step among 17 cm ones
    reports 17 cm, but the swing plan clears its 20 cm (found in review)."""
    from stereo_terrain.swing import plan_swing
    from stereo_terrain.terrain import STAIRS, Polytope, StairModel

    steps, n, _, _ = common_steps(_steps([0.20, 0.17, 0.17, 0.17]), 0.0, CONFIG)
    assert n == 4 and steps[0].rise_m == pytest.approx(0.17)
    model = StairModel(STAIRS, tuple(steps), 0.0, 0.0, Polytope(np.zeros((0, 3))), "yaw", "")
    assert plan_swing(model).step_height_m == pytest.approx(0.20)


def test_a_median_of_rises_without_sigmas_has_no_sigma():
    from stereo_terrain.terrain.sigmas import _median_sigma

    assert math.isnan(_median_sigma([math.nan, math.nan, math.nan], np.array([0.17, 0.17, 0.17])))
    assert math.isnan(_median_sigma([], np.array([])))
    assert _median_sigma([0.01, 0.01, 0.01], np.array([0.17, 0.17, 0.17])) > _STEP_VARIATION_M


def _first_step_unplaned(n_steps=4, rise=0.19, run=0.29, distance=1.3):
    """``_stairs`` whose first riser and first tread formed no plane (their samples stay)."""
    import dataclasses

    from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL

    planes = _stairs(n_steps=n_steps, rise=rise, run=run, distance=distance)
    keep = [
        seg
        for seg in planes.segments
        if not (seg.kind == VERTICAL and abs(seg.plane.offset - distance) < 1e-6)
        and not (seg.kind == HORIZONTAL and abs(seg.plane.offset + rise) < 1e-6)
    ]
    assert len(keep) == len(planes.segments) - 2
    return dataclasses.replace(planes, segments=tuple(keep))


def test_a_chain_above_the_ground_gets_its_first_step_inferred():
    """Realistic stairs whose first riser formed no plane: the riser planes above it chain
    with each other a run apart, a whole rise above the ground (issue 11)."""
    planes = _first_step_unplaned()
    off = build_terrain(planes, TerrainConfig(max_steps_below_chain=0))
    # without it only the too-tall-step safety net takes them: two steps as one of 38 cm
    assert len(off.steps) == 3 and off.steps[0].rise_m == pytest.approx(0.38, abs=0.02), off.note
    model = build_terrain(planes)
    assert model.obstacle == STAIRS and len(model.steps) == 4, model.note
    assert model.steps[0].rise_inferred and not model.steps[1].rise_inferred
    assert model.steps[0].distance_m == pytest.approx(1.3, abs=0.02)
    assert [s.top_z_m for s in model.steps] == pytest.approx([0.19, 0.38, 0.57, 0.76], abs=0.02)
    assert "below the lowest riser plane" in model.note


@settings(max_examples=40, deadline=None)
@given(
    rise=st.floats(0.12, 0.21),
    noise=st.lists(st.floats(-0.005, 0.005), min_size=4, max_size=7),
    at=st.integers(0, 5),
    shift=st.floats(0.04, 0.09),
    down=st.booleans(),
)
def test_one_misplaced_top_between_two_steps_takes_the_common_rise(rise, noise, at, shift, down):
    """The top between steps ``j`` and ``j + 1`` measured ``shift`` too high or too low makes
    one rise longer by as much as the next is shorter: both report the staircase's rise
    (the others' median), keep their own as the measured one, and are named."""
    j = at % (len(noise) - 1)
    shift = -shift if down else shift
    measured = [rise + e for e in noise]
    measured[j] += shift
    measured[j + 1] -= shift
    steps, n, _, pair = common_steps(_steps(measured), 0.0, RISES_ONLY)
    assert n == len(measured) and pair == j
    others = [x for i, x in enumerate(measured) if i not in (j, j + 1)]
    assert all(s.rise_m == pytest.approx(float(np.median(others)), abs=1e-12) for s in steps)
    assert all(abs(s.rise_m - rise) < 0.006 for s in steps)
    assert [s.measured_rise_m for s in steps] == pytest.approx(measured, abs=1e-12)
    assert steps[-1].top_z_m == pytest.approx(len(measured) * steps[0].rise_m, abs=1e-9)


def test_what_is_no_misplaced_top():
    """A single odd rise keeps its own (a landing, a first step on a thicker floor), so do
    two neighbours both too tall (a double step each), a pair whose mean is not the
    staircase's rise, a pair beside a single other rise (nothing tells which is wrong), two
    rises with an inferred step between them (they share no top), and a pair the nosings'
    rise already took."""

    def pair_of(rises, config=RISES_ONLY, inferred=(), **kw):
        steps, _, _, pair = common_steps(_steps(rises, inferred=inferred), 0.0, config, **kw)
        return steps, pair

    steps, pair = pair_of([0.17, 0.17, 0.17, 0.23])
    assert pair is None and steps[3].rise_m == pytest.approx(0.23)
    steps, pair = pair_of([0.17, 0.17, 0.34, 0.34, 0.17])
    assert pair is None and [s.rise_m for s in steps[2:4]] == pytest.approx([0.34, 0.34])
    steps, pair = pair_of([0.17, 0.17, 0.10, 0.30, 0.17])  # the pair's mean 20 cm
    assert pair is None and [s.rise_m for s in steps[2:4]] == pytest.approx([0.10, 0.30])
    for three in ([0.16, 0.10, 0.22], [0.184, 0.139, 0.19], [0.16, 0.14, 0.205]):
        steps, pair = pair_of(three)
        assert pair is None and [s.rise_m for s in steps] == pytest.approx(three)
    two = TerrainConfig(common_min_steps=2, common_run_tolerance_m=0.0)
    steps, pair = pair_of([0.12, 0.22], two)
    assert pair is None and [s.rise_m for s in steps] == pytest.approx([0.12, 0.22])
    steps, pair = pair_of([0.17, 0.10, 0.17, 0.24, 0.17, 0.17], inferred={2})
    assert pair is None and steps[1].rise_m == pytest.approx(0.10) and steps[3].rise_m == pytest.approx(0.24)
    steps, pair = pair_of([0.17, 0.22, 0.22, 0.17], rise_m=0.17, fits=[0, 1, 2, 3])
    assert pair is None and all(s.rise_m == pytest.approx(0.17) for s in steps)
    # Beside a majority that already agreed, and with the nosings' rise: the pair joins it.
    steps, pair = pair_of([0.17, 0.17, 0.11, 0.23, 0.17])
    assert pair == 2 and all(s.rise_m == pytest.approx(0.17) for s in steps)
    steps, pair = pair_of([0.17, 0.11, 0.23, 0.17, 0.17], rise_m=0.172)
    assert pair == 1 and all(s.rise_m == pytest.approx(0.172) for s in steps)


@pytest.mark.parametrize("shift", [0.06, -0.06])
def test_the_note_names_a_misplaced_top(shift):
    """The second step's top (its tread, and the third riser's foot) measured 6 cm high or
    low, its riser stretched to it and the third riser shrunk: the second and third rises
    differ by 12 cm, their mean the others'. All four report the common rise; the
    measured ones stay; the note names the two and counts the two others as agreeing."""
    import dataclasses

    planes = _stairs(n_steps=4, rise=0.17, run=0.29)
    segs = list(planes.segments)
    points = planes.samples.points.copy()
    for i, g in enumerate(segs):
        z = points[g.indices, 2]
        if g.kind == "horizontal" and g.plane.offset == pytest.approx(-0.34):
            points[g.indices, 2] += shift
            segs[i] = dataclasses.replace(g, plane=Plane(np.array([0.0, 0.0, 1.0]), -0.34 - shift))
        elif g.kind == "vertical" and 0.17 < np.median(z) < 0.34:
            points[g.indices, 2] = 0.17 + (z - 0.17) * (0.17 + shift) / 0.17
        elif g.kind == "vertical" and 0.34 < np.median(z) < 0.51:
            points[g.indices, 2] = 0.34 + shift + (z - 0.34) * (0.17 - shift) / 0.17
    samples = dataclasses.replace(planes.samples, points=points)
    model = build_terrain(dataclasses.replace(planes, segments=tuple(segs), samples=samples))
    assert model.obstacle == STAIRS and len(model.steps) == 4, model.note
    measured = [s.measured_rise_m for s in model.steps[1:3]]
    assert measured == pytest.approx([0.17 + shift, 0.17 - shift], abs=0.005)
    assert all(s.rise_m == pytest.approx(0.17, abs=0.005) for s in model.steps)
    assert "; 2 measured rises agree: those steps report their median" in model.note
    assert "steps 2 and 3 measured" in model.note and "the top between them misplaced" in model.note
    assert "misplaced" not in build_terrain(planes).note
