"""The two sweep threads, one per half of the CPUs."""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

_POOL: ThreadPoolExecutor | None = None


def cpu_halves() -> list[set[int]]:
    """The CPUs this process may use, split in two halves (one per sweep thread); an empty
    list where that cannot be done (one CPU, or no affinity on this system)."""
    if not hasattr(os, "sched_getaffinity"):
        return []
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) < 2:
        return []
    half = len(cpus) // 2
    return [set(cpus[:half]), set(cpus[half:])]


def _keep_to_own_cpus(halves: list[set[int]], which: Iterator[int]) -> None:
    """Pool initializer: the calling thread runs only on its half of the CPUs."""
    try:
        os.sched_setaffinity(0, halves[next(which) % len(halves)])  # 0: the calling thread
    except OSError:  # a CPU set changed under us, or not allowed: run anywhere
        pass


def sweep_pool() -> ThreadPoolExecutor:
    """One two-thread pool for the forward and backward sweeps, shared by all engines.

    Each thread keeps to its own half of the CPUs. Left free, the scheduler often woke
    both on the same core after an idle spell, and one sweep waited for the other: a call
    0.2 s after the previous one took 31-33 ms at 640x480x128 (median; quartiles 26-37 ms)
    instead of 26 ms (26-27 ms).
    """
    global _POOL
    if _POOL is None:
        halves = cpu_halves()
        if halves:
            _POOL = ThreadPoolExecutor(
                max_workers=2, thread_name_prefix="sgm", initializer=_keep_to_own_cpus,
                initargs=(halves, itertools.count()),
            )  # fmt: skip
        else:
            _POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="sgm")
    return _POOL
