"""Recorded sources played against a clock (:class:`Paced`), and the times that pair two
streams of images (:func:`match_stamps`) and space a looped replay (:func:`replay_step_s`)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from ...errors import ConfigError
from .events import END, NONE, CaptureEvent, Clock


def match_stamps(t_left: np.ndarray, t_right: np.ndarray) -> list[tuple[int, int]]:
    """Pair two streams of image stamps (seconds, each in time order): ``(i, j)`` when left
    image ``i`` and right image ``j`` are each other's nearest in time.

    Every image is in at most one pair, in time order. How far apart a pair's two images
    are is not judged here: :class:`Capture` drops pairs skewed beyond ``max_skew_s``, the
    rule of the live cameras, so a recorded source pairs exactly as the cameras do.
    """
    tl = np.asarray(t_left, dtype=np.float64).reshape(-1)
    tr = np.asarray(t_right, dtype=np.float64).reshape(-1)
    if len(tl) == 0 or len(tr) == 0:
        return []

    def nearest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        j = np.clip(np.searchsorted(b, a), 1, len(b) - 1) if len(b) > 1 else np.zeros(len(a), dtype=np.int64)
        if len(b) > 1:
            j = np.where(np.abs(b[j - 1] - a) <= np.abs(b[j] - a), j - 1, j)
        return j

    jl = nearest(tl, tr)
    ir = nearest(tr, tl)
    return [(i, int(j)) for i, j in enumerate(jl) if ir[j] == i]


class _Sequential(Protocol):
    """A recorded source: frames in order with known timestamps."""

    def peek_time(self) -> float | None: ...

    def skip(self) -> None: ...

    def read(self) -> CaptureEvent: ...

    def close(self) -> None: ...


def replay_step_s(times: Sequence[float] | np.ndarray) -> float:
    """The mean time between a recording's pairs (``times`` in order), at least 1/30 s:
    what a looped replay leaves between its last pair and its first (never zero, or the
    replay would never get past a pair)."""
    n = len(times)
    mean = (float(times[-1]) - float(times[0])) / (n - 1) if n > 1 else 0.0
    return max(mean, 1.0 / 30.0)


class Paced:
    """Plays a recorded source against a clock: at each :meth:`read` the newest pair whose
    recorded time has come (older ones are skipped and counted, never queued).

    Capture times are moved onto ``clock`` (``t_clock = start + (t_rec - t_first) / speed``),
    so latency is measured as it would be live. With ``realtime=False`` every pair is
    given in order as fast as the loop takes them, stamped with the clock when read.
    """

    def __init__(
        self, source: _Sequential, *, clock: Clock = time.monotonic, realtime: bool = True, speed: float = 1.0
    ) -> None:
        if not speed > 0:
            raise ConfigError(f"replay speed must be > 0, got {speed}")
        self.source = source
        self.clock = clock
        self.realtime = realtime
        self.speed = float(speed)
        self._start: float | None = None
        self._t0 = 0.0

    def _restamp(self, ev: CaptureEvent, now: float) -> CaptureEvent:
        f = ev.frame
        if f is None:
            return ev
        if self.realtime:
            tl = self._start + (f.t_left_s - self._t0) / self.speed  # type: ignore[operator]
            tr = self._start + (f.t_right_s - self._t0) / self.speed  # type: ignore[operator]
        else:
            # Keep the recorded skew, stamp the later image with the time it was read.
            tl = now - max(0.0, f.t_right_s - f.t_left_s)
            tr = now - max(0.0, f.t_left_s - f.t_right_s)
        return CaptureEvent(
            ev.status, dataclasses.replace(f, t_left_s=tl, t_right_s=tr), ev.skipped, ev.detail
        )

    def read(self) -> CaptureEvent:
        now = self.clock()
        if not self.realtime:
            return self._restamp(self.source.read(), now)
        t_next = self.source.peek_time()
        if t_next is None:
            return CaptureEvent(END)
        if self._start is None:
            self._start, self._t0 = now, t_next
        due = self._t0 + (now - self._start) * self.speed
        if t_next > due:
            return CaptureEvent(NONE)
        skipped = 0
        peek_after = getattr(self.source, "peek_time_after", None)
        if peek_after is not None:
            # Skip superseded pairs by their recorded times, without decoding them.
            while (following := peek_after()) is not None and following <= due:
                self.source.skip()
                skipped += 1
        ev = self.source.read()
        # Video files decode one pair ahead: drop what is read while a newer pair is due too.
        while (following := self.source.peek_time()) is not None and following <= due:
            ev = self.source.read()
            skipped += 1
        return CaptureEvent(ev.status, self._restamp(ev, now).frame, skipped, ev.detail)

    def close(self) -> None:
        self.source.close()
