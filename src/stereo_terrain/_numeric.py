"""Small numeric helpers that give NumPy's exact results with less overhead (issue 13).

``np.percentile`` spends 20-40 microseconds in its general machinery whatever the size of
the data; the terrain stage calls it a dozen times a frame on lists of a few values.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, overload

import numpy as np


@overload
def percentile(values: Sequence[float] | np.ndarray, q: float) -> np.float64: ...
@overload
def percentile(values: Sequence[float] | np.ndarray, q: Sequence[float]) -> np.ndarray: ...
def percentile(values: Sequence[float] | np.ndarray, q: Any) -> Any:
    """``np.percentile(values, q)`` (method ``linear``) for one-dimensional float data.

    The same arithmetic as NumPy's (virtual index ``(n - 1) q / 100``, its floor and
    fraction, NumPy's two-sided linear interpolation), so the same bits. Anything other
    than a non-empty 1-D float64 array without NaN, or ``q`` outside ``[0, 100]``, is
    handed to ``np.percentile`` itself.

    Returns
    -------
    np.float64 for a scalar ``q``, else a (len(q),) float64 array.
    """
    a = np.asarray(values)
    scalar = np.ndim(q) == 0
    qs = [float(q)] if scalar else [float(v) for v in np.asarray(q, dtype=np.float64).reshape(-1)]
    if (
        a.ndim != 1
        or a.dtype != np.float64
        or len(a) == 0
        or np.ndim(q) > 1
        or not all(0.0 <= v <= 100.0 for v in qs)
        or np.isnan(a).any()
    ):
        return np.percentile(a, q)
    n = len(a)
    picks = []
    for qi in qs:
        vi = (n - 1) * (qi / 100.0)  # NumPy: q / 100, then (n - 1) * q
        if vi >= n - 1:  # NumPy's index -1 (the last), gamma against it; b - a is 0 there
            lo, hi, t = -1, -1, vi + 1.0
        else:
            lo = int(math.floor(vi))
            hi, t = lo + 1, vi - lo
        picks.append((lo, hi, t))
    # NumPy's partition, with NumPy's kth (np.unique of 0, -1 and the indices), so that
    # equal values such as -0.0 and 0.0 land where they land there.
    part = np.partition(a, sorted({0, -1, *(p[0] for p in picks), *(p[1] for p in picks)}))
    out = []
    for lo, hi, t in picks:
        x, y = float(part[lo]), float(part[hi])
        d = y - x
        out.append(y - d * (1.0 - t) if t >= 0.5 else x + d * t)  # NumPy's _lerp
    return np.float64(out[0]) if scalar else np.array(out)


def group_percentile(
    values: np.ndarray, groups: np.ndarray, n_groups: int, q: Sequence[float], min_count: int = 1
) -> np.ndarray:
    """``percentile(values[groups == k], q)`` for every group ``k`` in ``0 .. n_groups - 1``
    at once, as a ``(len(q), n_groups)`` array (NaN for a group of fewer than
    ``min_count`` values, at least 1): one sort instead of a mask and a call per group.
    ``values`` 1-D float64 without NaN, ``q`` within ``[0, 100]``; the same arithmetic as
    :func:`percentile` (NumPy's virtual index and two-sided interpolation), so the same
    values; only the sign of a zero may differ (equal values are ordered by a sort here,
    by NumPy's partition there)."""
    counts = np.bincount(groups, minlength=n_groups)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    ok = counts >= max(min_count, 1)
    out = np.full((len(q), n_groups), np.nan)
    if not ok.any():
        return out
    ordered = values[np.lexsort((values, groups))]  # by group, then value
    n = counts[ok].astype(np.float64)
    for row, qi in enumerate(q):
        vi = (n - 1) * (float(qi) / 100.0)
        last = vi >= n - 1  # NumPy's index -1 (the last value); b - a is 0 there
        lo = np.where(last, n - 1, np.floor(vi)).astype(np.int64)
        t = np.where(last, 1.0, vi - np.floor(vi))
        x, y = ordered[starts[ok] + lo], ordered[starts[ok] + np.where(last, lo, lo + 1)]
        d = y - x
        out[row, ok] = np.where(t >= 0.5, y - d * (1.0 - t), x + d * t)  # NumPy's _lerp
    return out


def median(values: Sequence[float] | np.ndarray, axis: int | None = None) -> Any:
    """``np.median(values, axis)`` for a float64 array, 1-D (``axis`` None or 0) or 2-D
    along ``axis=0``, or a 1-D float32 one.

    NumPy's partition (same kth) and its mean of the middle one or two values (``(0 + x) / 1``,
    ``(0 + x + y) / 2``), so the same bits; NaN, other dtypes, shapes or axes, and empty input
    are handed to ``np.median``.
    """
    a = np.asarray(values)
    if a.dtype == np.float32 and a.ndim == 1 and axis in (None, 0) and a.shape[0] and not np.isnan(a).any():
        # float32: np.mean's float32 sum and division (NumPy keeps a float32 mean float32).
        n = a.shape[0]
        h = n // 2
        part = np.partition(a, [h - 1, h, -1] if n % 2 == 0 else [(n - 1) // 2, -1])
        zero = np.float32(0.0)
        if n % 2:
            return (zero + part[h]) / np.float32(1.0)
        return (zero + part[h - 1] + part[h]) / np.float32(2.0)
    if (
        a.dtype != np.float64
        or a.ndim not in (1, 2)
        or (a.ndim == 1 and axis not in (None, 0))
        or (a.ndim == 2 and axis != 0)
        or a.shape[0] == 0
        or np.isnan(a).any()
    ):
        return np.median(a, axis=axis)
    n = a.shape[0]
    h = n // 2
    part = np.partition(a, [h - 1, h, -1] if n % 2 == 0 else [(n - 1) // 2, -1], axis=0)
    # np.mean's sum starts from its identity, +0.0 (which turns a -0.0 into 0.0).
    if a.ndim == 1:
        return np.float64((0.0 + part[h]) / 1.0 if n % 2 else (0.0 + part[h - 1] + part[h]) / 2.0)
    return (0.0 + part[h]) / 1.0 if n % 2 else (0.0 + part[h - 1] + part[h]) / 2.0


def cross3(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray) -> np.ndarray:
    """``np.cross`` of two 3-vectors: its products and differences in float64, in its
    order (the same bits), without its general machinery's ~30 us a call (issue 13)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def wrap_angle(a: float) -> float:
    """``a`` (radians) wrapped into ``[-pi, pi)``."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi
