"""Stage 7 (planning side): swing height and trigger distance (paper section 4.2).

swing height = max(nominal, top-of-step height + clearance), capped by the leg's reach;
a step whose top is above the cap is not traversable. The trigger: start the raised
swing once the distance travelled since the detection reaches ``d - d_buffer`` (the
intent of the paper's eq. 2, whose printed inequality is reversed).
"""

from __future__ import annotations

from dataclasses import dataclass

from .checks import check_fields
from .errors import ConfigError
from .terrain import NONE, StairModel


@dataclass(frozen=True)
class SwingConfig:
    """Swing-leg parameters, metres.

    Attributes
    ----------
    nominal_height_m : float
        Swing apex on flat ground.
    clearance_m : float
        Margin above the top of the step.
    max_height_m : float
        Highest apex the leg can reach (the cap).
    buffer_m : float
        ``d_buffer``: how far before the first riser the raised swing starts.
    """

    nominal_height_m: float = 0.15
    clearance_m: float = 0.10
    max_height_m: float = 0.40
    buffer_m: float = 0.10

    def __post_init__(self) -> None:
        check_fields(self)
        if not 0 < self.nominal_height_m <= self.max_height_m:
            raise ConfigError("need 0 < nominal_height_m <= max_height_m")
        if self.clearance_m < 0 or self.buffer_m < 0:
            raise ConfigError("clearance_m and buffer_m must be >= 0")


@dataclass(frozen=True)
class SwingPlan:
    """What the swing-leg planner should do for the terrain ahead.

    Attributes
    ----------
    height_m : float
        Swing apex above the surface the foot leaves.
    trigger_distance_m : float or None
        Distance to travel from the detection before raising the swing (``d - d_buffer``,
        never negative); None with no obstacle.
    traversable : bool
    step_height_m : float
        Top-of-step height the plan clears (highest rise), 0 with no obstacle.
    """

    height_m: float
    trigger_distance_m: float | None
    traversable: bool
    step_height_m: float


def plan_swing(model: StairModel, config: SwingConfig | None = None) -> SwingPlan:
    """Swing plan for the obstacle in ``model`` (the nominal swing when there is none)."""
    config = config or SwingConfig()
    if model.obstacle == NONE or not model.steps:
        return SwingPlan(config.nominal_height_m, None, True, 0.0)
    step_height = max(s.rise_m for s in model.steps)
    wanted = max(config.nominal_height_m, step_height + config.clearance_m)
    height = min(wanted, config.max_height_m)
    traversable = step_height <= config.max_height_m
    trigger = max(0.0, model.steps[0].distance_m - config.buffer_m)
    return SwingPlan(float(height), float(trigger), bool(traversable), float(step_height))


def should_raise_swing(plan: SwingPlan, distance_travelled_m: float) -> bool:
    """True once the robot has travelled ``d - d_buffer`` since the detection."""
    return plan.trigger_distance_m is not None and distance_travelled_m >= plan.trigger_distance_m
