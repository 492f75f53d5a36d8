"""Keep what native libraries print (libpng, libjpeg, OpenCV's logging) off the user's
terminal.

libpng and libjpeg write warnings such as ``Premature end of JPEG file`` straight to the C
``stderr`` (file descriptor 2), below Python's ``sys.stderr``; OpenCV logs ``[ERROR:0@...]``
lines there too. :func:`captured_native_stderr` routes descriptor 2 to a temporary file
around one call and hands back what was written, so that the caller can turn it into the
package's own message (a truncated JPEG is an :class:`~stereo_terrain.errors.InputError`)
or drop it. :func:`silence_opencv_logging` turns OpenCV's own logging off.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import tempfile
import threading
from collections.abc import Iterator

log = logging.getLogger(__name__)

_LOCK = threading.Lock()


class NativeOutput:
    """What native code wrote to descriptor 2 inside :func:`captured_native_stderr`."""

    def __init__(self) -> None:
        self.text = ""

    def lines(self) -> list[str]:
        return [line.strip() for line in self.text.splitlines() if line.strip()]


@contextlib.contextmanager
def captured_native_stderr() -> Iterator[NativeOutput]:
    """Route file descriptor 2 to a temporary file for the ``with`` body.

    Yields a :class:`NativeOutput` whose ``text`` holds what was written once the body
    ends. Where descriptor 2 cannot be redirected (no such descriptor), the body runs
    unchanged and ``text`` stays empty.
    """
    out = NativeOutput()
    with _LOCK:
        try:
            sys.stderr.flush()
        except (AttributeError, OSError, ValueError):
            pass
        try:
            saved = os.dup(2)
        except OSError:
            yield out
            return
        try:
            with tempfile.TemporaryFile() as tmp:
                os.dup2(tmp.fileno(), 2)
                try:
                    yield out
                finally:
                    os.dup2(saved, 2)
                    tmp.seek(0)
                    out.text = tmp.read(65536).decode("utf-8", errors="replace")
        finally:
            os.close(saved)
    if out.text:
        log.debug("native output: %s", out.text.strip())


def silence_opencv_logging() -> None:
    """Turn OpenCV's own logging (``[ WARN:0@...]``, ``[ERROR:0@...]`` lines) off."""
    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")
    try:
        import cv2

        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    except (ImportError, AttributeError):  # pragma: no cover - older OpenCV
        pass
