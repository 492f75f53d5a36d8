"""Compiled inner loop of the terrain stage (Numba, :func:`stereo_terrain.terrain.risers._riser_edges`).

A riser's edge heights come from the samples near its plane: those inside its lateral
extent, connected in height to its own, cut into lateral slices whose low and high order
statistics are the slices' edges. In NumPy that was a dozen small operations per riser
candidate (issue 13: most of ``_riser_edges``' time); here it is one pass after a sort.
The residuals and lateral positions stay NumPy's (the caller computes them), the rest is
comparisons and look-ups, so the edges are the same bit for bit. Compiled on first use and
cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def riser_edge_slices(
    z: np.ndarray, lat: np.ndarray, v_lo: float, v_hi: float, seed_z: float, max_gap: float, bins: int
) -> tuple[int, np.ndarray, np.ndarray, float, float]:  # pragma: no cover - compiled
    """The slices' edge heights of one riser (see ``risers._riser_edges``).

    Parameters
    ----------
    z, lat : (N,) float64, height and lateral position of the samples near the plane
    v_lo, v_hi : float, the riser's lateral extent (exclusive bounds)
    seed_z : float, a height on the riser (its inliers' median)
    max_gap : float, largest gap in height within the riser's connected samples
    bins : int, lateral slices

    Returns
    -------
    kept : int, samples inside the extent (0: no edges)
    lows, highs : (S,) float64, the 2nd and 98th percentile sample of each slice with 3
        samples or more, in slice order
    lo_all, hi_all : float, the same of all the connected samples (for ``S == 0``)
    """
    n = 0
    for i in range(z.shape[0]):
        if lat[i] > v_lo and lat[i] < v_hi:
            n += 1
    zk = np.empty(n)
    lk = np.empty(n)
    j = 0
    for i in range(z.shape[0]):
        if lat[i] > v_lo and lat[i] < v_hi:
            zk[j] = z[i]
            lk[j] = lat[i]
            j += 1
    empty = np.empty(0)
    if n == 0:
        return 0, empty, empty, 0.0, 0.0
    # Sorted by height; samples of equal height may come in any order (each keeps its own
    # lateral position, and only the sorted heights are read).
    order = np.argsort(zk)
    zs = zk[order]
    ls = lk[order]
    # np.searchsorted(zs, seed_z) (left), clipped to a valid index.
    k = n
    for i in range(n):
        if zs[i] >= seed_z:
            k = i
            break
    k = min(max(k, 0), n - 1)
    lo_i = 0
    hi_i = n
    for i in range(n - 1):
        if zs[i + 1] - zs[i] > max_gap:
            if i < k:
                lo_i = i + 1
            else:
                hi_i = i + 1
                break
    width = max(v_hi - v_lo, 1e-9)
    counts = np.zeros(bins, np.int64)
    b_of = np.empty(hi_i - lo_i, np.int64)
    for i in range(lo_i, hi_i):
        b = int((ls[i] - v_lo) / width * bins)
        b = min(max(b, 0), bins - 1)
        b_of[i - lo_i] = b
        counts[b] += 1
    starts = np.zeros(bins + 1, np.int64)
    for b in range(bins):
        starts[b + 1] = starts[b] + counts[b]
    sorted_z = np.empty(hi_i - lo_i)
    fill = starts[:bins].copy()
    for i in range(lo_i, hi_i):
        b = b_of[i - lo_i]
        sorted_z[fill[b]] = zs[i]  # each slice's heights stay sorted
        fill[b] += 1
    lows = np.empty(bins)
    highs = np.empty(bins)
    s = 0
    for b in range(bins):
        c = counts[b]
        if c >= 3:
            lows[s] = sorted_z[starts[b] + int(0.02 * (c - 1) + 0.5)]
            highs[s] = sorted_z[starts[b] + int(0.98 * (c - 1) + 0.5)]
            s += 1
    m = hi_i - lo_i
    return n, lows[:s], highs[:s], zs[lo_i + int(0.02 * (m - 1) + 0.5)], zs[lo_i + int(0.98 * (m - 1) + 0.5)]
