"""Compiled inner loop of the coarse gravity estimate (Numba, :func:`stereo_terrain.gravity.estimate_up`).

Each up hypothesis is scored by the truncated squared sines of the sample normals' angles
to its nearest family. In NumPy that was five passes over an (S, H) float32 array (the
cosines squared, one minus them, two minima, a column sum: 600000 values for the default
2000 normals and 300 hypotheses, a few milliseconds; issue 13). Here it is one pass over
the cosines (kept from NumPy's matrix product, whose bits a loop would not reproduce),
in float32 and in NumPy's order: a sum along the first axis of a C-ordered array adds
the rows one after the other, from the first row's values. So the scores are the same
bit for bit. Compiled on first use and cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)  # no fastmath: NumPy's roundings, in NumPy's order
def truncated_family_error_sums(  # pragma: no cover - compiled
    cosines: np.ndarray, s2: np.float32
) -> np.ndarray:
    """Column sums of ``min(min(1 - c^2, c^2), s2)`` of the (S, H) float32 ``cosines``,
    in float32: ``np.minimum(np.minimum(1.0 - D2, D2), s2).sum(axis=0)`` with ``D2 =
    np.square(cosines)``. ``S`` must be at least 1."""
    n_rows, n_cols = cosines.shape
    out = np.empty(n_cols, dtype=np.float32)
    one = np.float32(1.0)
    for i in range(n_rows):
        for j in range(n_cols):
            c = cosines[i, j]
            d2 = c * c
            e = one - d2
            if d2 < e:
                e = d2
            if s2 < e:
                e = s2
            if i == 0:
                out[j] = e
            else:
                out[j] += e
    return out


@njit(cache=True, nogil=True)
def floor_inlier_counts(  # pragma: no cover - compiled
    dots: np.ndarray, offsets: np.ndarray, thresholds: np.ndarray, cosines: np.ndarray, min_cos: float
) -> np.ndarray:
    """Per hypothesis ``h``, the points ``j`` with ``|dots[h, j] + offsets[h]| <
    thresholds[j]`` and ``|cosines[h, j]| >= min_cos``: NumPy's
    ``((np.abs(dots + offsets[:, None]) < thresholds) & (np.abs(cosines) >= min_cos)).sum(axis=1)``
    in one pass (the same float64 sums and comparisons, so the same counts; for
    :func:`stereo_terrain.gravity.floor_up`)."""
    n_h, n_s = dots.shape
    out = np.zeros(n_h, dtype=np.int64)
    for h in range(n_h):
        off = offsets[h]
        k = 0
        for j in range(n_s):
            if abs(dots[h, j] + off) < thresholds[j] and abs(cosines[h, j]) >= min_cos:
                k += 1
        out[h] = k
    return out
