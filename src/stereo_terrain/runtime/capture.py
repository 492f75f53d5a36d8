"""Stereo capture: two cameras, two video files or a folder of recorded pairs.

Every source gives :class:`CaptureEvent` values from :meth:`read`: a timestamped
:class:`StereoFrame`, or ``none`` (no new pair yet), ``unreadable`` (a frame could not be
decoded) or ``end``. Sources never queue: a live source hands out the *newest* pair and
counts the frames it skipped, so the loop never works on stale images.

:class:`Capture` wraps a source and drops pairs whose left/right timestamps differ by
more than ``max_skew_s``: the paper (section 5) notes that a lag between the two frames
acts like a moved camera, i.e. a wrong extrinsic calibration, while the robot moves.

The recorded-pairs folder (written by :func:`record_pairs`, read by :class:`FolderPairs`)::

    DIR/pairs.csv             index,t_left,t_right,left,right[,x,y,z,roll,pitch,yaw]
    DIR/left_000000.png ...   raw (unrectified) grey images
    DIR/calib.yaml, rig.yaml  optional: used by ``replay`` when --calib/--rig are not given

Times are seconds; the optional pose columns are the body's odometry (world frame,
metres) and attitude (radians) at the pair's time, as a state estimator would give them.
"""

from __future__ import annotations

import csv
import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from ..errors import ConfigError, InputError
from ..odometry import Odometry
from ..rectify import check_same_size, read_image

log = logging.getLogger(__name__)

FRAME, NONE, UNREADABLE, SKEW, END = "frame", "none", "unreadable", "skew", "end"
PAIRS_FILE = "pairs.csv"
_POSE_KEYS = ("x", "y", "z", "roll", "pitch", "yaw")

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


# --------------------------------------------------------------------------- cameras


def parse_device(text: str) -> int | str:
    """A camera index (``0``) stays an int; anything else is a device path or video file."""
    return int(text) if text.strip().isdigit() else text


def _open_capture(device: int | str, what: str) -> cv2.VideoCapture:
    if isinstance(device, str) and not device.startswith(("/dev/", "rtsp:", "http:", "https:")):
        if not Path(device).exists():
            raise InputError(f"{what} video not found: {device} (give a camera index, /dev/videoN or a file)")
    # OpenCV logs its own warnings when a device cannot be opened; the error below says it.
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        cap = cv2.VideoCapture(device)
    finally:
        cv2.utils.logging.setLogLevel(level)
    if not cap.isOpened():
        cap.release()
        raise InputError(
            f"cannot open {what} camera/video {device!r}: not connected, in use, "
            "or not a video OpenCV can read"
        )
    return cap


class _LatestGrabber:
    """A thread that keeps reading one camera and holds only its newest frame.

    OpenCV (V4L2) keeps a few frames buffered; reading them at the loop's pace would hand
    out ever older images. Reading continuously and keeping the newest one avoids that.
    """

    def __init__(self, cap: cv2.VideoCapture, clock: Clock, name: str) -> None:
        self.cap = cap
        self.clock = clock
        self.lock = threading.Lock()
        self.frame: np.ndarray | None = None
        self.t = 0.0
        self.seq = 0
        self.failures = 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"grab-{name}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop.is_set():
            ok, img = self.cap.read()
            t = self.clock()
            if not ok or img is None:
                with self.lock:
                    self.failures += 1
                time.sleep(0.005)
                continue
            with self.lock:
                self.frame, self.t, self.seq = img, t, self.seq + 1

    def latest(self) -> tuple[np.ndarray | None, float, int, int]:
        with self.lock:
            return self.frame, self.t, self.seq, self.failures

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=1.0)
        self.cap.release()


class CameraPair:
    """Two live cameras (index or device path), newest pair on each :meth:`read`.

    Each image is stamped on ``clock`` when ``VideoCapture.read`` returned it.
    """

    def __init__(
        self,
        left: int | str,
        right: int | str,
        *,
        clock: Clock = time.monotonic,
        size: tuple[int, int] | None = None,
    ) -> None:
        caps = []
        for dev, what in ((left, "left"), (right, "right")):
            cap = _open_capture(dev, what)
            if size is not None:
                cap.set(cv2.CAP_PROP_FRAME_WIDTH, size[0])
                cap.set(cv2.CAP_PROP_FRAME_HEIGHT, size[1])
            cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)
            caps.append(cap)
        self.grabbers = [_LatestGrabber(c, clock, n) for c, n in zip(caps, ("left", "right"), strict=True)]
        self._last_seq = [0, 0]
        self._index = 0

    def read(self) -> CaptureEvent:
        (fl, tl, sl, _), (fr, tr, sr, _) = (g.latest() for g in self.grabbers)
        if fl is None or fr is None or sl == self._last_seq[0] or sr == self._last_seq[1]:
            return CaptureEvent(NONE)
        skipped = max(sl - self._last_seq[0], sr - self._last_seq[1]) - 1
        self._last_seq = [sl, sr]
        frame = StereoFrame(fl, fr, tl, tr, self._index)
        self._index += 1
        return CaptureEvent(FRAME, frame, max(0, skipped))

    def close(self) -> None:
        for g in self.grabbers:
            g.close()


# --------------------------------------------------------------------------- recorded sources


class _Sequential(Protocol):
    """A recorded source: frames in order with known timestamps."""

    def peek_time(self) -> float | None: ...

    def skip(self) -> None: ...

    def read(self) -> CaptureEvent: ...

    def close(self) -> None: ...


class VideoPair:
    """Two video files read in step; timestamps from the files (``CAP_PROP_POS_MSEC``)."""

    def __init__(self, left: str | Path, right: str | Path, *, loop: bool = False) -> None:
        self.paths = (str(left), str(right))
        self.caps = [_open_capture(p, w) for p, w in zip(self.paths, ("left", "right"), strict=True)]
        self.loop = loop
        self._index = 0
        self._offset = 0.0
        self._next: tuple[np.ndarray, np.ndarray, float, float] | None = None
        self._ended = False
        self._advance()

    def _grab_one(self) -> tuple[np.ndarray, np.ndarray, float, float] | None:
        got = []
        for cap in self.caps:
            ok, img = cap.read()
            if not ok:
                return None
            got.append((img, cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0))  # of the frame just read
        return got[0][0], got[1][0], got[0][1] + self._offset, got[1][1] + self._offset

    def _advance(self) -> None:
        nxt = self._grab_one()
        if nxt is None and self.loop and self._index > 0:
            last = self._next
            self._offset = (last[2] if last else 0.0) + 1.0 / 30.0
            for cap in self.caps:
                cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            nxt = self._grab_one()
        self._next = nxt
        self._ended = nxt is None

    def peek_time(self) -> float | None:
        return None if self._next is None else max(self._next[2], self._next[3])

    def skip(self) -> None:
        self._index += 1
        self._advance()

    def read(self) -> CaptureEvent:
        if self._next is None:
            return CaptureEvent(END)
        left, right, tl, tr = self._next
        frame = StereoFrame(left, right, tl, tr, self._index)
        self.skip()
        return CaptureEvent(FRAME, frame)

    def close(self) -> None:
        for cap in self.caps:
            cap.release()


@dataclass(frozen=True)
class _Row:
    t_left: float
    t_right: float
    left: Path
    right: Path
    pose: tuple[float, ...] | None
    t_pose: float | None = None  # the pose's recorded time where the replay moved t_left


def _pose_time(row: _Row) -> float:
    """The recorded time of a row's pose (the pause caps move the pairs, not the poses'
    clock: the odometry's jumps are judged on it, stereo_terrain.odometry)."""
    return row.t_left if row.t_pose is None else row.t_pose


#: Recorded times beyond this magnitude are not seconds (a clock in ns, a garbled file).
MAX_ABS_TIME_S = 1e11

#: A pause in a recording longer than this is replayed as this long (and said so): a
#: recording whose clock jumps by decades must not leave ``replay`` waiting forever.
MAX_REPLAY_GAP_S = 2.0


def read_pairs_index(folder: str | Path) -> list[_Row]:
    """Rows of ``folder/pairs.csv`` (see the module docstring).

    :class:`InputError` when the folder or the file is missing, unreadable, without the
    columns, or holds no usable row. A bad row among good ones (times that are not
    finite seconds, or earlier than the row before; image names missing) is a bad frame of
    the recording, not a bad recording: it is left out and one warning names how many and
    the first. A row repeating a kept one (the same times and images) is left out the same
    way. A pose that is not finite leaves the row without a pose (the live loop flags the
    frame)."""
    import io

    from ..checks import read_text_file

    folder = Path(folder)
    index = folder / PAIRS_FILE
    if not folder.exists():
        raise InputError(f"recorded pairs folder not found: {folder}")
    if not folder.is_dir():
        raise InputError(f"{folder} is not a folder of recorded pairs (it holds {PAIRS_FILE} and the images)")
    if not index.is_file():
        raise InputError(
            f"{folder} is not a recording: it has no {PAIRS_FILE}; record one with 'stereo-terrain record' "
            "or 'simulate --record' (replay also takes a ROS 2 bag or an MCAP file)"
        )
    text = read_text_file(index, "pairs index")
    rows: list[_Row] = []
    bad: list[str] = []  # why each left-out row was left out
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        need = {"t_left", "t_right", "left", "right"}
        if reader.fieldnames is None or not need <= set(reader.fieldnames):
            raise InputError(f"{index} must have the columns {sorted(need)}, got {reader.fieldnames}")
        has_pose = set(_POSE_KEYS) <= set(reader.fieldnames)
        lines: list[int] = []  # the file line of each kept row
        for rec in reader:
            why = _bad_row(rec, rows[-1] if rows else None, has_pose)
            if why == _EARLIER and len(rows) >= 2 and _bad_row(rec, rows[-2], has_pose) == "":
                # Earlier than the row before, not than the one before that: that row's
                # time was the glitch (one row 1e6 s ahead would leave out all the rest).
                rows.pop()
                bad.append(f"line {lines.pop()}: {_EARLIER} (after it, line {reader.line_num} is earlier)")
                why = ""
            if why:
                bad.append(f"line {reader.line_num}: {why}")
                continue
            t_left, t_right = float(rec["t_left"]), float(rec["t_right"])
            left, right = folder / rec["left"], folder / rec["right"]
            same = _repeat_of(rows, t_left, t_right, left, right)
            if same is not None:
                bad.append(f"line {reader.line_num}: a repeat of line {lines[same]}")
                continue
            lines.append(reader.line_num)
            pose = tuple(float(rec[k]) for k in _POSE_KEYS) if has_pose else None
            if pose is not None and not all(math.isfinite(v) for v in pose):
                pose = None
            rows.append(_Row(t_left, t_right, left, right, pose))
    except csv.Error as exc:
        raise InputError(f"{index} is not a readable CSV file: {exc}") from None
    if not rows:
        first = f" ({bad[0]})" if bad else ""
        raise InputError(f"{index} lists no pairs{first}")
    if len(bad) > len(rows):
        total = len(bad) + len(rows)
        raise InputError(f"{index}: most rows are bad ({len(bad)} of {total}; the first, {bad[0]})")
    if bad:
        log.warning("%s: %d bad row(s) left out (the first, %s)", index, len(bad), bad[0])
    return rows


def _repeat_of(rows: list[_Row], t_left: float, t_right: float, left: Path, right: Path) -> int | None:
    """Index in ``rows`` of the row with these times and images (the pose aside), or None.

    A recording that lists a pair twice (a row copied, a writer that retried) would replay
    that frame twice. Times never decrease in ``rows``, so only the last rows of the same
    time need a look."""
    t = max(t_left, t_right)
    for k in range(len(rows) - 1, -1, -1):
        r = rows[k]
        if max(r.t_left, r.t_right) < t:
            return None
        if (r.t_left, r.t_right, r.left, r.right) == (t_left, t_right, left, right):
            return k
    return None


def _bad_row(rec: dict, previous: _Row | None, has_pose: bool) -> str:
    """Why a ``pairs.csv`` row cannot be replayed, or "" when it can."""
    try:
        t_left, t_right = float(rec["t_left"]), float(rec["t_right"])
        if has_pose:
            tuple(float(rec[k]) for k in _POSE_KEYS)
    except (TypeError, ValueError, OverflowError):
        return "times and pose must be numbers"
    left, right = rec["left"], rec["right"]
    if not left or not right or "\x00" in left + right:
        return "left and right must be image file names"
    if not (math.isfinite(t_left) and math.isfinite(t_right)):
        return "times must be finite numbers"
    if max(abs(t_left), abs(t_right)) > MAX_ABS_TIME_S:
        return f"times must be seconds (|t| <= {MAX_ABS_TIME_S:g})"
    if previous is not None and max(t_left, t_right) < max(previous.t_left, previous.t_right):
        return _EARLIER
    return ""


_EARLIER = "pair times must not decrease"


def replay_step_s(times: Sequence[float] | np.ndarray) -> float:
    """The mean time between a recording's pairs (``times`` in order), at least 1/30 s:
    what a looped replay leaves between its last pair and its first (never zero, or the
    replay would never get past a pair)."""
    n = len(times)
    mean = (float(times[-1]) - float(times[0])) / (n - 1) if n > 1 else 0.0
    return max(mean, 1.0 / 30.0)


def _capped_gaps(rows: list[_Row], index: Path) -> list[_Row]:
    """``rows`` with every pause longer than :data:`MAX_REPLAY_GAP_S` shortened to it (a
    warning names the first and how many)."""
    out: list[_Row] = []
    shift, long_gaps, first = 0.0, 0, ""
    for i, r in enumerate(rows):
        if i:
            gap = max(r.t_left, r.t_right) - max(rows[i - 1].t_left, rows[i - 1].t_right)
            if gap > MAX_REPLAY_GAP_S:
                long_gaps += 1
                first = first or f"line {i + 2}: {gap:.3g} s"
                shift += gap - MAX_REPLAY_GAP_S
        out.append(
            _Row(r.t_left - shift, r.t_right - shift, r.left, r.right, r.pose, _pose_time(r)) if shift else r
        )
    if long_gaps:
        log.warning(
            "%s: %d pause(s) longer than %.1f s (the first at %s) replayed as %.1f s",
            index, long_gaps, MAX_REPLAY_GAP_S, first, MAX_REPLAY_GAP_S,
        )  # fmt: skip
    return out


class FolderPairs:
    """Pairs recorded in a folder (``pairs.csv`` + images), in order, optionally repeated."""

    def __init__(self, folder: str | Path, *, loop: bool = False) -> None:
        self.rows = _capped_gaps(read_pairs_index(folder), Path(folder) / PAIRS_FILE)
        self.loop = loop
        self._i = 0
        self._lap = 0  # of the last pair read
        t = [max(r.t_left, r.t_right) for r in self.rows]
        step = replay_step_s(t)
        self._period = t[-1] - t[0] + step
        # The same on the poses' own clock (uncapped): each lap's poses come after the last's.
        self._pose_period = _pose_time(self.rows[-1]) - _pose_time(self.rows[0]) + step

    def __len__(self) -> int:
        return len(self.rows)

    def _row(self) -> tuple[_Row, float] | None:
        n = len(self.rows)
        if self._i >= n and not self.loop:
            return None
        return self.rows[self._i % n], (self._i // n) * self._period

    def peek_time(self) -> float | None:
        got = self._row()
        return None if got is None else max(got[0].t_left, got[0].t_right) + got[1]

    def peek_time_after(self) -> float | None:
        """Time of the pair after the next one."""
        self._i += 1
        try:
            return self.peek_time()
        finally:
            self._i -= 1

    def skip(self) -> None:
        self._i += 1

    def read(self) -> CaptureEvent:
        got = self._row()
        if got is None:
            return CaptureEvent(END)
        row, offset = got
        index = self._i
        self._i += 1
        try:  # what libpng/libjpeg print goes into the detail, not to the terminal
            left, right = read_image(row.left), read_image(row.right)
        except InputError as exc:
            return CaptureEvent(UNREADABLE, detail=str(exc))
        lap = index // len(self.rows)
        restart, self._lap = lap > self._lap, lap  # (its first pair may have been skipped)
        odo = rpy = None
        if row.pose is not None:
            x, y, z, roll, pitch, yaw = row.pose
            # a looped replay's later laps come later on the poses' clock too
            odo = Odometry((x, y, z), yaw, _pose_time(row) + lap * self._pose_period)
            rpy = (roll, pitch, yaw)
        frame = StereoFrame(
            left, right, row.t_left + offset, row.t_right + offset, index, odo, rpy, restart=restart
        )
        return CaptureEvent(FRAME, frame)

    def close(self) -> None:
        pass


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


def open_devices(left: str, right: str, *, clock: Clock = time.monotonic) -> PairSource:
    """Two cameras, or two video files (played in real time) from command-line strings."""
    dl, dr = parse_device(left), parse_device(right)
    files = [isinstance(d, str) and not d.startswith("/dev/") and Path(d).is_file() for d in (dl, dr)]
    if all(files):
        return Paced(VideoPair(str(dl), str(dr)), clock=clock)
    if any(files):
        side, other = ("right", dr) if files[0] else ("left", dl)
        if isinstance(other, str) and not other.startswith("/dev/"):
            what = "is a folder" if Path(other).is_dir() else "does not exist"
            raise InputError(f"{side} video {other} {what}; give two video files or two cameras")
        raise InputError("give two cameras or two video files, not one of each")
    return CameraPair(dl, dr, clock=clock)


# --------------------------------------------------------------------------- recording


class PairWriter:
    """Writes pairs into a recorded-pairs folder (``pairs.csv`` + PNGs); a context manager.

    The pose columns are written when the first frame has odometry and attitude. A writer
    closed with no pair written leaves nothing behind (no empty recording that a second
    try would then refuse).
    """

    def __init__(self, out_dir: str | Path) -> None:
        self.out = Path(out_dir)
        self._created = not self.out.exists()
        try:
            self.out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot create {self.out}: {exc.strerror}") from None
        if (self.out / PAIRS_FILE).exists():
            raise InputError(f"{self.out} already holds a recording ({PAIRS_FILE}); choose a new folder")
        self._fh = (self.out / PAIRS_FILE).open("w", newline="")
        self._writer = csv.writer(self._fh)
        self._with_pose: bool | None = None
        self.count = 0

    def write(self, f: StereoFrame) -> None:
        if self._with_pose is None:
            self._with_pose = f.odometry is not None and f.body_rpy is not None
            header = ["index", "t_left", "t_right", "left", "right"]
            self._writer.writerow(header + (list(_POSE_KEYS) if self._with_pose else []))
        n = self.count
        names = (f"left_{n:06d}.png", f"right_{n:06d}.png")
        for name, img in zip(names, (f.left, f.right), strict=True):
            if not cv2.imwrite(str(self.out / name), np.ascontiguousarray(img)):
                raise InputError(f"cannot write {self.out / name}")
        row = [str(n), f"{f.t_left_s:.6f}", f"{f.t_right_s:.6f}", *names]
        if self._with_pose:
            if f.odometry is None or f.body_rpy is None:
                raise InputError(f"pair {f.index} has no pose but the recording has pose columns")
            row += [f"{v:.6f}" for v in (*f.odometry.position_m, *f.body_rpy)]
        self._writer.writerow(row)
        self._fh.flush()
        self.count += 1

    def close(self) -> None:
        if self._fh.closed:
            return
        self._fh.close()
        if self.count == 0:
            (self.out / PAIRS_FILE).unlink(missing_ok=True)
            if self._created and not any(self.out.iterdir()):
                self.out.rmdir()

    def __enter__(self) -> PairWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def record_pairs(
    capture: Capture,
    out_dir: str | Path,
    *,
    max_pairs: int = 0,
    max_duration_s: float = 0.0,
    clock: Clock = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> int:
    """Save synchronized pairs (skew-checked by ``capture``) with their timestamps.

    Writes a recorded-pairs folder (see the module docstring) into ``out_dir``; stops
    after ``max_pairs`` pairs or ``max_duration_s`` seconds (0: no limit) or at the
    source's end. Ctrl-C stops cleanly: what was recorded is kept. Returns the number of
    pairs written.
    """
    start = clock()
    with PairWriter(out_dir) as writer:
        try:
            while not (max_pairs and writer.count >= max_pairs):
                if max_duration_s and clock() - start >= max_duration_s:
                    break
                ev = capture.read()
                if ev.status == END:
                    break
                if ev.status == FRAME and ev.frame is not None:
                    writer.write(ev.frame)
                elif ev.status == NONE:
                    sleep(0.002)
        except KeyboardInterrupt:
            log.info("recording interrupted after %d pairs", writer.count)
        return writer.count


def write_pairs(out_dir: str | Path, frames: Iterable[StereoFrame]) -> int:
    """Write frames (with their poses, if any) as a recorded-pairs folder; returns the count."""
    with PairWriter(out_dir) as writer:
        for f in frames:
            writer.write(f)
        return writer.count
