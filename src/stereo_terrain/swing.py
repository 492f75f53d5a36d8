"""Stage 7 (planning side): swing height and trigger distance (paper section 4.2).

swing height = max(nominal, top-of-step height + clearance), capped by the leg's reach;
a step whose top is above the cap is not traversable. The trigger: start the raised
swing once the distance travelled since the detection reaches ``d - d_buffer`` (the
intent of the paper's eq. 2, whose printed inequality is reversed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .checks import check_fields
from .errors import ConfigError
from .odometry import Odometry, usable_odometry  # Odometry: importable from here as before
from .terrain import NONE, StairModel, Step


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


def rise_to_clear(step: Step) -> float:
    """The rise a swing must clear at ``step``: the larger of its reported rise and its own
    measured one, where the reported one is the staircase's common rise (the pooled rises
    may differ by up to twice the tolerance: :mod:`stereo_terrain.terrain.uniform`)."""
    return max(step.rise_m, step.own_rise_m)


def plan_swing(model: StairModel, config: SwingConfig | None = None) -> SwingPlan:
    """Swing plan for the obstacle in ``model`` (the nominal swing when there is none)."""
    config = config or SwingConfig()
    if model.obstacle == NONE or not model.steps:
        return SwingPlan(config.nominal_height_m, None, True, 0.0)
    step_height = max(rise_to_clear(s) for s in model.steps)
    wanted = max(config.nominal_height_m, step_height + config.clearance_m)
    height = min(wanted, config.max_height_m)
    traversable = step_height <= config.max_height_m
    trigger = max(0.0, model.steps[0].distance_m - config.buffer_m)
    return SwingPlan(float(height), float(trigger), bool(traversable), float(step_height))


def should_raise_swing(plan: SwingPlan, distance_travelled_m: float) -> bool:
    """True once the robot has travelled ``d - d_buffer`` since the detection."""
    return plan.trigger_distance_m is not None and distance_travelled_m >= plan.trigger_distance_m


# --------------------------------------------------------------------------- trigger state machine

PHASE_IDLE, PHASE_APPROACH, PHASE_RAISED, PHASE_BLOCKED = "idle", "approach", "raised", "blocked"


@dataclass(frozen=True)
class TriggerConfig:
    """Parameters of :class:`SwingTrigger`, metres unless named otherwise.

    Attributes
    ----------
    gate_m : float
        A new first-riser distance within this of the dead-reckoned prediction refines the
        estimate; one outside it is an outlier (or a different riser).
    smoothing : float
        Weight (0, 1] of a measurement inside the gate against the prediction.
    confirm_frames : int
        Frames in a row that must see an obstacle before the trigger arms.
    reacquire_frames : int
        Consecutive outliers on the same side (or frames with nothing while the riser should
        be in view) after which the estimate is dropped and started again.
    min_visible_m : float
        Below this predicted distance the first riser is expected to have left the camera's
        view: farther measurements (the next riser) and empty frames are then ignored and the
        estimate runs on odometry alone, which is what the paper's eq. 2 is for.
    release_m : float
        The raised swing is kept until the body has passed the last seen riser by this much.
    history : int
        Accepted frames whose per-step median rises give the height to clear (one bad
        frame cannot change the swing height).
    """

    gate_m: float = 0.08
    smoothing: float = 0.3
    confirm_frames: int = 2
    reacquire_frames: int = 3
    min_visible_m: float = 0.8
    release_m: float = 0.8
    history: int = 9

    def __post_init__(self) -> None:
        check_fields(self)
        if not self.gate_m > 0 or not 0 < self.smoothing <= 1:
            raise ConfigError("TriggerConfig needs gate_m > 0 and 0 < smoothing <= 1")
        if self.confirm_frames < 1 or self.reacquire_frames < 1 or self.history < 1:
            raise ConfigError("TriggerConfig confirm_frames, reacquire_frames and history must be >= 1")
        if self.min_visible_m < 0 or self.release_m < 0:
            raise ConfigError("TriggerConfig min_visible_m and release_m must be >= 0")


@dataclass(frozen=True)
class TriggerState:
    """The decision of :class:`SwingTrigger` and what the controller needs to apply it.

    Attributes
    ----------
    phase : str
        ``idle`` (nothing ahead), ``approach`` (tracking the first riser), ``raised`` (raised
        swing on) or ``blocked`` (the step is above the leg's reach).
    raise_swing : bool
    swing_height_m : float
        Apex to use when raised (the nominal height otherwise).
    trigger_distance_m : float or None
        ``d - d_buffer`` from ``p0_m`` along ``heading_rad`` (never negative); a controller
        running faster than the camera raises the swing once it has travelled this far from
        ``p0_m`` (paper eq. 2). None when idle.
    remaining_m : float or None
        Dead-reckoned distance from the body to the first riser now.
    p0_m : (3,) float, world frame
    heading_rad : float
    traversable : bool
    """

    phase: str
    raise_swing: bool
    swing_height_m: float
    trigger_distance_m: float | None
    remaining_m: float | None
    p0_m: tuple[float, float, float]
    heading_rad: float
    traversable: bool


class SwingTrigger:
    """When to switch to the raised swing, stable while frames keep arriving (paper eq. 2).

    The paper raises the swing once ``p_CoM,x - p_0,x >= d - d_buffer``: the distance
    travelled since the stairs were detected at ``d`` reaches ``d - d_buffer``. Walking on,
    every new frame measures ``d`` again from a new ``p_0``; naively restarting the count
    would let noise move the trigger back and forth, and near the stairs the first riser
    leaves the camera's view (the next riser is then reported as the nearest). So the
    first riser's distance is *tracked*: predicted from odometry, refined by measurements
    inside a gate, outliers ignored, and the decision latched once taken.

    Feed it every processed frame with :meth:`update` (terrain + odometry) and, between
    frames, odometry alone (a controller tick) to decide at the odometry's rate. With
    tracking on (issue 14, :mod:`stereo_terrain.tracking`), the live loop feeds it the
    tracked staircase once its track is confirmed, and nothing ahead before that
    (:func:`stereo_terrain.runtime.loop.track_and_trigger`): the first riser then keeps
    its place when it leaves the view, and a bad frame cannot move the trigger.
    """

    def __init__(self, swing: SwingConfig | None = None, config: TriggerConfig | None = None) -> None:
        self.swing = swing or SwingConfig()
        self.config = config or TriggerConfig()
        self._last_odometry: Odometry | None = None  # the last finite pose (kept over resets)
        self.reset()

    def reset(self) -> None:
        """Back to idle, forgetting every estimate."""
        self._phase = PHASE_IDLE
        self._seen = 0
        self._p0 = (0.0, 0.0, 0.0)
        self._heading = 0.0
        self._d0: float | None = None  # first-riser distance at p0
        self._extent = 0.0  # from the first riser to the far side of the last seen riser
        self._camera_z: float | None = None
        self._rises: list[list[float]] = []  # per accepted frame: the rise of each step, nearest first
        self._nearer = self._farther = self._empty = 0
        self._last = self._state(None)

    @property
    def state(self) -> TriggerState:
        """The latest decision."""
        return self._last

    def _travelled(self, odo: Odometry | None) -> float:
        if odo is None:
            return 0.0
        dx = odo.position_m[0] - self._p0[0]
        dy = odo.position_m[1] - self._p0[1]
        return dx * math.cos(self._heading) + dy * math.sin(self._heading)

    def _start(self, d: float, model: StairModel, odo: Odometry | None) -> None:
        self._d0 = d
        self._set_origin(odo)
        self._rises = [self._measured_rises(model)]
        self._extent = self._stair_extent(model)
        self._nearer = self._farther = self._empty = 0
        self._phase = PHASE_APPROACH

    def _set_origin(self, odo: Odometry | None) -> None:
        if odo is not None:
            self._p0 = tuple(float(v) for v in odo.position_m)  # type: ignore[assignment]
            self._heading = float(odo.yaw_rad)

    @staticmethod
    def _stair_extent(model: StairModel) -> float:
        last = model.steps[-1]
        return last.distance_m - model.steps[0].distance_m + (last.run_m or 0.0)

    def update(
        self, odometry: Odometry | None, model: StairModel | None = None, *, camera_z_m: float | None = None
    ) -> TriggerState:
        """Advance with new odometry and, when a frame was processed, its terrain and plan.

        Parameters
        ----------
        odometry : Odometry or None
            Body pose now; None when there is no odometry (travel then counts as zero, so
            only the measurements themselves bring the trigger closer). A pose with a NaN
            is none. Where earlier frames had poses, a frame without one counts the travel
            to the last pose and its terrain is not used (it cannot be placed).
        model : StairModel, optional
            The terrain (yaw frame) when a frame was processed.
        camera_z_m : float, optional
            Height of the camera in the model's frame. A tread above the camera cannot be
            seen, so the rise of such a step (beyond the first) is a guess and does not set
            the swing height; the robot sees it properly once it has climbed.
        """
        cfg = self.config
        self._camera_z = camera_z_m
        odometry = usable_odometry(odometry)
        if odometry is None and self._last_odometry is not None:
            # No pose this frame (dropped, or NaN) where there were poses: the travel is
            # counted to the last pose, and a terrain cannot be set against the origin.
            odometry, model = self._last_odometry, None
        elif odometry is not None:
            if self._last_odometry is None and self._d0 is not None:
                # The first pose: the travel so far counted none, so it counts from here.
                self._set_origin(odometry)
            self._last_odometry = odometry
        if model is not None:
            seen = model.obstacle != NONE and bool(model.steps)
            if self._phase == PHASE_IDLE:
                self._seen = self._seen + 1 if seen else 0
                if seen and self._seen >= cfg.confirm_frames:
                    self._start(model.steps[0].distance_m, model, odometry)
            elif self._phase in (PHASE_APPROACH, PHASE_BLOCKED):
                self._measure(odometry, model, seen)
        remaining = None if self._d0 is None else self._d0 - self._travelled(odometry)
        if self._phase in (PHASE_APPROACH, PHASE_BLOCKED) and remaining is not None:
            blocked = self._step_height() > self.swing.max_height_m
            self._phase = PHASE_BLOCKED if blocked else PHASE_APPROACH
            if not blocked and remaining <= self.swing.buffer_m:
                self._phase = PHASE_RAISED  # eq. 2: travelled >= d - d_buffer; latched
        if (
            self._phase == PHASE_RAISED
            and remaining is not None
            and remaining < -(self._extent + cfg.release_m)
        ):
            self.reset()
            remaining = None
        self._last = self._state(remaining)
        return self._last

    def _measure(self, odo: Odometry | None, model: StairModel, seen: bool) -> None:
        cfg = self.config
        assert self._d0 is not None
        predicted = self._d0 - self._travelled(odo)
        visible = predicted > cfg.min_visible_m
        if not seen:
            self._empty = self._empty + 1 if visible else 0
            if self._empty >= cfg.reacquire_frames:
                self.reset()  # it is gone while it should be in view: a false detection
            return
        self._empty = 0
        d = model.steps[0].distance_m
        if odo is None and (d < predicted or visible):
            predicted = d  # nothing to predict with: each measurement stands on its own
        if abs(d - predicted) <= cfg.gate_m:
            self._d0 = predicted + cfg.smoothing * (d - predicted)
            self._set_origin(odo)
            self._rises = (self._rises + [self._measured_rises(model)])[-cfg.history :]
            self._extent = max(self._extent, self._stair_extent(model))
            self._nearer = self._farther = 0
            return
        if d < predicted:
            self._nearer, self._farther = self._nearer + 1, 0
        else:
            # Farther than predicted: near the stairs the first riser is out of view and the
            # next riser is reported first; that is no reason to move the trigger.
            self._farther, self._nearer = (self._farther + 1 if visible else 0), 0
        if max(self._nearer, self._farther) >= cfg.reacquire_frames:
            self._start(d, model, odo)

    def _measured_rises(self, model: StairModel) -> list[float]:
        z = self._camera_z
        steps = model.steps
        return [rise_to_clear(s) for i, s in enumerate(steps) if i == 0 or z is None or s.top_z_m <= z]

    def _step_height(self) -> float:
        """Top-of-step height to clear: the highest per-step median rise over the recent
        accepted frames. Step ``i`` counts if at least half of them saw it, so one frame
        that merges a far step with the landing cannot raise the swing to the cap."""
        frames = self._rises
        best = 0.0
        for i in range(max((len(r) for r in frames), default=0)):
            rises = [r[i] for r in frames if len(r) > i]
            if 2 * len(rises) >= len(frames):
                best = max(best, self._median(rises))
        return best

    @staticmethod
    def _median(values: list[float]) -> float:
        s = sorted(values)
        n = len(s)
        return 0.0 if n == 0 else (s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2]))

    def _state(self, remaining: float | None) -> TriggerState:
        sw = self.swing
        idle = self._phase == PHASE_IDLE or self._d0 is None
        wanted = max(sw.nominal_height_m, self._step_height() + sw.clearance_m)
        height = sw.nominal_height_m if idle else min(wanted, sw.max_height_m)
        trigger = None if idle else max(0.0, self._d0 - sw.buffer_m)  # type: ignore[operator]
        return TriggerState(
            phase=self._phase,
            raise_swing=self._phase == PHASE_RAISED,
            swing_height_m=float(height),
            trigger_distance_m=trigger,
            remaining_m=remaining,
            p0_m=self._p0,
            heading_rad=self._heading,
            traversable=self._phase != PHASE_BLOCKED,
        )
