"""Compiled inner loops of the plane stage (Numba): per-region MSAC of the contour method
and the oriented hypotheses of the orientation method. The per-point cost and the plane
through three points come from ``msac._kernels``. Compiled on first use and cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..msac._kernels import plane_through, point_cost


@njit(cache=True, nogil=True)
def region_msac(
    points: np.ndarray,
    normals: np.ndarray,
    inv_threshold: np.ndarray,
    grid_lut: np.ndarray,
    grid_row: np.ndarray,
    grid_col: np.ndarray,
    inside: np.ndarray,
    seeds: np.ndarray,
    score: np.ndarray,
    radius: int,
    batch: int,
    max_trials: int,
    confidence: float,
    agreement_cos: float,
    uniform: np.ndarray,
) -> tuple[np.ndarray, float, float, int]:  # pragma: no cover - compiled
    """Adaptive plane MSAC inside one image region, hypotheses of any orientation.

    Each trial draws a first point from ``seeds`` and two more within ``radius`` grid cells
    of it that are also ``inside`` the region; the plane through them is scored on the
    points ``score`` (truncated quadratic, a point whose normal disagrees costs 1). Trials
    run in batches until ``max_trials``, or until an all-inlier sample has been drawn with
    probability ``confidence`` given the best hypothesis' inlier ratio (``w**3``).

    ``uniform`` is ``(A, 5)`` floats in [0, 1) from the caller's generator (the randomness
    stays in one seeded place): one row per attempt; an attempt whose sample is invalid
    (outside the region, repeated or collinear points) is no trial, and no more than ``A``
    attempts are made.

    Returns ``(normal (3,), offset, cost, trials)``; cost is inf when no valid sample was
    drawn.
    """
    span = 2 * radius + 1
    gh, gw = grid_lut.shape
    best_n = np.zeros(3)
    best_d = 0.0
    best_cost = np.inf
    trials = 0
    budget = max_trials
    log_fail = np.log(1.0 - confidence)
    n_seeds = seeds.shape[0]
    m_count = score.shape[0]
    attempts = 0
    n_attempts = uniform.shape[0]
    while trials < budget and attempts < n_attempts:
        for _ in range(batch):
            if attempts >= n_attempts:
                break
            u = uniform[attempts]
            attempts += 1
            i0 = seeds[min(int(u[0] * n_seeds), n_seeds - 1)]
            js = np.empty(2, dtype=np.int64)
            ok = True
            for t in range(2):
                r = min(max(grid_row[i0] + int(u[1 + 2 * t] * span) - radius, 0), gh - 1)
                c = min(max(grid_col[i0] + int(u[2 + 2 * t] * span) - radius, 0), gw - 1)
                j = grid_lut[r, c]
                if j < 0 or not inside[j] or j == i0:
                    ok = False
                    break
                js[t] = j
            if not ok or js[0] == js[1]:
                continue
            nx, ny, nz, d, valid = plane_through(points, i0, js[0], js[1])
            if not valid:
                continue
            trials += 1
            cost = 0.0
            inl = 0
            for k in range(m_count):
                c = point_cost(nx, ny, nz, d, points, normals, inv_threshold, score[k], agreement_cos, True)
                cost += c
                if c < 1.0:
                    inl += 1
                if cost >= best_cost:
                    break  # cannot win; its inlier count is used only when it does
            if cost < best_cost:
                best_cost = cost
                best_n[0], best_n[1], best_n[2] = nx, ny, nz
                best_d = d
                w = inl / max(m_count, 1)
                p_good = w * w * w
                if p_good >= 1.0 - 1e-12:
                    need = 1
                elif p_good <= 1e-12:
                    need = max_trials
                else:
                    need = int(np.ceil(log_fail / np.log(1.0 - p_good)))
                budget = min(max_trials, max(batch, need))
            if trials >= budget or trials >= max_trials:
                break
    return best_n, best_d, best_cost, trials


@njit(cache=True, nogil=True)
def best_oriented_hypothesis(
    points: np.ndarray,
    normals: np.ndarray,
    inv_threshold: np.ndarray,
    triplets: np.ndarray,
    score: np.ndarray,
    up: np.ndarray,
    cos_tol: float,
    sin_tol: float,
    agreement_cos: np.ndarray,
) -> tuple[np.ndarray, float, float]:  # pragma: no cover - compiled
    """The orientation method's MSAC scoring in one pass: the plane through each triplet
    (``(K, 3)`` indices), kept only when its normal is within the tolerance of horizontal
    (``|n . up| >= cos_tol``) or vertical (``<= sin_tol``), scored on the points ``score``
    by the truncated quadratic with the normal-agreement test (``agreement_cos`` per point:
    the cosine each point's normal must reach).

    Returns ``(normal (3,), offset, cost)`` of the cheapest; cost is inf when no triplet
    gives a valid hypothesis.
    """
    best_n = np.zeros(3)
    best_d = 0.0
    best_cost = np.inf
    for k in range(triplets.shape[0]):
        nx, ny, nz, d, valid = plane_through(points, triplets[k, 0], triplets[k, 1], triplets[k, 2])
        if not valid:
            continue
        c = abs(nx * up[0] + ny * up[1] + nz * up[2])
        if not (c >= cos_tol or c <= sin_tol):
            continue
        cost = 0.0
        for m in range(score.shape[0]):
            cost += point_cost(
                nx, ny, nz, d, points, normals, inv_threshold, score[m], agreement_cos[score[m]], True
            )
            if cost >= best_cost:
                break  # costs only grow: this one cannot win (the winner is summed whole)
        if cost < best_cost:
            best_cost = cost
            best_n[0], best_n[1], best_n[2] = nx, ny, nz
            best_d = d
    return best_n, best_d, best_cost


@njit(cache=True, nogil=True)
def oriented_inliers(
    points: np.ndarray,
    normals: np.ndarray,
    threshold: np.ndarray,
    n: np.ndarray,
    d: float,
    agreement_cos: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """Inlier mask: residual under the point's threshold and local normal agreeing (its
    ``|cos|`` with ``n`` at least the point's ``agreement_cos``)."""
    out = np.empty(points.shape[0], dtype=np.bool_)
    for i in range(points.shape[0]):
        r = abs(n[0] * points[i, 0] + n[1] * points[i, 1] + n[2] * points[i, 2] + d)
        c = abs(n[0] * normals[i, 0] + n[1] * normals[i, 1] + n[2] * normals[i, 2])
        out[i] = r < threshold[i] and c >= agreement_cos[i]
    return out


@njit(cache=True, nogil=True)
def refine_oriented_plane(
    points: np.ndarray,
    normals: np.ndarray,
    threshold: np.ndarray,
    weights: np.ndarray,
    n: np.ndarray,
    d: float,
    up: np.ndarray,
    cos_tol: float,
    sin_tol: float,
    agreement_cos: np.ndarray,
    iterations: int,
) -> tuple[np.ndarray, float, np.ndarray]:  # pragma: no cover - compiled
    """IRLS (Tukey weights times ``weights``) on the inliers of ``n . x + d = 0``, keeping
    the orientation constraint: a refit that leaves it, or a degenerate one, stops the
    refinement. Returns ``(normal, offset, inlier mask)``."""
    n = n.copy()
    inl = oriented_inliers(points, normals, threshold, n, d, agreement_cos)
    for _ in range(iterations):
        count = 0
        sw = 0.0
        cx = cy = cz = 0.0
        for i in range(points.shape[0]):
            if inl[i]:
                count += 1
        if count < 3:
            break
        w = np.zeros(points.shape[0])
        for i in range(points.shape[0]):
            if inl[i]:
                r = (n[0] * points[i, 0] + n[1] * points[i, 1] + n[2] * points[i, 2] + d) / threshold[i]
                t = max(1.0 - r * r, 0.0)
                w[i] = (t * t + 1e-6) * weights[i]
                sw += w[i]
                cx += w[i] * points[i, 0]
                cy += w[i] * points[i, 1]
                cz += w[i] * points[i, 2]
        if sw <= 0.0:
            break
        cx, cy, cz = cx / sw, cy / sw, cz / sw
        cov = np.zeros((3, 3))
        for i in range(points.shape[0]):
            if inl[i]:
                q0, q1, q2 = points[i, 0] - cx, points[i, 1] - cy, points[i, 2] - cz
                cov[0, 0] += w[i] * q0 * q0
                cov[0, 1] += w[i] * q0 * q1
                cov[0, 2] += w[i] * q0 * q2
                cov[1, 1] += w[i] * q1 * q1
                cov[1, 2] += w[i] * q1 * q2
                cov[2, 2] += w[i] * q2 * q2
        cov[1, 0], cov[2, 0], cov[2, 1] = cov[0, 1], cov[0, 2], cov[1, 2]
        ev, vec = np.linalg.eigh(cov)
        if ev[1] <= 1e-12 * max(ev[2], 1e-300):
            break  # (nearly) collinear inliers
        m = vec[:, 0] / np.sqrt(vec[0, 0] ** 2 + vec[1, 0] ** 2 + vec[2, 0] ** 2)
        c = abs(m[0] * up[0] + m[1] * up[1] + m[2] * up[2])
        if not (c >= cos_tol or c <= sin_tol):
            break
        n = m
        d = -(m[0] * cx + m[1] * cy + m[2] * cz)
        inl = oriented_inliers(points, normals, threshold, n, d, agreement_cos)
    return n, d, inl


@njit(cache=True, nogil=True)
def triplets_from_draws(
    grid_lut: np.ndarray,
    grid_row: np.ndarray,
    grid_col: np.ndarray,
    first: np.ndarray,
    offsets: np.ndarray,
    remaining: np.ndarray,
    count: int,
) -> np.ndarray:  # pragma: no cover - compiled
    """Index triplets from drawn first points ``(D,)`` and cell offsets ``(D, 2, 2)`` of the
    two others: kept, in draw order, where both cells hold a remaining sample and the
    three are distinct; at most ``count``. Returns ``(<= count, 3)`` int64."""
    gh, gw = grid_lut.shape
    out = np.empty((min(count, first.shape[0]), 3), dtype=np.int64)
    n = 0
    for t in range(first.shape[0]):
        if n >= count:
            break
        i0 = first[t]
        j = np.empty(2, dtype=np.int64)
        ok = True
        for s in range(2):
            r = min(max(grid_row[i0] + offsets[t, s, 0], 0), gh - 1)
            c = min(max(grid_col[i0] + offsets[t, s, 1], 0), gw - 1)
            j[s] = grid_lut[r, c]
            if j[s] < 0 or not remaining[j[s]] or j[s] == i0:
                ok = False
        if not ok or j[0] == j[1]:
            continue
        out[n, 0], out[n, 1], out[n, 2] = i0, j[0], j[1]
        n += 1
    return out[:n]


@njit(cache=True, nogil=True)
def oriented_round(
    points: np.ndarray,
    normals: np.ndarray,
    threshold: np.ndarray,
    inv_threshold: np.ndarray,
    weights: np.ndarray,
    grid_lut: np.ndarray,
    grid_row: np.ndarray,
    grid_col: np.ndarray,
    first: np.ndarray,
    offsets: np.ndarray,
    remaining: np.ndarray,
    count: int,
    rest: np.ndarray,
    score: np.ndarray,
    up: np.ndarray,
    cos_tol: float,
    sin_tol: float,
    agreement_cos: np.ndarray,
    iterations: int,
) -> tuple[bool, np.ndarray, float, np.ndarray, float, int]:  # pragma: no cover - compiled
    """One MSAC round of the orientation method without adaptive batches, in one call
    (issue 13: the Python between the kernels cost more than the kernels): the triplets
    from the draws (:func:`triplets_from_draws`), the cheapest oriented hypothesis scored
    on ``rest[score]`` (:func:`best_oriented_hypothesis`), its IRLS refinement on the
    points ``rest`` (:func:`refine_oriented_plane` on ``points[rest]``, the same sums in
    the same order) and the inlier ratio on the scored points.

    ``weights`` and ``agreement_cos`` are per point (all of them, not only ``rest``).

    Returns ``(found, normal, offset, inliers (M,) int64 ascending, ratio, hypotheses)``;
    ``found`` is False when no triplet gave a valid oriented hypothesis.
    """
    trip = triplets_from_draws(grid_lut, grid_row, grid_col, first, offsets, remaining, count)
    scored = np.empty(score.shape[0], dtype=np.int64)
    for m in range(score.shape[0]):
        scored[m] = rest[score[m]]
    n, d, cost = best_oriented_hypothesis(
        points, normals, inv_threshold, trip, scored, up, cos_tol, sin_tol, agreement_cos
    )
    empty = np.empty(0, dtype=np.int64)
    if not cost < np.inf:
        return False, n, d, empty, 0.0, trip.shape[0]
    pr = np.empty((rest.shape[0], 3), dtype=points.dtype)
    nr = np.empty((rest.shape[0], 3), dtype=normals.dtype)
    tr = np.empty(rest.shape[0], dtype=threshold.dtype)
    wr = np.empty(rest.shape[0], dtype=weights.dtype)
    ar = np.empty(rest.shape[0], dtype=agreement_cos.dtype)
    for k in range(rest.shape[0]):
        i = rest[k]
        pr[k, 0], pr[k, 1], pr[k, 2] = points[i, 0], points[i, 1], points[i, 2]
        nr[k, 0], nr[k, 1], nr[k, 2] = normals[i, 0], normals[i, 1], normals[i, 2]
        tr[k] = threshold[i]
        wr[k] = weights[i]
        ar[k] = agreement_cos[i]
    n, d, inl_r = refine_oriented_plane(pr, nr, tr, wr, n, d, up, cos_tol, sin_tol, ar, iterations)
    hits = 0
    for m in range(score.shape[0]):
        if inl_r[score[m]]:
            hits += 1
    ratio = hits / score.shape[0] if score.shape[0] > 0 else 0.0
    total = 0
    for k in range(rest.shape[0]):
        if inl_r[k]:
            total += 1
    idx = np.empty(total, dtype=np.int64)
    j = 0
    for k in range(rest.shape[0]):
        if inl_r[k]:
            idx[j] = rest[k]
            j += 1
    return True, n, d, idx, ratio, trip.shape[0]
