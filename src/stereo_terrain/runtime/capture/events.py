"""What a stereo source gives (:class:`StereoFrame`, :class:`CaptureEvent` and its
statuses, :class:`PairSource`) and :class:`Capture`, which drops pairs whose two images
were taken too far apart and counts what was dropped."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ...errors import ConfigError, InputError
from ...odometry import Odometry
from ...rectify import check_same_size

FRAME, NONE, UNREADABLE, SKEW, END = "frame", "none", "unreadable", "skew", "end"

Clock = Callable[[], float]


@dataclass(frozen=True)
class StereoFrame:
    """One raw stereo pair with its capture times.

    Attributes
    ----------
    left, right : (H, W) uint8 or (H, W, 3) uint8
        Raw (unrectified) images.
    t_left_s, t_right_s : float
        Capture time of each image, seconds, on the loop's clock.
    index : int
        Index of the pair in its source.
    odometry : Odometry or None
        Body pose at the pair's time when the source knows it (a recording with poses).
    body_rpy : (3,) float or None
        Body roll, pitch, yaw w.r.t. gravity, radians, when the source knows it.
    stamp_s : float or None
        Capture time of the pair on the source's own clock, seconds since the epoch, when
        it has one (a bag's header stamps); kept when :class:`Paced` moves the times onto
        the loop's clock, so outputs can carry the original stamps.
    restart : bool
        The first pair of a looped source's next round: it starts over (the loop forgets
        the odometry's jump history, :class:`~stereo_terrain.odometry.PoseJumps`).
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    t_left_s: float
    t_right_s: float
    index: int
    odometry: Odometry | None = None
    body_rpy: tuple[float, float, float] | None = None
    stamp_s: float | None = None
    restart: bool = False

    @property
    def t_capture_s(self) -> float:
        """Capture time of the pair: the later of the two images."""
        return max(self.t_left_s, self.t_right_s)

    @property
    def skew_s(self) -> float:
        """|t_left - t_right|, seconds."""
        return abs(self.t_left_s - self.t_right_s)


@dataclass(frozen=True)
class CaptureEvent:
    """What one :meth:`PairSource.read` gave.

    Attributes
    ----------
    status : str
        ``frame``, ``none`` (nothing new yet), ``unreadable``, ``skew`` (dropped by
        :class:`Capture`) or ``end``.
    frame : StereoFrame or None
    skipped : int
        Pairs that arrived since the previous event and were superseded by this one.
    detail : str
    """

    status: str
    frame: StereoFrame | None = None
    skipped: int = 0
    detail: str = ""


class PairSource(Protocol):
    """Anything that gives stereo pairs."""

    def read(self) -> CaptureEvent: ...

    def close(self) -> None: ...


@dataclass
class CaptureStats:
    """Counts kept by :class:`Capture`, and why the first pair was dropped (if one was)."""

    pairs: int = 0
    skew_dropped: int = 0
    unreadable: int = 0
    skipped: int = 0
    empty_polls: int = 0
    first_problem: str = ""


class Capture:
    """A source plus the left/right skew limit and the counts of what was dropped.

    Parameters
    ----------
    source : PairSource
    max_skew_s : float
        Pairs whose images were taken further apart than this are dropped (``skew``).
    """

    def __init__(self, source: PairSource, max_skew_s: float = 0.015) -> None:
        if not max_skew_s >= 0:
            raise ConfigError(f"max_skew_s must be >= 0 seconds, got {max_skew_s}")
        self.source = source
        self.max_skew_s = float(max_skew_s)
        self.stats = CaptureStats()

    def read(self) -> CaptureEvent:
        ev = self.source.read()
        self.stats.skipped += ev.skipped
        frame = ev.frame
        if ev.status == FRAME and frame is not None:
            try:
                check_same_size(frame.left, frame.right)
            except InputError as exc:
                ev = CaptureEvent(UNREADABLE, None, ev.skipped, f"pair {frame.index}: {exc}")
            else:
                if frame.skew_s > self.max_skew_s:
                    ev = CaptureEvent(SKEW, frame, ev.skipped, f"left/right skew {frame.skew_s * 1e3:.1f} ms")
                    self.stats.skew_dropped += 1
                else:
                    self.stats.pairs += 1
        if ev.status == UNREADABLE:
            self.stats.unreadable += 1
        elif ev.status == NONE:
            self.stats.empty_polls += 1
        if ev.status in (UNREADABLE, SKEW) and not self.stats.first_problem:
            self.stats.first_problem = ev.detail
        return ev

    def close(self) -> None:
        self.source.close()
