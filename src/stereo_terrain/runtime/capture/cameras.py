"""Live cameras (:class:`CameraPair`, each read by its own thread that keeps the newest
frame) and two video files read in step (:class:`VideoPair`); :func:`open_devices` opens
either from command-line strings."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import cv2
import numpy as np

from ...errors import InputError
from .events import END, FRAME, NONE, CaptureEvent, Clock, PairSource, StereoFrame
from .pacing import Paced


def parse_device(text: str) -> int | str:
    """A camera index (``0``) stays an int; anything else is a device path or video file."""
    return int(text) if text.strip().isdigit() else text


def _open_capture(device: int | str, what: str) -> cv2.VideoCapture:
    if isinstance(device, str):
        try:
            device.encode("utf-8")
        except UnicodeEncodeError:
            # OpenCV's VideoCapture crashes the process on such a name (Python hands it a str
            # with surrogate escapes); its reader takes no bytes.
            raise InputError(
                f"{what} video {device!r}: its name is not UTF-8, which OpenCV's video reader "
                "cannot open; rename the file"
            ) from None
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


def open_devices(
    left: str, right: str, *, clock: Clock = time.monotonic, realtime: bool = True
) -> PairSource:
    """Two cameras, or two video files (played in real time, or with ``realtime=False``
    every pair as fast as the loop takes them) from command-line strings. Cameras give
    their frames at their own rate: ``realtime=False`` with them is an
    :class:`InputError`."""
    dl, dr = parse_device(left), parse_device(right)
    files = [isinstance(d, str) and not d.startswith("/dev/") and Path(d).is_file() for d in (dl, dr)]
    if all(files):
        return Paced(VideoPair(str(dl), str(dr)), clock=clock, realtime=realtime)
    if any(files):
        side, other = ("right", dr) if files[0] else ("left", dl)
        if isinstance(other, str) and not other.startswith("/dev/"):
            what = "is a folder" if Path(other).is_dir() else "does not exist"
            raise InputError(f"{side} video {other} {what}; give two video files or two cameras")
        raise InputError("give two cameras or two video files, not one of each")
    if not realtime:
        raise InputError("--as-fast needs two video files: cameras give their frames at their own rate")
    return CameraPair(dl, dr, clock=clock)
