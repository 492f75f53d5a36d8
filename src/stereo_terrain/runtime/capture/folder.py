"""The recorded-pairs folder (``pairs.csv`` and the images; the package docstring gives
its layout): :func:`read_pairs_index` reads its index, :class:`FolderPairs` plays it."""

from __future__ import annotations

import csv
import logging
import math
from dataclasses import dataclass
from pathlib import Path

from ...errors import InputError
from ...odometry import Odometry
from ...rectify import read_image
from .events import END, FRAME, UNREADABLE, CaptureEvent, StereoFrame
from .pacing import replay_step_s

log = logging.getLogger(__name__)

PAIRS_FILE = "pairs.csv"
POSE_KEYS = ("x", "y", "z", "roll", "pitch", "yaw")


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
    """Rows of ``folder/pairs.csv`` (see the package docstring).

    :class:`InputError` when the folder or the file is missing, unreadable, without the
    columns, or holds no usable row. A bad row among good ones (times that are not
    finite seconds, or earlier than the row before; image names missing) is a bad frame of
    the recording, not a bad recording: it is left out and one warning names how many and
    the first. A row repeating a kept one (the same times and images) is left out the same
    way. A pose that is not finite leaves the row without a pose (the live loop flags the
    frame)."""
    import io

    from ...checks import read_text_file

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
        has_pose = set(POSE_KEYS) <= set(reader.fieldnames)
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
            pose = tuple(float(rec[k]) for k in POSE_KEYS) if has_pose else None
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
            tuple(float(rec[k]) for k in POSE_KEYS)
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
