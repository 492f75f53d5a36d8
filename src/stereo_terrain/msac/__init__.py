"""MSAC (Torr & Zisserman 2000): RANSAC scored by a truncated quadratic cost.

Each point contributes ``min(r**2, t**2)`` where ``r`` is its residual and ``t`` the
inlier threshold, so hypotheses are ranked by how well their inliers fit, not only by
how many there are.

Two entry points:

* :func:`msac` -- generic, scikit-image style: a model class with ``estimate`` and
  ``residuals``; one hypothesis per trial.
* :func:`plane_msac` -- planes only, vectorised: hundreds of 3-point hypotheses scored at
  once against a subsample, with an optional constraint on the hypothesis normal (the
  paper's orientation method) and on the agreement of point normals.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class Plane:
    """The plane ``normal . x + offset = 0``.

    Attributes
    ----------
    normal : (3,) float64, unit
        By convention pointing up (horizontal planes) or toward the camera.
    offset : float, metres
    """

    normal: np.ndarray
    offset: float

    def __post_init__(self) -> None:
        n = np.asarray(self.normal, dtype=np.float64).reshape(3)
        norm = math.sqrt(float(n.dot(n)))  # np.linalg.norm's own sum, without its overhead
        if not math.isfinite(norm) or norm < 1e-12:
            raise InputError(f"plane normal must be a finite non-zero 3-vector, got {n}")
        n = n / norm
        n.setflags(write=False)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "offset", float(self.offset) / norm)

    @classmethod
    def estimate(cls, points: np.ndarray, weights: np.ndarray | None = None) -> Plane | None:
        """(Weighted) least-squares plane through ``points`` ((N, 3), N >= 3); None if
        degenerate."""
        p = np.asarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise InputError(f"points must be (N, 3), got {p.shape}")
        if len(p) < 3:
            return None
        if weights is None:
            c = p.mean(axis=0)
            q = p - c
            cov = q.T @ q
        else:
            w = np.asarray(weights, dtype=np.float64).reshape(-1)
            if w.shape != (len(p),) or not np.all(w >= 0) or w.sum() <= 0:
                raise InputError("weights must be (N,) non-negative with a positive sum")
            c = (w[:, None] * p).sum(axis=0) / w.sum()
            q = p - c
            cov = (w[:, None] * q).T @ q
        w, v = np.linalg.eigh(cov)
        # Degenerate when the points are (nearly) collinear: second eigenvalue ~ 0.
        if w[1] <= 1e-12 * max(w[2], 1e-300) or not np.all(np.isfinite(v)):
            return None
        n = v[:, 0]
        return cls(n, -float(n @ c))

    def residuals(self, points: np.ndarray) -> np.ndarray:
        """Absolute point-to-plane distances, metres."""
        return np.abs(np.asarray(points) @ self.normal + self.offset)

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points) @ self.normal + self.offset

    def moved(self, rotation: np.ndarray, translation: np.ndarray) -> Plane:
        """The plane through the points ``rotation @ x + translation`` of this one."""
        n = rotation @ self.normal
        return Plane(n, self.offset - float(n @ translation))

    def oriented_toward(self, point: np.ndarray) -> Plane:
        """The same plane with its normal pointing to the side of ``point``."""
        if self.signed_distance(np.asarray(point, dtype=np.float64)) < 0:
            return Plane(-self.normal, -self.offset)
        return self


class Model(Protocol):
    def residuals(self, data: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class MsacResult:
    """Outcome of an MSAC run.

    Attributes
    ----------
    model : the best model, or None when no valid hypothesis was found
    inliers : (N,) bool
    cost : float
        Truncated quadratic cost of the best model (sum over the points scored).
    trials : int
    success : bool
    """

    model: Any
    inliers: np.ndarray = field(repr=False)
    cost: float
    trials: int

    @property
    def success(self) -> bool:
        return self.model is not None


def truncated_quadratic_cost(residuals: np.ndarray, threshold: float | np.ndarray) -> np.ndarray:
    """MSAC cost ``sum(min(r**2, t**2))`` over the last axis."""
    r2 = np.minimum(residuals * residuals, threshold * threshold)
    return r2.sum(axis=-1)


def required_trials(inlier_ratio: float, sample_size: int, confidence: float) -> int:
    """Trials needed to draw one all-inlier sample with probability ``confidence``.

    Returns a very large number (``2**31 - 1``) when the inlier ratio is too small for any
    finite count; callers cap it with their ``max_trials``.
    """
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be in (0, 1), got {confidence}")
    w = float(np.clip(inlier_ratio, 0.0, 1.0))
    p_good = w**sample_size
    if p_good >= 1.0 - 1e-12:
        return 1
    denom = np.log1p(-p_good)
    if denom == 0.0:
        return 2**31 - 1
    n = np.ceil(np.log1p(-confidence) / denom)
    return int(n) if np.isfinite(n) and n < 2**31 - 1 else 2**31 - 1


def msac(
    data: np.ndarray,
    estimate: Callable[[np.ndarray], Model | None],
    min_samples: int,
    threshold: float,
    *,
    rng: np.random.Generator | int | None = None,
    max_trials: int = 1000,
    confidence: float = 0.99,
    is_model_valid: Callable[[Model], bool] | None = None,
) -> MsacResult:
    """Generic MSAC.

    Parameters
    ----------
    data : (N, D) array
    estimate : callable
        ``estimate(sample) -> model | None`` (e.g. :meth:`Plane.estimate`).
    min_samples : int
        Size of a minimal sample.
    threshold : float
        Inlier threshold on ``model.residuals``.
    rng : Generator or seed
    max_trials : int
        Upper bound; fewer are run once ``confidence`` is reached for the best inlier ratio.
    is_model_valid : callable, optional
        Rejects hypotheses (e.g. normals outside an orientation tolerance).

    Returns
    -------
    MsacResult; the model is refit by ``estimate`` on the inliers of the best hypothesis.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> pts = np.c_[rng.uniform(-1, 1, (100, 2)), np.zeros(100)]
    >>> res = msac(pts, Plane.estimate, 3, 0.01, rng=0)
    >>> bool(abs(res.model.normal[2]) > 0.999)
    True
    """
    data = np.asarray(data)
    if data.ndim != 2:
        raise InputError(f"data must be (N, D), got shape {data.shape}")
    if min_samples < 1:
        raise InputError(f"min_samples must be >= 1, got {min_samples}")
    if not threshold > 0:
        raise InputError(f"threshold must be > 0, got {threshold}")
    rng = np.random.default_rng(rng)
    n = len(data)
    none = MsacResult(None, np.zeros(n, dtype=bool), float("inf"), 0)
    if n < min_samples:
        return none
    best_model, best_cost, best_inliers = None, np.inf, None
    budget = max_trials
    trials = 0
    while trials < budget:
        trials += 1
        idx = rng.choice(n, min_samples, replace=False)
        model = estimate(data[idx])
        if model is None or (is_model_valid is not None and not is_model_valid(model)):
            continue
        r = model.residuals(data)
        cost = float(truncated_quadratic_cost(r, threshold))
        if cost < best_cost:
            best_model, best_cost, best_inliers = model, cost, r < threshold
            budget = min(max_trials, required_trials(best_inliers.mean(), min_samples, confidence))
    if best_model is None or best_inliers is None:
        return MsacResult(None, np.zeros(n, dtype=bool), float("inf"), trials)
    refit = estimate(data[best_inliers]) if best_inliers.sum() >= min_samples else None
    if refit is not None and (is_model_valid is None or is_model_valid(refit)):
        r = refit.residuals(data)
        best_model, best_inliers = refit, r < threshold
        best_cost = float(truncated_quadratic_cost(r, threshold))
    return MsacResult(best_model, best_inliers, best_cost, trials)


def planes_from_triplets(
    p0: np.ndarray, p1: np.ndarray, p2: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit normals and offsets of the planes through K point triplets.

    Returns ``normals (K, 3)``, ``offsets (K,)``, ``ok (K,) bool`` (False for collinear).
    """
    a, b = p1 - p0, p2 - p0
    # np.cross and np.linalg.norm written out: their operations in their order, a fifth of
    # their call overhead (issue 13; the fill calls this once per region and frame).
    n = np.empty(a.shape, dtype=np.result_type(a, b))
    a0, a1, a2, b0, b1, b2 = a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2]
    n[:, 0] = a1 * b2 - a2 * b1
    n[:, 1] = a2 * b0 - a0 * b2
    n[:, 2] = a0 * b1 - a1 * b0
    norm = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])
    ok = norm > 1e-9
    n = n / np.where(ok, norm, 1.0)[:, None]
    d = -np.einsum("ij,ij->i", n, p0)
    return n, d, ok


def plane_msac(
    points: np.ndarray,
    threshold: np.ndarray | float,
    samples: np.ndarray,
    *,
    point_normals: np.ndarray | None = None,
    normal_agreement_cos: float = 0.8,
    hypothesis_ok: Callable[[np.ndarray], np.ndarray] | None = None,
    score_subset: np.ndarray | None = None,
    compute_inliers: bool = True,
) -> MsacResult:
    """Vectorised plane MSAC over precomputed minimal samples.

    Parameters
    ----------
    points : (N, 3) float
    threshold : float or (N,) float, metres
        Inlier threshold per point (depth-dependent noise allowed).
    samples : (K, 3) int
        Index triplets (drawn by the caller, e.g. spatially local samples).
    point_normals : (N, 3) float, optional
        Local surface normals; a point whose normal disagrees with the hypothesis
        (``|n_p . n| < normal_agreement_cos``) counts as an outlier.
    hypothesis_ok : callable, optional
        ``hypothesis_ok(normals (K, 3)) -> (K,) bool``: the orientation constraint.
    score_subset : (M,) int, optional
        Indices of the points the hypotheses are scored on (all points if None).
    compute_inliers : bool
        False skips the inlier mask over all points (the result's mask is then empty), for
        callers that compute inliers on a subset themselves.

    Returns
    -------
    MsacResult with a :class:`Plane` (not refit; the caller refines) and inliers over all
    ``points``.
    """
    pts = np.asarray(points)
    n_pts = len(pts)
    if samples.ndim != 2 or samples.shape[1] != 3:
        raise InputError(f"samples must be (K, 3) indices, got {samples.shape}")
    empty = MsacResult(None, np.zeros(n_pts, dtype=bool), float("inf"), len(samples))
    if len(samples) == 0 or n_pts < 3:
        return empty
    normals, offsets, ok = planes_from_triplets(pts[samples[:, 0]], pts[samples[:, 1]], pts[samples[:, 2]])
    if hypothesis_ok is not None:
        ok &= hypothesis_ok(normals)
    if not ok.any():
        return empty
    normals, offsets = normals[ok], offsets[ok]
    sub = np.arange(n_pts) if score_subset is None else score_subset
    # Scoring in float32: (K, M) residual matrices are the bulk of the work.
    from ._kernels import msac_costs

    inv_t = 1.0 / np.broadcast_to(np.asarray(threshold, dtype=np.float32), (n_pts,))[sub]
    pn = (
        np.zeros((0, 3), np.float32)
        if point_normals is None
        else np.ascontiguousarray(point_normals[sub], dtype=np.float32)
    )
    cost = msac_costs(
        np.ascontiguousarray(normals, dtype=np.float32),
        np.ascontiguousarray(offsets, dtype=np.float32),
        np.ascontiguousarray(pts[sub], dtype=np.float32),
        np.ascontiguousarray(inv_t, dtype=np.float32),
        pn,
        float(normal_agreement_cos),
    )
    best = int(np.argmin(cost))
    plane = Plane(normals[best], offsets[best])
    if not compute_inliers:
        return MsacResult(plane, np.zeros(0, dtype=bool), float(cost[best]), len(samples))
    r_all = plane.residuals(pts)
    inl = r_all < np.broadcast_to(threshold, (n_pts,))
    if point_normals is not None:
        inl &= np.abs(point_normals @ plane.normal) >= normal_agreement_cos
    return MsacResult(plane, inl, float(cost[best]), len(samples))
