import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.swing import SwingConfig, plan_swing, should_raise_swing
from stereo_terrain.terrain import NONE, STAIRS, Polytope, StairModel, Step


def _model(rises, distance=1.42):
    steps = tuple(
        Step(
            r,
            0.3,
            distance + 0.3 * i,
            1.0,
            sum(rises[: i + 1]),
            distance + 0.3 * i,
            Plane([-1.0, 0, 0], distance),
        )
        for i, r in enumerate(rises)
    )
    return StairModel(STAIRS, steps, 0.0, 0.0, Polytope(np.zeros((0, 3))), "yaw")


def test_swing_rule_from_conventions():
    plan = plan_swing(_model([0.21, 0.18]))
    assert plan.height_m == pytest.approx(0.31)  # max(0.15, 0.21 + 0.10)
    assert plan.trigger_distance_m == pytest.approx(1.32)  # d - d_buffer
    assert plan.traversable


def test_low_step_keeps_nominal_height():
    assert plan_swing(_model([0.03])).height_m == pytest.approx(0.15)


def test_cap_and_untraversable():
    cfg = SwingConfig(max_height_m=0.35)
    plan = plan_swing(_model([0.30]), cfg)
    assert plan.height_m == pytest.approx(0.35) and plan.traversable
    plan = plan_swing(_model([0.40]), cfg)
    assert plan.height_m == pytest.approx(0.35) and not plan.traversable


def test_no_obstacle_is_nominal():
    m = StairModel(NONE, (), 0.0, 0.0, Polytope(np.zeros((0, 3))), "yaw")
    plan = plan_swing(m)
    assert plan.height_m == 0.15 and plan.trigger_distance_m is None and plan.traversable
    assert not should_raise_swing(plan, 10.0)


def test_trigger_fires_after_d_minus_buffer():
    plan = plan_swing(_model([0.2], distance=1.0))
    assert not should_raise_swing(plan, 0.89)
    assert should_raise_swing(plan, 0.90)
    assert plan_swing(_model([0.2], distance=0.05)).trigger_distance_m == 0.0


def test_bad_config():
    with pytest.raises(ConfigError):
        SwingConfig(nominal_height_m=0.5, max_height_m=0.4)
    with pytest.raises(ConfigError):
        SwingConfig(buffer_m=-1)
