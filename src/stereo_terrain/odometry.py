"""The body pose from the robot's state estimator, and the jumps of its frame.

:class:`Odometry` is the pose the swing trigger (:mod:`stereo_terrain.swing`) and the
tracker (:mod:`stereo_terrain.tracking`) count the travel with. A state estimator's frame
can jump: a one-update glitch (+2 m and back), or a relocalisation (a loop closure moves
the whole frame by a metre near the stairs). Counted as travel, a glitch latches the raised
swing early, and a relocalisation puts the trigger a metre late, into the riser.

:class:`PoseJumps` tells a jump from travel with the poses' own clock
(``Odometry.stamp_s``): between two stamped poses the body moves at most
``max_speed_mps`` times the time between them (and turns at most ``max_turn_rate_dps``),
plus a slack for the estimator's noise. A step beyond that is a jump of the frame, not
travel: the pose is taken where the body would be at its last speed, and every later pose
is moved by the same rigid shift (a turn about up and a translation), so the travel counted
goes on from there. A second jump (the glitch's way back) is taken the same way, so a
glitch leaves a shift of a few centimetres at most. A camera stall is no jump: the poses'
times say how long the body had to walk.

Only stamped poses are judged. A pose without a stamp cannot be (a step of a metre is a
jump after 30 ms and walking after a second), so it is moved by the shift as it stands and
changes nothing: give every pose its stamp, or none (then nothing is judged, as before
this stage existed). Every pose source of the package stamps its poses: a recording's
rows, a bag's odometry headers, the LCM state's ``utime``, the simulator's times. The
stamps are the poses' own, not the loop's clock, so a replay run as fast as it goes judges
the recorded times.

The swing trigger's origin (``TriggerState.p0_m``, ``heading_rad``) is kept in the
corrected frame; the loop publishes it in the estimator's own frame
(:meth:`PoseJumps.to_raw`), which is the one a controller compares it with.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from .checks import check_fields
from .errors import ConfigError, InputError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Odometry:
    """Body pose from the robot's state estimator (CoM odometry), world frame.

    Attributes
    ----------
    position_m : (3,) float, metres, world frame
    yaw_rad : float
        Heading of the body x axis in the world frame, radians.
    stamp_s : float or None
        The pose's time on the state estimator's own clock, seconds; None when not known.
        With stamps, a jump of the estimator's frame is told from travel
        (:class:`PoseJumps`).
    """

    position_m: tuple[float, float, float]
    yaw_rad: float = 0.0
    stamp_s: float | None = None

    def __post_init__(self) -> None:
        try:
            ok = len(self.position_m) == 3
            [float(v) for v in (*self.position_m, self.yaw_rad)]
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(
                f"Odometry needs position_m (x, y, z) in metres and yaw_rad as numbers, "
                f"got {self.position_m!r}, {self.yaw_rad!r}"
            )
        if self.stamp_s is not None:
            try:
                stamp_ok = math.isfinite(float(self.stamp_s))
            except (TypeError, ValueError):
                stamp_ok = False
            if not stamp_ok:
                raise InputError(
                    f"Odometry.stamp_s must be a finite number of seconds or None, got {self.stamp_s!r}"
                )

    @property
    def finite(self) -> bool:
        """Whether the pose is a pose: a state estimator may send NaN when it has none."""
        return all(math.isfinite(float(v)) for v in self.position_m) and math.isfinite(float(self.yaw_rad))


def usable_odometry(odometry: Odometry | None) -> Odometry | None:
    """``odometry`` when it holds a finite pose, else None (no pose this frame)."""
    return odometry if odometry is not None and odometry.finite else None


@dataclass(frozen=True)
class PoseJumpConfig:
    """When a step between two stamped poses is a jump of the frame (:class:`PoseJumps`).

    Attributes
    ----------
    enabled : bool
    max_speed_mps : float
        Fastest the body moves (a quadruped trots at 1-3 m/s; on stairs' approach less).
    max_turn_rate_dps : float
        Fastest the body turns, degrees per second.
    slack_m, slack_deg : float
        Added to what the time allows: the estimator's own noise between two poses.
    max_gap_s : float
        After a gap this long between poses the last speed is not carried on: a pose that
        jumps after it is taken where the last one was.
    """

    enabled: bool = True
    max_speed_mps: float = 4.0
    max_turn_rate_dps: float = 180.0
    slack_m: float = 0.15
    slack_deg: float = 5.0
    max_gap_s: float = 1.0

    def __post_init__(self) -> None:
        check_fields(self)
        for name in ("max_speed_mps", "max_turn_rate_dps", "slack_m", "slack_deg", "max_gap_s"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"PoseJumpConfig.{name} must be > 0, got {getattr(self, name)}")


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class PoseJumps:
    """Removes the jumps of a state estimator's frame from its poses (module docstring).

    Feed it every pose, in order, with :meth:`correct`, and pass what it returns to the
    trigger and the tracker (the live loop does). The corrected poses are the estimator's
    moved by the shift of every jump so far.
    """

    def __init__(self, config: PoseJumpConfig | None = None) -> None:
        self.config = config or PoseJumpConfig()
        self.jumps = 0  # how many jumps were taken out
        self._turn = 0.0  # the shift: corrected = R(turn) raw + offset
        self._offset = np.zeros(3)
        self._last: Odometry | None = None  # the last stamped pose, corrected
        self._velocity = np.zeros(2)  # corrected frame, m/s, from the last two stamped poses

    def _shifted(self, odo: Odometry) -> Odometry:
        c, s = math.cos(self._turn), math.sin(self._turn)
        x, y, z = (float(v) for v in odo.position_m)
        p = (c * x - s * y + self._offset[0], s * x + c * y + self._offset[1], z + self._offset[2])
        return Odometry(p, _wrap(float(odo.yaw_rad) + self._turn), odo.stamp_s)

    def correct(self, odometry: Odometry | None) -> Odometry | None:
        """The pose with the frame's jumps taken out (None and a pose that is not finite
        are returned as they are)."""
        if odometry is None or not odometry.finite or not self.config.enabled:
            return odometry
        moved = self._shifted(odometry)
        last = self._last
        if odometry.stamp_s is None:
            return moved  # cannot be judged without its time
        if last is None or last.stamp_s is None:
            self._last = moved
            return moved
        dt = float(odometry.stamp_s) - float(last.stamp_s)
        if dt < 0:
            return moved  # an older pose than the last: not judged, not kept
        cfg = self.config
        step = np.array(moved.position_m[:2]) - np.array(last.position_m[:2])
        turn = _wrap(moved.yaw_rad - last.yaw_rad)
        far = float(np.hypot(*step)) > cfg.max_speed_mps * dt + cfg.slack_m
        turned = abs(math.degrees(turn)) > cfg.max_turn_rate_dps * dt + cfg.slack_deg
        if far or turned:
            log.warning(
                "odometry jumped %.2f m and %.1f deg in %.3f s: taken for a shift of its frame, not travel",
                float(np.hypot(*step)),
                math.degrees(turn),
                dt,
            )
            moved = self._rebase(odometry, last, dt)
        elif dt > 0:
            speed = float(np.hypot(*step)) / dt
            self._velocity = step / dt * min(1.0, cfg.max_speed_mps / max(speed, 1e-12))
        self._last = moved
        return moved

    def _rebase(self, raw: Odometry, last: Odometry, dt: float) -> Odometry:
        """A jump: the shift that puts ``raw`` where the body would be ``dt`` after ``last``
        at its last speed, with ``last``'s heading and height."""
        carried = self._velocity * dt if dt <= self.config.max_gap_s else np.zeros(2)
        x0, y0, z0 = (float(v) for v in last.position_m)
        target = np.array([x0 + carried[0], y0 + carried[1], z0])
        self._turn = _wrap(last.yaw_rad - float(raw.yaw_rad))
        c, s = math.cos(self._turn), math.sin(self._turn)
        x, y, z = (float(v) for v in raw.position_m)
        self._offset = target - np.array([c * x - s * y, s * x + c * y, z])
        self.jumps += 1
        return Odometry((float(target[0]), float(target[1]), float(target[2])), last.yaw_rad, raw.stamp_s)

    def to_raw(
        self, position_m: tuple[float, float, float], heading_rad: float
    ) -> tuple[tuple[float, float, float], float]:
        """A position and heading of the corrected frame in the estimator's own frame now
        (the inverse of the current shift): what a controller comparing its own odometry
        with them needs."""
        c, s = math.cos(self._turn), math.sin(self._turn)
        x = float(position_m[0]) - self._offset[0]
        y = float(position_m[1]) - self._offset[1]
        z = float(position_m[2]) - self._offset[2]
        return (c * x + s * y, -s * x + c * y, z), _wrap(float(heading_rad) - self._turn)
