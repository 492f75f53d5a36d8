"""The controller's side of the terrain messages: the swing each message commands, and
where along the walk the swing is raised (the paper's eq. 2 at the controller's rate)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..messages import terrain_t


@dataclass(frozen=True)
class SwingCommand:
    """What the controller knows from one terrain message (the fields of ``terrain_t`` it uses).

    Attributes
    ----------
    x_m : float
        Body x (world) when the message was published (its frame's odometry).
    p0_x_m : float
        World x the trigger distance is counted from.
    trigger_distance_m : float
        ``d - d_buffer`` (NaN: nothing to trigger on).
    height_m : float
    raised : bool
        The state machine's decision when published.
    approach : bool
        The state machine is tracking stairs (not idle, not blocked).
    """

    x_m: float
    p0_x_m: float
    trigger_distance_m: float
    height_m: float
    raised: bool
    approach: bool

    @classmethod
    def from_message(cls, msg: terrain_t, x_m: float) -> SwingCommand:
        return cls(
            x_m=float(x_m),
            p0_x_m=float(msg.p0_m[0]),
            trigger_distance_m=float(msg.trigger_distance_m),
            height_m=float(msg.swing_height_m),
            raised=bool(msg.raise_swing),
            approach=msg.trigger_phase == terrain_t.PHASE_APPROACH,
        )


def commanded_swing(commands: Sequence[SwingCommand], x_m: float, nominal_m: float) -> tuple[bool, float]:
    """(raised, swing height) for a controller at body x ``x_m`` (world, heading +x).

    Uses the latest message published before the body got there and applies eq. 2 at the
    controller's own rate: raised once ``x - p0_x >= d - d_buffer``.
    """
    cmd = None
    for c in commands:
        if c.x_m <= x_m + 1e-9:
            cmd = c
        else:
            break
    if cmd is None:
        return False, nominal_m
    raised = cmd.raised or (
        cmd.approach and math.isfinite(cmd.trigger_distance_m) and x_m - cmd.p0_x_m >= cmd.trigger_distance_m
    )
    return raised, (cmd.height_m if raised else nominal_m)


def trigger_position(
    commands: Sequence[SwingCommand], x_end_m: float, nominal_m: float, step_m: float = 0.001
) -> float | None:
    """First body x (world) at which the controller raises the swing, sampled every ``step_m``."""
    if not commands:
        return None
    for x in np.arange(commands[0].x_m, x_end_m, step_m):
        if commanded_swing(commands, float(x), nominal_m)[0]:
            return float(x)
    return None
