"""The process's threads around a frame (issue 13): the BLAS libraries held to one
thread while a frame runs, and the one worker thread that overlaps the matcher."""

from __future__ import annotations

import contextlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

_BLAS: list[Any] = []  # the process's BLAS libraries (threadpoolctl), see find_blas


def find_blas() -> None:
    """Look up the process's BLAS libraries now (threadpoolctl; about 3 ms), for
    :func:`one_blas_thread`. Each ``Pipeline(...)`` does, after its warm-up has loaded
    what its frames use."""
    from threadpoolctl import ThreadpoolController

    _BLAS[:] = [ThreadpoolController().select(user_api="blas")]


def one_blas_thread() -> contextlib.AbstractContextManager[Any]:
    """A context that holds the BLAS libraries (NumPy's OpenBLAS) to one thread while a
    frame runs on the main thread, and gives the caller's setting back after it.

    The pipeline's matrix products are small (hundreds of plane hypotheses times a few
    thousand points) and gain nothing from a second BLAS thread, but after each threaded
    call OpenBLAS leaves its workers spinning for a while, and on two cores they take one
    from the disparity matcher of the next frame: OpenCV's 3-way SGBM right after a frame
    without a rig took 36 ms instead of 25 (docs/benchmarks.md, "Fifth session: frames
    without a rig"). OpenBLAS's setting is process-wide: frames run at once in other
    threads would save and restore each other's values (and could leave the process at
    one thread), so a frame on another thread leaves it alone. The CLI, the live loop and
    ``bench`` run frames on the main thread. Libraries loaded after the last
    ``Pipeline(...)`` are not limited."""
    if threading.current_thread() is not threading.main_thread():
        return contextlib.nullcontext()
    if not _BLAS:
        find_blas()
    return _BLAS[0].limit(limits=1)


_BACKGROUND: dict[int, ThreadPoolExecutor] = {}


def background() -> ThreadPoolExecutor:
    """The process's one worker thread for work that overlaps the disparity matcher (shared
    by every pipeline, so that many pipelines do not leave many idle threads). Keyed by
    process id: a child forked after a frame has no thread behind its parent's executor,
    and would wait on it forever."""
    pid = os.getpid()
    if pid not in _BACKGROUND:
        _BACKGROUND.clear()
        _BACKGROUND[pid] = ThreadPoolExecutor(max_workers=1, thread_name_prefix="stereo-terrain")
    return _BACKGROUND[pid]
