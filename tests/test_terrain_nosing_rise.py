"""A staircase's rise from the heights of the nosings the image's segments show
(terrain/nosings/ ``nosing_heights``, terrain/uniform.py ``rise_from_nosings``;
``TerrainConfig.nosing_rise``), issue 11."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.planes.orientation import HORIZONTAL
from stereo_terrain.terrain import STAIRS, TerrainConfig, build_terrain
from stereo_terrain.terrain.nosings import nosing_heights
from stereo_terrain.terrain.uniform import common_steps, rise_from_nosings

from .test_terrain import _stairs
from .test_terrain_nosings import _lines, _planes, _segment, _stair_lines, _with_pixels
from .test_terrain_uniform import _steps

CONFIG = TerrainConfig()
X, Y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])


def test_the_rise_that_puts_the_nosings_at_their_heights():
    assert rise_from_nosings([0.17, 0.34, 0.51], 0.0, CONFIG) == (pytest.approx(0.17), [0, 1, 2])
    # Through the ground: a nosing not shown is left out; the ground counts.
    assert rise_from_nosings([None, 0.44, 0.61], 0.10, CONFIG) == (pytest.approx(0.17), [1, 2])
    # Measured heights a few millimetres off: the least-squares rise.
    k = np.array([1.0, 2.0, 3.0])
    h = 0.18 * k + np.array([0.004, -0.003, 0.002])
    assert rise_from_nosings(list(h), 0.0, CONFIG)[0] == pytest.approx(float(k @ h / (k @ k)))


def test_nosings_that_do_not_fit_one_staircase_give_no_rise():
    assert rise_from_nosings([0.17], 0.0, CONFIG) is None  # one nosing: nothing checks it
    assert rise_from_nosings([0.17, None], 0.0, CONFIG, lone=True) is None  # two steps
    assert rise_from_nosings([None, None, None], 0.0, CONFIG) is None
    # A double step among them (the third nosing two rises above the second).
    assert rise_from_nosings([0.17, 0.34, 0.68], 0.0, CONFIG) is None
    # A rise no stair has.
    assert rise_from_nosings([0.02, 0.04, 0.06], 0.0, CONFIG) is None
    assert rise_from_nosings([0.40, 0.80], 0.0, CONFIG) is None
    # Without the ground, two nosings fit any rise exactly: three are needed.
    assert rise_from_nosings([0.37, 0.54], None, CONFIG) is None
    assert rise_from_nosings([0.37, 0.54, 0.71], None, CONFIG)[0] == pytest.approx(0.17)
    assert rise_from_nosings([0.17, 0.34, 0.51], 0.0, TerrainConfig(common_rise_tolerance_m=0.0)) is None


@settings(max_examples=60, deadline=None)
@given(
    rise=st.floats(0.10, 0.25),
    ground=st.floats(-0.5, 0.5),
    noise=st.lists(st.floats(-0.003, 0.003), min_size=2, max_size=8),
    missing=st.sets(st.integers(0, 7), max_size=3),
    known_ground=st.booleans(),
)
def test_the_rise_is_as_near_as_the_heights(rise, ground, noise, missing, known_ground):
    """Heights within 3 mm of a staircase's nosings give its rise within 3 mm (the fit
    weighs the nosings by their step number), whichever are missing."""
    heights = [None if i in missing else ground + (i + 1) * rise + e for i, e in enumerate(noise)]
    shown = sum(h is not None for h in heights)
    got = rise_from_nosings(heights, ground if known_ground else None, CONFIG)
    if shown < 2 + (not known_ground):
        assert got is None
    elif known_ground:
        assert got is not None and got[0] == pytest.approx(rise, abs=0.003 + 1e-9)
        assert got[1] == [i for i, h in enumerate(heights) if h is not None]
    else:
        assert got is not None and abs(got[0] - rise) < 0.01


def test_the_measured_rises_near_the_nosings_rise_report_it():
    steps = _steps([0.21, 0.16, 0.19, 0.35])  # the last a double step
    out, n_rises, _, _ = common_steps(steps, 0.0, CONFIG, rise_m=0.18)
    assert n_rises == 3
    assert [s.rise_m for s in out] == [0.18, 0.18, 0.18, 0.35]
    assert [s.measured_rise_m for s in out[:3]] == [0.21, 0.16, 0.19]
    assert out[-1].measured_rise_m is None
    assert [s.top_z_m for s in out] == pytest.approx([0.18, 0.36, 0.54, 0.89])
    # None near it: the median's rule (three or more within the tolerance of their median).
    out, n_rises, _, _ = common_steps(_steps([0.17, 0.17, 0.18]), 0.0, CONFIG, rise_m=0.25)
    assert n_rises == 3 and out[0].rise_m == pytest.approx(0.17)
    # A step whose nosing it fits takes it, whatever its measured rise (two steps' nosings
    # at 36 and 54 cm: the 27 cm measured is the disparity's, not the step's).
    out, n_rises, _, _ = common_steps(_steps([0.17, 0.27, 0.10]), 0.0, CONFIG, rise_m=0.18, fits=[1])
    assert [s.rise_m for s in out] == [0.18, 0.18, 0.10] and n_rises == 2
    # Steps whose rise was inferred take it too.
    out, n_rises, _, _ = common_steps(_steps([0.21, 0.21], inferred=(1,)), 0.0, CONFIG, rise_m=0.20)
    assert n_rises == 1 and [s.rise_m for s in out] == [0.20, 0.20]


def test_nosing_heights_from_the_segments():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _planes(3, rise, run, distance, missing=0)
    model = build_terrain(planes, TerrainConfig(continue_steps=False, nosing_rise=False))
    assert len(model.steps) == 3
    # The steps' tops 2 cm off; segments on the true nosings of the first two steps only.
    steps = [dataclasses.replace(s, top_z_m=s.top_z_m - 0.02) for s in model.steps]
    lines = _lines(_stair_lines(2, rise, run, distance, feet=False))
    heights = nosing_heights(steps, X, Y, (-0.5, 0.5), lines)
    assert heights[0] == pytest.approx(rise, abs=0.002)
    assert heights[1] == pytest.approx(2 * rise, abs=0.002)
    assert heights[2] is None
    # A segment further than a third of a rise from a step's top is not its nosing.
    far = _lines(np.array([_segment(lines, distance, rise + 0.08, 0.0)]))
    assert nosing_heights(steps[:1], X, Y, (-0.5, 0.5), far) == [None]
    assert nosing_heights(steps, X, Y, (-0.5, 0.5), _lines(np.empty((0, 4)))) == [None] * 3


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0])
def test_the_staircase_takes_the_rise_its_nosings_show(yaw_deg):
    """The planes' rise 17 cm, the nosings' segments drawn for 18 cm (the heights of the
    planes a centimetre off per step, as the disparity leaves them on wooden faces): the
    staircase reports the nosings' rise, and the planes' without them or with the option
    off."""
    yaw = np.radians(yaw_deg)
    distance, run = 1.3, 0.29
    planes = _planes(3, 0.17, run, distance, yaw, missing=0)
    lines = _lines(_stair_lines(3, 0.18, run, distance, yaw, feet=False))
    config = TerrainConfig(continue_steps=False, nosing_steps=False)
    model = build_terrain(planes, config, lines=lines)
    assert model.obstacle == STAIRS and len(model.steps) == 3
    assert [s.rise_m for s in model.steps] == pytest.approx([0.18] * 3, abs=0.003)
    assert [s.measured_rise_m for s in model.steps] == pytest.approx([0.17] * 3, abs=0.005)
    assert model.steps[-1].top_z_m == pytest.approx(0.54, abs=0.01)
    assert "nosings the image's line segments show at their heights" in model.note
    off = build_terrain(planes, dataclasses.replace(config, nosing_rise=False), lines=lines)
    assert [s.rise_m for s in off.steps] == pytest.approx([0.17] * 3, abs=0.003)
    assert "agree with the rise" not in off.note
    alone = build_terrain(planes, config)
    assert [s.rise_m for s in alone.steps] == pytest.approx([0.17] * 3, abs=0.003)
    # Lines near the first two tops that no one rise from the ground fits (13 and 39 cm):
    # the fit is refused, the planes' rise stays.
    s0 = distance * np.cos(yaw)
    odd = _lines(np.array([_segment(lines, s0, 0.13, yaw), _segment(lines, s0 + run, 0.39, yaw)]))
    assert [s.rise_m for s in build_terrain(planes, config, lines=odd).steps] == pytest.approx(
        [0.17] * 3, abs=0.003
    )


def test_a_lone_step_whose_top_is_not_seen_takes_its_nosings_height():
    """One step, its top no tread plane measured: with the ground known, the height of its
    own nosing above the ground is its rise (its riser's top edge from the samples is the
    weakest height they give)."""
    assert rise_from_nosings([0.19], 0.0, CONFIG, lone=True) == (pytest.approx(0.19), [0])
    assert rise_from_nosings([0.29], 0.10, CONFIG, lone=True) == (pytest.approx(0.19), [0])
    assert rise_from_nosings([0.19], None, CONFIG, lone=True) is None  # the ground a guess
    assert rise_from_nosings([None], 0.0, CONFIG, lone=True) is None
    assert rise_from_nosings([0.45], 0.0, CONFIG, lone=True) is None  # no stair rise
    assert rise_from_nosings([0.19], 0.0, TerrainConfig(common_rise_tolerance_m=0.0), lone=True) is None


@pytest.mark.parametrize("yaw_deg", [0.0, 25.0])
def test_a_lone_riser_reports_the_rise_its_nosing_shows(yaw_deg):
    """A lone riser 17 cm tall whose tread formed no plane, its nosing's segment drawn at
    18 cm: the step reports 18 cm (its own 17 cm kept as the measured rise), and its riser's
    edge without the segment, with the option off, or with a tread plane on top."""
    yaw = np.radians(yaw_deg)
    distance = 1.3
    full = _stairs(n_steps=1, rise=0.17, yaw=yaw, distance=distance)
    planes = _with_pixels(
        dataclasses.replace(
            full,
            segments=tuple(
                s for s in full.segments if not (s.kind == HORIZONTAL and abs(s.plane.offset + 0.17) < 1e-6)
            ),
        )
    )
    config = TerrainConfig(continue_steps=False, nosing_steps=False)
    lines = _lines(np.array([_segment(_lines(np.empty((0, 4))), distance * np.cos(yaw), 0.18, yaw)]))
    model = build_terrain(planes, config, lines=lines)
    assert model.obstacle == STAIRS and len(model.steps) == 1
    step = model.steps[0]
    assert step.tread is None
    assert step.rise_m == pytest.approx(0.18, abs=0.003)
    assert step.top_z_m == pytest.approx(0.18, abs=0.003)
    assert step.measured_rise_m == pytest.approx(0.17, abs=0.02)
    assert "its nosing's height above the ground" in model.note
    for other in (
        build_terrain(planes, config),
        build_terrain(planes, dataclasses.replace(config, nosing_rise=False), lines=lines),
    ):
        assert other.steps[0].rise_m == pytest.approx(0.17, abs=0.02)
        assert other.steps[0].measured_rise_m is None
    # Its top seen (a tread plane): the tread's height stays the step's.
    boxed = build_terrain(_with_pixels(full), config, lines=lines)
    assert boxed.steps[0].tread is not None
    assert boxed.steps[0].rise_m == pytest.approx(0.17, abs=0.003)
