"""A staircase's common rise (terrain/uniform.py) and the least run of a step
(``TerrainConfig.min_run_m``), issue 11."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.terrain import STAIRS, Step, TerrainConfig, build_terrain, estimate_step_sigmas
from stereo_terrain.terrain.sigmas import _RISE_VARIATION_M
from stereo_terrain.terrain.uniform import common_rise

from .test_terrain import _stairs

CONFIG = TerrainConfig()


def _steps(rises, inferred=(), ground=0.0, run=0.29) -> list[Step]:
    out, top = [], ground
    for i, r in enumerate(rises):
        top += r
        s = 1.3 + i * run
        out.append(
            Step(r, run, s, 1.0, top, s, Plane(np.array([-1.0, 0.0, 0.0]), s), rise_inferred=i in inferred)
        )
    return out


@settings(max_examples=40, deadline=None)
@given(
    rise=st.floats(0.12, 0.21),
    noise=st.lists(st.floats(-0.012, 0.012), min_size=3, max_size=7),
    ground=st.floats(-0.2, 0.2),
)
def test_agreeing_rises_report_their_median(rise, noise, ground):
    measured = [rise + e for e in noise]
    steps, n = common_rise(_steps(measured, ground=ground), ground, CONFIG)
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
    steps, n = common_rise(_steps(measured), 0.0, CONFIG)
    assert n == 3
    assert [s.rise_m for s in steps] == pytest.approx([0.17, 0.17, 0.23, 0.17])
    assert steps[2].measured_rise_m is None and steps[0].measured_rise_m == pytest.approx(0.17)
    assert steps[-1].top_z_m == pytest.approx(0.17 * 3 + 0.23)


def test_two_steps_or_no_agreeing_majority_are_left_alone():
    two = _steps([0.17, 0.12])
    assert common_rise(two, 0.0, CONFIG) == (two, 0)
    scattered = _steps([0.10, 0.17, 0.24])  # each 7 cm from the median: no two agree with it
    assert common_rise(scattered, 0.0, CONFIG) == (scattered, 0)
    off = TerrainConfig(common_rise_tolerance_m=0.0)
    steps = _steps([0.17, 0.18, 0.16])
    assert common_rise(steps, 0.0, off) == (steps, 0)


def test_an_inferred_rise_takes_the_common_rise_and_is_no_measurement():
    measured = [0.17, 0.18, 0.16, 0.15]
    steps, n = common_rise(_steps(measured + [0.16], inferred={4}), 0.0, CONFIG)
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
    assert all(s.rise_sigma_m >= _RISE_VARIATION_M for s in sig)
    assert all(s.rise_sigma_m < _RISE_VARIATION_M + max(o.rise_sigma_m for o in sig_own) for s in sig)


@pytest.mark.parametrize(
    "bad",
    [{"common_rise_tolerance_m": -0.01}, {"common_rise_min_steps": 1}, {"min_run_m": -0.1}],
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
