"""Compiled inner loops of MSAC (Numba).

Scoring K plane hypotheses against M points is a K x M loop with a truncated quadratic
and a normal-agreement test per pair; in NumPy it builds several (K, M) temporaries, here
it is one pass with no allocation. Compiled on first use and cached on disk. The plane
stage's region kernels (``planes/_kernels.py``) build on the two inlined helpers here.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, inline="always")
def point_cost(
    nx, ny, nz, d, points, point_normals, inv_threshold, m, agreement_cos, use_normals
):  # pragma: no cover
    """MSAC cost of point ``m`` for the plane ``(nx, ny, nz) . x + d = 0``: its truncated
    squared residual in threshold units, 1 when its normal disagrees (``use_normals``)."""
    if use_normals:
        c = nx * point_normals[m, 0] + ny * point_normals[m, 1] + nz * point_normals[m, 2]
        if abs(c) < agreement_cos:
            return 1.0
    r = (nx * points[m, 0] + ny * points[m, 1] + nz * points[m, 2] + d) * inv_threshold[m]
    r2 = r * r
    return r2 if r2 < 1.0 else 1.0


@njit(cache=True, nogil=True, inline="always")
def plane_through(points, i, j, k):  # pragma: no cover
    """Unit normal and offset of the plane through points ``i, j, k`` (differences taken in
    the points' dtype, products in float64); ``valid`` False when they are collinear."""
    p0 = points[i]
    a = points[j] - p0
    b = points[k] - p0
    nx = float(a[1]) * b[2] - float(a[2]) * b[1]
    ny = float(a[2]) * b[0] - float(a[0]) * b[2]
    nz = float(a[0]) * b[1] - float(a[1]) * b[0]
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    if norm <= 1e-9:
        return 0.0, 0.0, 0.0, 0.0, False
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    return nx, ny, nz, -(nx * p0[0] + ny * p0[1] + nz * p0[2]), True


@njit(cache=True, nogil=True)  # no fastmath: same sums on every CPU
def msac_costs(
    normals: np.ndarray,
    offsets: np.ndarray,
    points: np.ndarray,
    inv_threshold: np.ndarray,
    point_normals: np.ndarray,
    agreement_cos: float,
) -> np.ndarray:  # pragma: no cover - compiled
    """MSAC cost of each hypothesis: ``sum_m min((r_km / t_m)^2, 1)``, where a point whose
    normal disagrees with the hypothesis (``|n_k . n_m| < agreement_cos``) costs 1.

    ``point_normals`` with zero rows disables the agreement test.
    """
    k_count = normals.shape[0]
    m_count = points.shape[0]
    use_normals = point_normals.shape[0] == m_count
    costs = np.empty(k_count, dtype=np.float32)
    for k in range(k_count):
        nx, ny, nz, d = normals[k, 0], normals[k, 1], normals[k, 2], offsets[k]
        acc = np.float32(0.0)
        for m in range(m_count):
            acc += point_cost(
                nx, ny, nz, d, points, point_normals, inv_threshold, m, agreement_cos, use_normals
            )
        costs[k] = acc
    return costs
