"""The real-time loop: newest pair -> pipeline -> swing trigger -> terrain message.

One pair is processed at a time and it is always the newest one the source has (sources
skip, never queue). Whatever goes wrong with a frame (no frame for a while, an unreadable
or corrupt frame, a left/right skew beyond the limit, an error inside the pipeline) is
counted, flagged in the next message's ``quality`` bits, and the loop goes on. While no
fresh terrain arrives, the last one is re-sent every ``heartbeat_s`` marked ``stale`` with
its age, so the controller never acts on old terrain without knowing it.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TextIO

import numpy as np

from ..checks import check_fields
from ..errors import ConfigError, InputError, StereoTerrainError
from ..frames import Rig
from ..odometry import Odometry, PoseJumpConfig, PoseJumps
from ..pipeline import Pipeline, TerrainResult
from ..swing import SwingTrigger, TriggerState
from ..terrain import NONE as NO_OBSTACLE
from ..terrain import StairModel
from ..tracking import TRACK_NONE, StairTracker, single_frame_model
from .capture import END, FRAME, NONE, SKEW, UNREADABLE, Capture, Clock, StereoFrame
from .messages import terrain_message, terrain_t

log = logging.getLogger(__name__)

#: Set by :func:`request_stop` (the SIGTERM handler): the live loop stops at the next frame
#: boundary even when the interrupt itself surfaced inside a compiled kernel or a library as
#: an ordinary error, which the loop would otherwise count as one failed frame and go on.
_stop_requested = threading.Event()


def request_stop() -> None:
    """Ask every running :class:`LiveLoop` to stop, as Ctrl-C does (signal-handler safe)."""
    _stop_requested.set()


#: Pairs whose latencies the summary keeps.
LATENCY_WINDOW = 20_000

#: Pose provider: the body pose for a frame (odometry and roll/pitch/yaw), either may be None.
PoseProvider = Callable[[StereoFrame | None], tuple[Odometry | None, tuple[float, float, float] | None]]


@dataclass(frozen=True)
class LoopConfig:
    """Live-loop parameters, seconds.

    Attributes
    ----------
    max_skew_s : float
        Pairs whose left and right images are further apart in time are dropped.
    stall_timeout_s : float
        No fresh pair for this long counts as a stall; messages are then marked stale.
    heartbeat_s : float
        While stalled, the last terrain is re-sent (stale) this often.
    status_interval_s : float
        How often the status line is refreshed.
    poll_s : float
        Sleep when the source has no new pair.
    max_frames : int
        Stop after this many processed pairs (0: no limit).
    max_duration_s : float
        Stop after this long (0: no limit).
    pose_jumps : PoseJumpConfig
        When a step between two stamped poses is a jump of the state estimator's frame
        (a glitch, a relocalisation), not travel (:class:`~stereo_terrain.odometry.PoseJumps`).
    max_unusable_start : int
        Consecutive unusable pairs (unreadable, wrong size, skewed, refused by the pipeline)
        before the first usable one after which the loop stops with an :class:`InputError`
        naming the reason (wrong calibration size, wrong sources); later runs of unusable
        pairs are warned about every ``max_unusable_start`` pairs and the loop goes on.
    denoised_every : int
        While the pipeline's second opinions keep nothing they run on every other pair;
        the denoised ones (``PipelineConfig.rematch_denoised``, the dearest: about 150 ms
        of a 640x480 pair here) run on every ``denoised_every``-th of those: with 2, on
        every fourth pair. 1: whenever the others run. Once any second opinion keeps
        something, every pair runs them all again.
    """

    max_skew_s: float = 0.015
    stall_timeout_s: float = 0.5
    heartbeat_s: float = 0.1
    status_interval_s: float = 0.5
    poll_s: float = 0.002
    max_frames: int = 0
    max_duration_s: float = 0.0
    max_unusable_start: int = 10
    pose_jumps: PoseJumpConfig = field(default_factory=PoseJumpConfig)
    denoised_every: int = 2

    def __post_init__(self) -> None:
        check_fields(self)
        if self.max_unusable_start < 1:
            raise ConfigError(f"LoopConfig.max_unusable_start must be >= 1, got {self.max_unusable_start}")
        if self.denoised_every < 1:
            raise ConfigError(f"LoopConfig.denoised_every must be >= 1, got {self.denoised_every}")
        for name in ("max_skew_s", "stall_timeout_s", "heartbeat_s", "status_interval_s", "poll_s"):
            if getattr(self, name) < 0:
                raise ConfigError(f"LoopConfig.{name} must be >= 0 seconds, got {getattr(self, name)}")
        if self.max_frames < 0 or self.max_duration_s < 0:
            raise ConfigError("LoopConfig.max_frames and max_duration_s must be >= 0 (0: no limit)")


@dataclass
class LoopSummary:
    """What the loop did; :meth:`format` gives the report printed at exit."""

    processed: int = 0
    published: int = 0
    heartbeats: int = 0
    skew_dropped: int = 0
    unreadable: int = 0
    failed: int = 0
    skipped: int = 0
    bad_poses: int = 0
    pose_jumps: int = 0  # jumps of the state estimator's frame taken out (PoseJumps)
    stalls: int = 0
    stalled_s: float = 0.0
    elapsed_s: float = 0.0
    interrupted: bool = False
    # Bounded, so that memory stays flat however long the loop runs: the latency quantiles
    # are over the last LATENCY_WINDOW pairs (about 11 minutes at 30 fps).
    latencies_s: deque[float] = field(default_factory=lambda: deque(maxlen=LATENCY_WINDOW), repr=False)
    periods_s: deque[float] = field(default_factory=lambda: deque(maxlen=30), repr=False)

    @property
    def fps(self) -> float:
        """Processed pairs per second over the run."""
        return self.processed / self.elapsed_s if self.elapsed_s > 0 else 0.0

    def latency_ms(self, q: float) -> float:
        """Capture-to-publish latency quantile ``q`` (0..100) over the last ``LATENCY_WINDOW``
        pairs, milliseconds (NaN if none)."""
        return float(np.percentile(self.latencies_s, q)) * 1e3 if self.latencies_s else math.nan

    def format(self) -> str:
        end = "interrupted" if self.interrupted else "done"
        return (
            f"{end}: {self.processed} pairs in {self.elapsed_s:.1f} s ({self.fps:.1f} fps); latency "
            f"median {self.latency_ms(50):.0f} ms, p99 {self.latency_ms(99):.0f} ms; published "
            f"{self.published} ({self.heartbeats} stale heartbeats); dropped: skew {self.skew_dropped}, "
            f"unreadable {self.unreadable}, failed {self.failed}, superseded {self.skipped}; "
            f"bad poses ignored {self.bad_poses}; odometry jumps {self.pose_jumps}; "
            f"stalls {self.stalls} ({self.stalled_s:.1f} s)"
        )


#: Quality bits that describe how a terrain was made (kept by the heartbeats that re-send
#: it), as opposed to the events since the previous message.
_CONDITIONS = terrain_t.QUALITY_GRAVITY_FROM_FLOOR | terrain_t.QUALITY_POSE_MISSING


def _finite_pose(odo: Odometry | None, rpy: tuple[float, float, float] | None) -> bool:
    """Whether the odometry and attitude that are given hold only finite numbers."""
    values = list(rpy or ())
    if odo is not None:
        values += [*odo.position_m, odo.yaw_rad]
    return all(math.isfinite(v) for v in values)


def rig_pose(rig: Rig | None) -> PoseProvider:
    """Pose provider from the rig file: its body attitude, no odometry."""

    def pose(frame: StereoFrame | None) -> tuple[Odometry | None, tuple[float, float, float] | None]:
        if frame is not None and (frame.odometry is not None or frame.body_rpy is not None):
            return frame.odometry, frame.body_rpy
        return None, (None if rig is None else rig.body_rpy)

    return pose


def track_and_trigger(
    tracker: StairTracker | None,
    trigger: SwingTrigger,
    terrain: StairModel,
    odometry: Odometry | None,
    t_s: float,
    *,
    camera_z_m: float | None = None,
    floor_z_m: float | None = None,
) -> tuple[StairModel, str, TriggerState]:
    """One frame's terrain through the tracker (when there is one) and the swing trigger.

    Returns the model to publish (the tracked staircase while there is a track, also a
    tentative one, else the frame's), the track state and the trigger's decision. With a
    tracker, the trigger sees only an established (confirmed or coasting) track, and
    nothing ahead before that. Without one, the frame's model is published with
    :func:`~stereo_terrain.tracking.single_frame_model` for the robot's floor height
    ``floor_z_m`` (``TrackingConfig.floor_z_m``; None: unknown).
    """
    if tracker is None:
        published = single_frame_model(terrain, floor_z_m)
        return published, TRACK_NONE, trigger.update(odometry, terrain, camera_z_m=camera_z_m)
    tracked = tracker.update(terrain, odometry, t_s)
    # No tracked model (no track, or a frame without a pose): the frame itself, with the
    # single-frame sigmas and floor check, not as if it were the fused track.
    model = single_frame_model(terrain, floor_z_m) if tracked.model is None else tracked.model
    ahead = model
    if not tracked.established:  # nothing confirmed ahead yet: the trigger waits for the track
        ahead = dataclasses.replace(terrain, obstacle=NO_OBSTACLE, steps=())
    return model, tracked.state, trigger.update(odometry, ahead, camera_z_m=camera_z_m)


class LiveLoop:
    """Runs the pipeline on the newest pairs of a source and publishes terrain messages.

    Parameters
    ----------
    capture : Capture
        The source with its skew limit (``LoopConfig.max_skew_s`` is applied here).
    pipeline : Pipeline
    publish : callable(terrain_t)
        E.g. :class:`~stereo_terrain.runtime.lcm_io.LcmPublisher`, or a list's ``append``.
    trigger : SwingTrigger, optional
        Defaults to one with the pipeline's swing config.
    pose : PoseProvider, optional
        Body pose per frame: from the recording, an LCM state listener or the rig.
    config : LoopConfig
    clock, sleep : callables
        Injectable for tests (a fake clock makes a 2 s stall instant).
    status : text stream or None
        Where the live status line goes (stderr in the CLI).
    tracker : StairTracker or None, optional
        Fuses the frames into one staircase (issue 14); by default one with the pipeline
        config's ``tracking`` section when ``tracking.enabled`` (the default), else none
        (single frames). Once its track is confirmed (or coasting) the messages carry the
        tracked staircase and the swing trigger follows it; before that the messages carry
        the frame's model and the trigger sees nothing ahead.
    """

    def __init__(
        self,
        capture: Capture,
        pipeline: Pipeline,
        publish: Callable[[terrain_t], None],
        *,
        trigger: SwingTrigger | None = None,
        pose: PoseProvider | None = None,
        config: LoopConfig | None = None,
        clock: Clock = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        status: TextIO | None = None,
        on_result: Callable[[StereoFrame, TerrainResult], None] | None = None,
        tracker: StairTracker | None = None,
    ) -> None:
        self.config = config or LoopConfig()
        self.capture = capture
        self.capture.max_skew_s = self.config.max_skew_s
        self.pipeline = pipeline
        self.publish = publish
        self.trigger = trigger or SwingTrigger(pipeline.config.swing)
        self.pose = pose or rig_pose(pipeline.rig)
        # The state estimator's frame jumps (glitch, relocalisation) are no travel: every pose
        # goes through this before the tracker and the trigger see it.
        self.pose_jumps = PoseJumps(self.config.pose_jumps)
        self._jumps_before = 0  # taken out before the source last started over
        self.clock = clock
        self.sleep = sleep
        self.status = status
        self.on_result = on_result
        tracking = pipeline.config.tracking
        self.tracker = (
            tracker if tracker is not None else (StairTracker(tracking) if tracking.enabled else None)
        )
        self._last_model: StairModel | None = None  # what the last message carried
        self._last_track_state = TRACK_NONE
        self.summary = LoopSummary()
        self.epoch_offset_s = time.time() - time.monotonic() if clock is time.monotonic else 0.0
        self._quality = 0
        # The conditions (not events) of the last fresh message: a heartbeat re-sends that
        # terrain, so it says what that terrain was made with.
        self._last_conditions = terrain_t.QUALITY_POSE_MISSING  # nothing yet: no pose either
        self._last_result: TerrainResult | None = None
        self._last_capture: float | None = None
        self._last_index = -1
        self._last_latency = math.nan
        self._last_fresh: float | None = None
        self._last_publish = -math.inf
        self._stalled_since: float | None = None
        self._last_status = -math.inf
        self._rpy: tuple[float, float, float] | None = None
        self._unusable_run = 0  # consecutive unusable pairs
        self._unusable_detail = ""
        self._last_failure: Exception | None = None
        self._rematched_nothing = False  # the last pair ran second opinions, which kept nothing
        self._idle_opinions = 0  # pairs since one kept something (or none was needed) that ran them

    def warm_up(self) -> None:
        """Run the pipeline once on a blank pair of the calibration's size so that the first
        real pair does not pay the matcher's first-call allocations. The compiled kernels
        were loaded when the pipeline was built (``Pipeline(warm_up=True)``), so no rendered
        scene is needed (rendering one cost about 1 s and 65 MB at start; issue 13)."""
        w, h = self.pipeline.calibration.image_size
        blank = np.full((h, w), 128, np.uint8)
        self.pipeline.run(blank, blank)
        self.pipeline.reset_drift()  # the blank pair must not count as evidence of drift

    # ----------------------------------------------------------------- one iteration

    def step(self) -> bool:
        """One read of the source and what follows; False at the source's end."""
        now = self.clock()
        if self._last_fresh is None:
            self._last_fresh = now
        ev = self.capture.read()
        self.summary.skipped += ev.skipped
        if ev.status == END:
            self._check_anything_usable()
            return False
        if ev.status == FRAME and ev.frame is not None:
            self._process(ev.frame)
        elif ev.status == SKEW:
            self.summary.skew_dropped += 1
            self._quality |= terrain_t.QUALITY_SKEW_DROPPED
            log.info("pair dropped: %s", ev.detail)
            self._unusable(f"pair skewed: {ev.detail}")
        elif ev.status == UNREADABLE:
            self._unreadable(ev.detail)
        elif ev.status == NONE:
            self._idle(now)
        self._show_status()
        return True

    def _unreadable(self, detail: str) -> None:
        self.summary.unreadable += 1
        self._quality |= terrain_t.QUALITY_UNREADABLE
        log.info("unreadable pair: %s", detail)
        self._unusable(detail)

    def _unusable(self, detail: str) -> None:
        """Count a pair that gave no terrain; stop (before any usable pair) or say it loudly
        (after) once ``max_unusable_start`` come in a row: a wrong calibration size or
        wrong sources make every pair unusable, and the user must see why."""
        self._unusable_run += 1
        self._unusable_detail = self._unusable_detail or detail
        n = self.config.max_unusable_start
        if self._unusable_run < n:
            return
        if self.summary.processed == 0:
            self._stop_unusable()
        elif self._unusable_run % n == 0:
            log.warning("%d pairs in a row gave no terrain; the latest: %s", self._unusable_run, detail)

    def _stop_unusable(self) -> None:
        if self._last_failure is not None and self._unusable_run == self.summary.failed:
            raise self._last_failure  # an internal error on every pair: exit 1, not a user error
        raise InputError(
            f"none of the first {self._unusable_run} pair(s) was usable, so nothing was processed; "
            f"the first: {self._unusable_detail}"
        )

    def _check_anything_usable(self) -> None:
        """At the source's end: a source all of whose pairs were unusable is an error."""
        if self.summary.processed == 0 and self._unusable_run > 0:
            self._stop_unusable()

    def _process(self, frame: StereoFrame) -> None:
        size = self.pipeline.calibration.image_size
        for img in (frame.left, frame.right):
            if (
                not isinstance(img, np.ndarray)
                or img.dtype != np.uint8
                or img.ndim not in (2, 3)
                or (img.shape[1], img.shape[0]) != size
            ):
                shape = getattr(img, "shape", None)
                got = f"{shape[1]}x{shape[0]}" if shape is not None and len(shape) >= 2 else repr(shape)
                self._unreadable(
                    f"pair {frame.index}: image {got} {getattr(img, 'dtype', '')} is not a "
                    f"{size[0]}x{size[1]} uint8 frame like the calibration"
                )
                return
        odo, rpy = self.pose(frame)
        if not _finite_pose(odo, rpy):
            # A bad pose from the state estimator or a recording (NaN, inf): ignore it for
            # this pair (the last good attitude stays; no odometry, flagged), and go on.
            self.summary.bad_poses += 1
            log.warning("pair %d: body pose ignored (not finite): %s, %s", frame.index, odo, rpy)
            odo, rpy = None, None
        if frame.restart:  # a looped source started over: its poses begin again too
            self._jumps_before += self.pose_jumps.jumps
            self.pose_jumps.reset()
        odo = self._without_jumps(odo)
        if rpy is not None and rpy != self._rpy and self.pipeline.rig is not None:
            # The body attitude from the state estimator (paper eq. 1) for this frame.
            self.pipeline.set_rig(dataclasses.replace(self.pipeline.rig, body_rpy=rpy))
            self._rpy = rpy
        try:
            # While the pipeline's second opinions (the rematch and the coarse rematch, for
            # frames whose first pass finds nothing convincing or steps that disagree, the
            # far planes where no pass finds anything, the same two rematches on the pair
            # denoised) keep nothing, they run on every other pair: a flat floor costs 3
            # passes a pair, not 5, and stairs are seen one pair later at most (issue 11).
            # The denoised ones, the dearest, run on every denoised_every-th of those
            # (stairs only they find: three pairs later at most with 2).
            if self._rematched_nothing:
                result = self.pipeline.run(frame.left, frame.right, rematch=False)
            elif self._idle_opinions % self.config.denoised_every:
                result = self.pipeline.run(frame.left, frame.right, denoised=False)
            else:
                result = self.pipeline.run(frame.left, frame.right)
        except StereoTerrainError as exc:
            self._unreadable(f"pair {frame.index}: {exc}")
            return
        except Exception as exc:  # keep running on the robot; the traceback goes to the log
            if _stop_requested.is_set():
                raise KeyboardInterrupt from exc  # a stop that surfaced as this error
            self.summary.failed += 1
            self._quality |= terrain_t.QUALITY_UNREADABLE
            log.warning("pipeline failed on pair %d", frame.index, exc_info=True)
            self._last_failure = exc
            self._unusable(f"pair {frame.index}: internal error {type(exc).__name__}: {exc}")
            return
        ran = any(k in result.timing_ms for k in ("rematch", "far_planes", "redraw", "denoise"))
        if not self._rematched_nothing:  # this pair could run them
            self._idle_opinions = self._idle_opinions + 1 if ran and not result.rematched else 0
        self._rematched_nothing = ran and not result.rematched
        model, track_state, trig = track_and_trigger(
            self.tracker,
            self.trigger,
            result.terrain,
            odo,
            frame.t_capture_s,
            camera_z_m=float(result.T_yaw_camera_rect.translation[2]),
            floor_z_m=self.pipeline.config.tracking.floor_z_m,
        )
        now = self.clock()
        latency = now - frame.t_capture_s
        if self._stalled_since is not None:
            self.summary.stalled_s += now - self._stalled_since
            self._stalled_since = None
        quality = self._quality
        if result.gravity_source != "rig":
            quality |= terrain_t.QUALITY_GRAVITY_FROM_FLOOR
        if odo is None:
            quality |= terrain_t.QUALITY_POSE_MISSING
        msg = terrain_message(
            model,
            self._in_estimator_frame(trig),
            capture_s=frame.t_capture_s,
            publish_s=now,
            frame_index=frame.index,
            latency_s=latency,
            density=result.disparity.density,
            quality=quality,
            stale=latency > self.config.stall_timeout_s,
            epoch_offset_s=self.epoch_offset_s,
            track_state=track_state,
        )
        self.publish(msg)
        self._last_model, self._last_track_state = model, track_state
        self._last_conditions = quality & _CONDITIONS
        self._quality = 0
        self._unusable_run, self._unusable_detail = 0, ""
        s = self.summary
        if self._last_capture is not None:
            s.periods_s.append(frame.t_capture_s - self._last_capture)
        s.processed += 1
        s.published += 1
        s.latencies_s.append(latency)
        self._last_result, self._last_capture, self._last_index = result, frame.t_capture_s, frame.index
        self._last_latency = latency
        self._last_fresh = self._last_publish = now
        if self.on_result is not None:
            self.on_result(frame, result)

    def _idle(self, now: float) -> None:
        assert self._last_fresh is not None
        cfg = self.config
        if now - self._last_fresh > cfg.stall_timeout_s:
            if self._stalled_since is None:
                self._stalled_since = self._last_fresh
                self.summary.stalls += 1
                log.info("no fresh pair for %.2f s", now - self._last_fresh)
            self._quality |= terrain_t.QUALITY_STALLED
            if now - self._last_publish >= cfg.heartbeat_s:
                self._heartbeat(now)
        self.sleep(cfg.poll_s)

    def _without_jumps(self, odo: Odometry | None) -> Odometry | None:
        """``odo`` through :class:`PoseJumps` (None: a pose delivered late), the summary's
        count of jumps taken out kept up to date."""
        odo = self.pose_jumps.correct(odo)
        self.summary.pose_jumps = self._jumps_before + self.pose_jumps.jumps
        return odo

    def _in_estimator_frame(self, trig: TriggerState) -> TriggerState:
        """The trigger's decision with its origin (``p0_m``, ``heading_rad``) in the state
        estimator's own frame, the one a controller compares with its odometry (the
        trigger counts in the frame without the jumps: :class:`PoseJumps`)."""
        if self.pose_jumps.jumps == 0:
            return trig
        p0, heading = self.pose_jumps.to_raw(trig.p0_m, trig.heading_rad)
        if not self.pose_jumps.settled:
            # Just after a jump the estimator's frame is not yet known (a glitch, or a
            # relocalisation the next pose confirms): the origin is in neither for sure, so no
            # distance is given this once; the controller goes by ``raise_swing``.
            return dataclasses.replace(trig, p0_m=p0, heading_rad=heading, trigger_distance_m=None)
        return dataclasses.replace(trig, p0_m=p0, heading_rad=heading)

    def _heartbeat(self, now: float) -> None:
        # A live pose source (the state estimator) has a pose between pairs: the trigger
        # moves on with it. A recording's poses come with its pairs, so a replay has none
        # here: the trigger and the terrain re-sent are those of the last pair, and so is
        # its pose flag (missing only if that pair had no pose; found in review: every
        # heartbeat of a replay with poses said the pose was missing).
        odo, _ = self.pose(None)
        if not _finite_pose(odo, None):
            odo = None  # as for a pair (a NaN is no pose)
        given = odo
        odo = self._without_jumps(odo)
        trig = self.trigger.update(odo) if odo is not None else self.trigger.state
        conditions = self._last_conditions
        if odo is not None:
            conditions &= ~terrain_t.QUALITY_POSE_MISSING
        elif given is not None:
            conditions |= terrain_t.QUALITY_POSE_MISSING  # a pose delivered late: dropped
        result = self._last_result
        capture = self._last_capture if self._last_capture is not None else self._last_fresh
        assert capture is not None
        msg = terrain_message(
            self._last_model,
            self._in_estimator_frame(trig),
            capture_s=capture,
            publish_s=now,
            frame_index=self._last_index,
            latency_s=self._last_latency,
            density=0.0 if result is None else result.disparity.density,
            quality=self._quality | conditions,
            stale=True,
            epoch_offset_s=self.epoch_offset_s,
            track_state=self._last_track_state,
        )
        self.publish(msg)
        self.summary.published += 1
        self.summary.heartbeats += 1
        self._last_publish = now

    # ----------------------------------------------------------------- status and run

    def status_line(self) -> str:
        s = self.summary
        recent = list(itertools.islice(reversed(s.latencies_s), 30))
        lat = f"{1e3 * float(np.median(recent)):.0f}" if recent else "-"
        periods = list(s.periods_s)
        rate = f"{1.0 / float(np.mean(periods)):.1f}" if periods and np.mean(periods) > 0 else "-"
        t = self.trigger.state
        ahead = "-"
        if self._last_result is not None and self._last_result.terrain.steps:
            st = self._last_result.terrain.steps[0]
            ahead = f"{self._last_result.terrain.obstacle} {st.distance_m:.2f}m"
        stale = " STALE" if self._stalled_since is not None else ""
        return (
            f"{s.processed} pairs {rate} fps lat {lat} ms | {ahead} | {t.phase} swing {t.swing_height_m:.2f}"
            f" | drop skew {s.skew_dropped} bad {s.unreadable + s.failed} stall {s.stalls}{stale}"
        )

    def _show_status(self) -> None:
        if self.status is None:
            return
        now = self.clock()
        if now - self._last_status >= self.config.status_interval_s:
            self.status.write("\r" + self.status_line().ljust(100)[:110])
            self.status.flush()
            self._last_status = now

    def run(self) -> LoopSummary:
        """Loop until the source ends, a limit is reached or Ctrl-C; returns the summary."""
        cfg = self.config
        start = self.clock()
        _stop_requested.clear()
        try:
            while True:
                if _stop_requested.is_set():
                    raise KeyboardInterrupt
                if cfg.max_frames and self.summary.processed >= cfg.max_frames:
                    break
                if cfg.max_duration_s and self.clock() - start >= cfg.max_duration_s:
                    break
                if not self.step():
                    break
        except KeyboardInterrupt:
            self.summary.interrupted = True
        finally:
            self.summary.elapsed_s = self.clock() - start
            if self._stalled_since is not None:
                self.summary.stalled_s += self.clock() - self._stalled_since
                self._stalled_since = None
            self.capture.close()
            if self.status is not None:
                self.status.write("\n")
                self.status.flush()
        return self.summary
