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
goes on from there. A glitch's way back returns to the shift from before it (the few last
shifts are kept), also after a stall. A camera stall is no jump: the poses' times say how
long the body had to walk. What it cannot see: a jump smaller than the body's own possible
travel in the time (0.28 m at 30 poses a second), and a frame that drifts; a continuous
odometry frame (ROS ``odom``, not ``map``) is the pose source to give it.

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
from collections import deque
from dataclasses import dataclass

import numpy as np

from ._numeric import wrap_angle
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
        The last speed is carried over a gap between poses for at most this long (where a
        jump is taken out, the body is put where that speed takes it; beyond it, the travel
        is not known: more is early, less would be late). Also: a pose older than the last
        by up to this and behind it was delivered late (dropped); otherwise the clock went
        back.
    """

    enabled: bool = True
    max_speed_mps: float = 4.0
    max_turn_rate_dps: float = 180.0
    slack_m: float = 0.15
    slack_deg: float = 5.0
    max_gap_s: float = 5.0

    def __post_init__(self) -> None:
        check_fields(self)
        for name in ("max_speed_mps", "max_turn_rate_dps", "slack_m", "slack_deg", "max_gap_s"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"PoseJumpConfig.{name} must be > 0, got {getattr(self, name)}")


class _Shift:
    """A rigid shift of the estimator's frame: ``corrected = R(turn) raw + offset``."""

    def __init__(self, turn: float = 0.0, offset: np.ndarray | None = None) -> None:
        self.turn = turn
        self.offset = np.zeros(3) if offset is None else offset

    def apply(self, odo: Odometry) -> Odometry:
        c, s = math.cos(self.turn), math.sin(self.turn)
        x, y, z = (float(v) for v in odo.position_m)
        p = (c * x - s * y + self.offset[0], s * x + c * y + self.offset[1], z + self.offset[2])
        return Odometry(p, wrap_angle(float(odo.yaw_rad) + self.turn), odo.stamp_s)

    @classmethod
    def placing(cls, raw: Odometry, target: np.ndarray, yaw: float) -> _Shift:
        """The shift that puts ``raw`` at ``target`` with heading ``yaw``."""
        turn = wrap_angle(yaw - float(raw.yaw_rad))
        c, s = math.cos(turn), math.sin(turn)
        x, y, z = (float(v) for v in raw.position_m)
        return cls(turn, target - np.array([c * x - s * y, s * x + c * y, z]))


#: Shifts kept besides the current one: a glitch's way back returns to the one before it.
_HISTORY = 3

#: Judged poses over which the stamps' pace is checked against the travel.
_SPEED_WINDOW = 10

#: This many jumps (not undone by a way back) within this long of stamps: the stamps are
#: wrong, not the frame (no estimator relocalises that often).
_MAX_JUMPS = 3
_MAX_JUMPS_WITHIN_S = 1.0

#: The stamps are too close when the poses' net travel over the window is this many
#: times what the fastest body could make in their time.
_PACE_MARGIN = 2.0

#: Slower than this (m/s) the body stands: a late pose is then where the last one was.
_STANDING_MPS = 0.05

#: An earlier shift must land within the slack plus this share of the fastest travel in
#: the time (the pace may have changed that much), and its miss be under this fraction of
#: the current shift's ("much nearer").
_NEAR_SPEED_SHARE = 0.25
_MUCH_NEARER = 0.5

#: An earlier shift is taken again only near the prediction over at most this long.
_NEAR_DT_S = 0.2

#: Earlier shifts are kept this long (stamp seconds) after they were left: a glitch comes
#: back within it; kept longer, an old shift could "explain" a stop in a later gap.
_KEEP_SHIFTS_S = 1.0


class PoseJumps:
    """Removes the jumps of a state estimator's frame from its poses (module docstring).

    Feed it every pose, in order, with :meth:`correct`, and pass what it returns to the
    trigger and the tracker (the live loop does). The corrected poses are the estimator's
    moved by the shift of every jump so far.

    Each stamped pose is judged against the last one. Under each shift kept (the current
    one and the few before it), the step from the last pose must be one the body can make
    in the time between them; of those that allow it, the one nearest where the body would
    be at its last speed is taken, keeping the current one unless another is much nearer
    (the way back of a glitch, even one followed by a stall, returns to the shift from
    before it). When none allows it, the frame jumped: a new shift puts the pose where the
    body would be. Stamps that do not advance while the pose moves (a source that never
    sets them, a clock in the wrong unit) are not judged and said so once. A pose older
    than the last by up to ``max_gap_s`` that lies behind it (standing: within the slack
    of it) was delivered late and is dropped (no pose); one ahead of it, or older by
    more, means the clock went back (a restart, a wall clock set back): the judging
    starts again from it, under the last confirmed shift. A new shift is published
    (:meth:`to_raw`) once the pose after the jump confirms it (:attr:`settled`).
    """

    def __init__(self, config: PoseJumpConfig | None = None) -> None:
        self.config = config or PoseJumpConfig()
        self.jumps = 0  # how many jumps were taken out
        self.late = 0  # poses dropped as older than the last
        self._shift = _Shift()
        self._history: list[tuple[_Shift, float]] = []  # earlier shifts and when they were left, newest first
        self._last: Odometry | None = None  # the last judged pose, corrected
        self._velocity = np.zeros(2)  # corrected frame, m/s, from the last two judged poses
        self._warned_stamps = False
        self._recent: deque[tuple[float, float, float]] = deque(maxlen=_SPEED_WINDOW)  # (stamp, x, y)
        self.untrusted = False  # the stamps are too close together for the poses' travel
        self._jumps_seen: deque[tuple[float, _Shift]] = deque(maxlen=_MAX_JUMPS)  # (stamp, shift before)
        # The shift the published origin is given in (to_raw): a new one only once the pose
        # after the jump confirms it (a one-pose glitch never reaches the controller).
        self._published = self._shift

    def correct(self, odometry: Odometry | None) -> Odometry | None:
        """The pose with the frame's jumps taken out; None for a pose delivered late (None
        and a pose that is not finite are returned as they are)."""
        if odometry is None or not odometry.finite or not self.config.enabled:
            return odometry
        if self.untrusted:
            return self._shift.apply(odometry)  # frozen: no more judging
        moved = self._shift.apply(odometry)
        last = self._last
        if odometry.stamp_s is None:
            return moved  # cannot be judged without its time
        if last is None or last.stamp_s is None:
            self._last = moved
            return moved
        cfg = self.config
        dt = float(odometry.stamp_s) - float(last.stamp_s)
        step = np.array(moved.position_m[:2]) - np.array(last.position_m[:2])
        if dt < 0:
            speed = float(np.hypot(*self._velocity))
            if speed > _STANDING_MPS:
                behind = float(step @ self._velocity) / speed < 0.0
            else:  # standing: a late pose is where the body stands
                behind = float(np.hypot(*step)) <= cfg.slack_m
            if behind and -dt <= cfg.max_gap_s:
                self.late += 1
                return None  # an older pose, delivered late (behind the last): no pose
            # Ahead of the last pose (standing: away from it) with an earlier stamp: the
            # clock stepped back (a restart, a wall clock set back), not an old pose.
            log.warning("the odometry's clock went back %.3f s: its jumps are judged from here", -dt)
            # A shift no pose has confirmed yet (a glitch's) is not carried into the restart
            # (found in the third review: a late pose under a glitch's shift kept it).
            self._shift = self._published
            moved = self._shift.apply(odometry)
            self._last = moved
            self._recent.clear()  # the pace of the stamps starts again too
            self._jumps_seen.clear()
            self._history = []  # left at stamps of the old clock
            return moved
        if dt == 0:
            if float(np.hypot(*step)) > cfg.slack_m and not self._warned_stamps:
                self._warned_stamps = True
                log.warning(
                    "odometry stamps do not advance while the pose moves: its jumps are not taken out "
                    "(give every pose its time on the estimator's clock, in seconds)"
                )
            return moved
        allowed_m = cfg.max_speed_mps * dt + cfg.slack_m
        allowed_deg = cfg.max_turn_rate_dps * dt + cfg.slack_deg
        carried = self._velocity * min(dt, cfg.max_gap_s)
        predicted = np.array(last.position_m[:2]) + carried

        def judged(shift: _Shift) -> tuple[Odometry, bool, float]:
            pose = shift.apply(odometry)
            xy = np.array(pose.position_m[:2])
            ok = (
                float(np.hypot(*(xy - np.array(last.position_m[:2])))) <= allowed_m
                and abs(math.degrees(wrap_angle(pose.yaw_rad - last.yaw_rad))) <= allowed_deg
            )
            return pose, ok, float(np.hypot(*(xy - predicted)))

        pose, ok, miss = judged(self._shift)
        best: tuple[int, Odometry, float] | None = (-1, pose, miss) if ok else None
        # An earlier shift only where it puts the pose near the prediction (the speed may
        # have changed by a quarter of the fastest in the time), and much nearer than the
        # current one does: the way back of a glitch, not a new jump that happens to land
        # near where an old shift would put it.
        # (Over at most a frame's time: after a long gap the speed is too unsure to tell an
        # old glitch's shift from a change of pace; and kept shifts expire.)
        near = cfg.slack_m + _NEAR_SPEED_SHARE * cfg.max_speed_mps * min(dt, _NEAR_DT_S)
        stamp = float(odometry.stamp_s)
        self._history = [(shift, left) for shift, left in self._history if stamp - left <= _KEEP_SHIFTS_S]
        for k, (shift, _left) in enumerate(self._history):
            other, other_ok, other_miss = judged(shift)
            if (
                other_ok
                and other_miss <= near
                and (best is None or other_miss + cfg.slack_m < _MUCH_NEARER * best[2])
            ):
                best = (k, other, other_miss)
        if best is None:
            log.warning(
                "odometry jumped %.2f m in %.3f s: taken for a shift of its frame, not travel",
                float(np.hypot(*step)),
                dt,
            )
            self._jumps_seen.append((stamp, self._shift))
            self._remember(self._shift, stamp)
            z0 = float(last.position_m[2])
            self._shift = _Shift.placing(odometry, np.array([predicted[0], predicted[1], z0]), last.yaw_rad)
            self.jumps += 1
            moved = self._shift.apply(odometry)
            first, before = self._jumps_seen[0]
            if len(self._jumps_seen) == _MAX_JUMPS and stamp - first < _MAX_JUMPS_WITHIN_S:
                # Several jumps within a second: no estimator relocalises that often, its
                # stamps are wrong (too close together for the travel). Those jumps are
                # undone; what was taken out before them stays.
                self._shift = self._published = before
                self._distrust(f"{_MAX_JUMPS} jumps within {stamp - first:.4f} s")
                return self._shift.apply(odometry)
        else:
            k, moved, _ = best
            if k >= 0:  # back to an earlier shift: the jump ended (a glitch's way back)
                log.warning("odometry back in the frame it had before a jump")
                if self._jumps_seen:
                    self._jumps_seen.pop()  # undone: not a jump that says the stamps are wrong
                earlier = self._history.pop(k)[0]
                self._remember(self._shift, stamp)
                self._shift = earlier
            self._published = self._shift  # this pose agrees with it
            step = np.array(moved.position_m[:2]) - np.array(last.position_m[:2])
            speed = float(np.hypot(*step)) / dt
            self._velocity = step / dt * min(1.0, cfg.max_speed_mps / max(speed, 1e-12))
            if self._stamps_too_close(stamp, moved):
                return moved
        self._last = moved
        return moved

    def _stamps_too_close(self, stamp: float, pose: Odometry) -> bool:
        """Whether the stamps are too close together for the poses' travel (the net
        displacement over the last few judged poses, each step within the slack): a clock
        in the wrong unit (milliseconds read as microseconds) would make every stall a
        jump. Then nothing more is judged (the current shift stays), and it is said once."""
        x, y = float(pose.position_m[0]), float(pose.position_m[1])
        self._recent.append((stamp, x, y))
        if len(self._recent) < _SPEED_WINDOW:
            return False
        t0, x0, y0 = self._recent[0]
        travelled, elapsed = math.hypot(x - x0, y - y0), stamp - t0
        if (
            travelled <= self.config.slack_m
            or travelled <= _PACE_MARGIN * self.config.max_speed_mps * elapsed
        ):
            return False
        self._distrust(f"{travelled:.2f} m in {elapsed:.4f} s")
        return True

    def _distrust(self, why: str) -> None:
        self.untrusted = True
        self._history = []
        log.warning(
            "odometry stamps are too close together for its travel (%s): its jumps are not taken "
            "out from here (the stamps must be seconds on the estimator's clock)",
            why,
        )

    def _remember(self, shift: _Shift, stamp: float) -> None:
        self._history = ([(shift, stamp)] + self._history)[:_HISTORY]

    def reset(self) -> None:
        """Forget every pose and shift (a source that starts over: a looped replay's next lap)."""
        self.__init__(self.config)  # type: ignore[misc]

    @property
    def settled(self) -> bool:
        """False just after a jump, until the next pose confirms the new shift (or goes back):
        the estimator's own frame is then not known for sure."""
        return self._shift is self._published

    def to_raw(
        self, position_m: tuple[float, float, float], heading_rad: float
    ) -> tuple[tuple[float, float, float], float]:
        """A position and heading of the corrected frame in the estimator's own frame (the
        inverse of the shift the last pose confirmed: a jump's new shift counts once the pose
        after it agrees, so a one-pose glitch never reaches the controller): what a
        controller comparing its own odometry with them needs."""
        turn, offset = self._published.turn, self._published.offset
        c, s = math.cos(turn), math.sin(turn)
        x = float(position_m[0]) - offset[0]
        y = float(position_m[1]) - offset[1]
        z = float(position_m[2]) - offset[2]
        return (c * x + s * y, -s * x + c * y, z), wrap_angle(float(heading_rad) - turn)
