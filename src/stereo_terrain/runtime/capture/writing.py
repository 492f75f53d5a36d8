"""Recording: :class:`PairWriter` writes a recorded-pairs folder, :func:`record_pairs`
fills one from a live source, :func:`write_pairs` from frames in hand."""

from __future__ import annotations

import csv
import logging
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from ...errors import InputError
from ...rectify import write_image
from .events import END, FRAME, NONE, Capture, Clock, StereoFrame
from .folder import PAIRS_FILE, POSE_KEYS

log = logging.getLogger(__name__)


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
            self._writer.writerow(header + (list(POSE_KEYS) if self._with_pose else []))
        n = self.count
        names = (f"left_{n:06d}.png", f"right_{n:06d}.png")
        for name, img in zip(names, (f.left, f.right), strict=True):
            write_image(self.out / name, img)
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

    Writes a recorded-pairs folder (see the package docstring) into ``out_dir``; stops
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
