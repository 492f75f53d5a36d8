"""Compiled inner loops of the plane stage (Numba).

Scoring K plane hypotheses against M points is a K x M loop with a truncated quadratic
and a normal-agreement test per pair; in NumPy it builds several (K, M) temporaries, here
it is one pass with no allocation. Compiled on first use and cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit


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
            if use_normals:
                c = nx * point_normals[m, 0] + ny * point_normals[m, 1] + nz * point_normals[m, 2]
                if abs(c) < agreement_cos:
                    acc += 1.0
                    continue
            r = (nx * points[m, 0] + ny * points[m, 1] + nz * points[m, 2] + d) * inv_threshold[m]
            r2 = r * r
            acc += r2 if r2 < 1.0 else 1.0
        costs[k] = acc
    return costs
