"""The coarse up, from the grid sample's local normals (:func:`estimate_up`, the first
stage of :mod:`stereo_terrain.gravity`), and up as the floor's normal (:func:`floor_up`)."""

from __future__ import annotations

import math

import numpy as np

from ..cloud import GridSample
from ..msac import Plane, planes_from_triplets
from ..planes.orientation import grid_lookup, local_triplets
from ._kernels import floor_inlier_counts, truncated_family_error_sums
from .config import GravityConfig, GravityEstimate, _failed
from .geometry import CAMERA_UP, _tangent_basis, _unit

#: Fewest samples that make a plane family (a floor, or a second wall direction).
_MIN_FAMILY_SAMPLES = 50


def _family_scatter(normals: np.ndarray, up: np.ndarray, tol_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the samples in the horizontal and vertical families of ``up``."""
    c = normals @ up
    s2 = math.sin(math.radians(tol_deg)) ** 2
    return (1.0 - c * c) < s2, c * c < s2


def _least_squares_up(normals: np.ndarray, horiz: np.ndarray, vert: np.ndarray, prior: np.ndarray):
    """Up minimising ``sum_v (n.u)^2 + sum_h |n x u|^2``: the smallest eigenvector of
    ``sum_v n n^T - sum_h n n^T``, signed toward ``prior``."""
    nv, nh = normals[vert], normals[horiz]
    M = nv.T @ nv - nh.T @ nh
    w, V = np.linalg.eigh(M)
    u = V[:, 0]
    return u if u @ prior >= 0 else -u


def estimate_up(
    samples: GridSample,
    config: GravityConfig | None = None,
    *,
    prior_up: np.ndarray | None = None,
    rng: np.random.Generator | int | None = None,
) -> GravityEstimate:
    """Coarse gravity-up from the local normals of a grid sample (stage 1 above).

    Parameters
    ----------
    samples : GridSample
        Any frame; typically ``camera_rect``.
    config : GravityConfig
    prior_up : (3,) float, optional
        The camera's up in ``samples.frame`` (default ``(0, -1, 0)``, optical axes).
    rng : Generator or seed; defaults to ``config.seed``.

    Returns
    -------
    GravityEstimate; ``ok`` False (with a reason) when the scene does not fix up.
    """
    config = config or GravityConfig()
    rng = np.random.default_rng(config.seed if rng is None else rng)
    prior = _unit(np.asarray(CAMERA_UP if prior_up is None else prior_up, dtype=np.float64))
    frame = samples.frame
    n = len(samples)
    if n < 100:
        return _failed(frame, f"too few samples with normals ({n})")
    N = samples.normals.astype(np.float64)
    N = _unit(N)
    cone = math.cos(math.radians(config.prior_cone_deg))
    c_prior = N @ prior
    # Hypotheses: horizontal surfaces (a normal near the prior) ...
    flat = np.flatnonzero(np.abs(c_prior) >= cone)
    steep = np.flatnonzero(np.abs(c_prior) <= math.sqrt(1.0 - cone * cone))
    hyps = []
    half = config.hypotheses // 2
    if len(flat):
        pick = N[rng.choice(flat, size=min(half, len(flat)), replace=False)]
        hyps.append(pick * np.sign(pick @ prior)[:, None])
    # ... and pairs of vertical surfaces (their normals' cross product).
    if len(steep) >= 2:
        m = config.hypotheses - (len(hyps[0]) if hyps else 0)
        i = rng.choice(steep, size=3 * m)
        j = rng.choice(steep, size=3 * m)
        c = np.cross(N[i], N[j])
        norm = np.linalg.norm(c, axis=1)
        ok = norm > math.sin(math.radians(30.0))
        c = c[ok] / norm[ok, None]
        c *= np.sign(c @ prior)[:, None]
        c = c[c @ prior >= cone][:m]
        if len(c):
            hyps.append(c)
    if not hyps:
        return _failed(frame, "no surface near horizontal or vertical for any plausible up")
    U = np.vstack(hyps)
    score_idx = rng.choice(n, size=min(config.score_points, n), replace=False)
    cosines = N[score_idx].astype(np.float32) @ U.T.astype(np.float32)  # (S, H)
    s2 = np.float32(math.sin(math.radians(config.family_tol_deg)) ** 2)
    # The weak prior "camera roughly upright": a broad Gaussian on the angle to the prior
    # up breaks ties between families that a slanted surface (the envelope of a noisy
    # staircase, a ramp) can make look vertical when up turns far.
    prior_w = np.exp(
        -0.5 * (np.arccos(np.clip(U @ prior, -1.0, 1.0)) / math.radians(config.prior_sigma_deg)) ** 2
    )
    # Each sample's squared sine to the nearest family (parallel or orthogonal to up),
    # truncated at s2, summed per hypothesis: one compiled pass, NumPy's bits (with one
    # hypothesis NumPy's column sum is a pairwise one: NumPy's own passes then).
    if cosines.shape[1] > 1:
        err_sums = truncated_family_error_sums(cosines, s2)
    else:
        D2 = np.square(cosines)
        err = np.minimum(1.0 - D2, D2)
        np.minimum(err, s2, out=err)
        err_sums = err.sum(axis=0)
    score = (len(score_idx) * s2 - err_sums) * prior_w
    u = U[int(np.argmax(score))]
    # Refinement: least squares on the family members, tolerance tightened; a step that
    # leaves the prior cone is not taken.
    for tol in (config.family_tol_deg, config.refine_tol_deg, config.refine_tol_deg):
        horiz, vert = _family_scatter(N, u, tol)
        if horiz.sum() + vert.sum() < 10:
            break
        nxt = _least_squares_up(N, horiz, vert, prior)
        if nxt @ prior < cone:
            break
        u = nxt
    horiz, vert = _family_scatter(N, u, config.refine_tol_deg)
    h_frac, v_frac = float(horiz.mean()), float(vert.mean())
    if u @ prior < cone:
        return _failed(frame, "the scene's up is outside the prior cone", h_frac, v_frac)
    t = math.radians(config.refine_tol_deg)
    chance_h, chance_v = 1.0 - math.cos(t), math.sin(t)
    if h_frac < config.min_support * chance_h and v_frac < config.min_support * chance_v:
        return _failed(
            frame,
            f"no plane family stands out of the clutter ({h_frac:.0%} horizontal, {v_frac:.0%} vertical "
            f"surfaces; chance alone gives {chance_h:.0%} and {chance_v:.0%})",
            h_frac,
            v_frac,
        )
    # The jackknife's spread, and the structural floor (surfaces are not exactly level).
    sigma = math.hypot(
        _jackknife_sigma_deg(samples, N, horiz, vert, u, prior, config.blocks), config.structure_sigma_deg
    )
    if not sigma <= config.max_sigma_deg:
        return GravityEstimate(
            u,
            frame,
            sigma,
            False,
            h_frac,
            v_frac,
            f"the surfaces fix up only to {sigma:.1f} deg (one wall family and no floor?)",
        )
    return GravityEstimate(u, frame, sigma, True, h_frac, v_frac, "plane families of the scene")


def load_gravity_kernels() -> None:
    """Load (or compile) the compiled kernels of :func:`estimate_up` and :func:`floor_up`
    now rather than in their first call (the pipeline's warm-up: with a rig that agrees
    with the scene neither runs on the warm-up pair)."""
    truncated_family_error_sums(np.zeros((1, 2), np.float32), np.float32(0.0))
    one = np.zeros((1, 1))
    floor_inlier_counts(one, np.zeros(1), np.zeros(1, np.float32), one, 0.9)


#: A floor's inlier has its local normal within about 25 deg of the floor's (cosine).
_FLOOR_NORMAL_COS = 0.9


def floor_up(
    samples: GridSample,
    *,
    prior_up: np.ndarray | None = None,
    max_tilt_deg: float = 45.0,
    min_drop_m: float = 0.1,
    hypotheses: int = 400,
    rng: np.random.Generator | int = 0,
) -> np.ndarray | None:
    """Up as the normal of the floor, or None: the plane with most inliers (points within
    their depth noise whose local normal agrees) among those at least ``min_drop_m`` below
    the camera and within ``max_tilt_deg`` of ``prior_up``. Fitted to points, not to local
    normals, so it stays exact when the normals are noisy; a start for the levelling (the
    pipeline's only levelling before issue 11)."""
    if len(samples) < 50:
        return None
    rng = np.random.default_rng(rng)
    prior = _unit(np.asarray(CAMERA_UP if prior_up is None else prior_up, dtype=np.float64))
    lut, gr, gc = grid_lookup(samples)
    everyone = np.ones(len(samples), dtype=bool)
    trip = local_triplets(lut, gr, gc, np.arange(len(samples)), everyone, 5, hypotheses, rng)
    pts = samples.points.astype(np.float64)
    normals, offsets, ok = planes_from_triplets(pts[trip[:, 0]], pts[trip[:, 1]], pts[trip[:, 2]])
    flip = normals @ prior < 0
    normals[flip] *= -1.0
    offsets[flip] *= -1.0
    cam = samples.camera_position
    ok &= (normals @ prior >= math.cos(math.radians(max_tilt_deg))) & (normals @ cam + offsets > min_drop_m)
    if not ok.any():
        return None
    normals, offsets = normals[ok], offsets[ok]
    sub = rng.choice(len(pts), size=min(2000, len(pts)), replace=False)
    thr = np.clip(3.0 * samples.sigma_m, 0.015, 0.06)
    counts = floor_inlier_counts(
        normals @ pts[sub].T,
        offsets,
        thr[sub],
        normals @ samples.normals[sub].T.astype(np.float64),
        _FLOOR_NORMAL_COS,
    )
    best = int(np.argmax(counts))
    plane = Plane(normals[best], offsets[best])
    inl = (plane.residuals(pts) < thr) & (np.abs(samples.normals @ plane.normal) >= _FLOOR_NORMAL_COS)
    if inl.sum() < 30:
        return None
    # The least-squares plane of the inliers, where it keeps their local normals' direction:
    # inliers along a narrow strip (a floor seen as a thin band, an edge) leave the fit free
    # to turn about the strip, and one such refit put up 86 deg from the camera's upright
    # on a realistic render (docs/benchmarks.md, "Nineteenth session").
    refit = Plane.estimate(pts[inl])
    if refit is not None and abs(float(refit.normal @ plane.normal)) >= _FLOOR_NORMAL_COS:
        plane = refit
    if plane.normal @ prior < 0:
        plane = Plane(-plane.normal, -plane.offset)
    if plane.normal @ prior < math.cos(math.radians(max_tilt_deg)):
        return None
    return plane.normal if float(plane.signed_distance(cam)) > min_drop_m else None


def _jackknife_sigma_deg(
    samples: GridSample,
    N: np.ndarray,
    horiz: np.ndarray,
    vert: np.ndarray,
    u: np.ndarray,
    prior: np.ndarray,
    blocks: int,
) -> float:
    """1-sigma of ``u`` (degrees) by a delete-one-block jackknife over image blocks."""
    # The jackknife misses a direction that no block constrains (one wall family and no
    # floor: up is free to turn about the wall's normal). Up is fixed only by a
    # horizontal family or by two vertical families at a clear angle to each other.
    if horiz.sum() < _MIN_FAMILY_SAMPLES:
        nt = N[vert] @ _tangent_basis(u).T
        theta = np.arctan2(nt[:, 1], nt[:, 0]) % np.pi  # direction of the normal, mod 180
        hist = np.bincount((theta / np.pi * 36).astype(int) % 36, minlength=36)
        main = (int(np.argmax(hist)) + 0.5) * np.pi / 36
        off = np.abs((theta - main + np.pi / 2) % np.pi - np.pi / 2)
        if np.sum(off > math.radians(30.0)) < max(_MIN_FAMILY_SAMPLES, 0.05 * vert.sum()):
            return math.inf
    gh, gw = samples.grid_shape
    gr, gc = samples.grid_index // gw, samples.grid_index % gw
    block = (gr * blocks // max(gh, 1)) * blocks + (gc * blocks // max(gw, 1))
    n_blocks = blocks * blocks
    Mb = np.zeros((n_blocks, 3, 3))
    sign = np.where(vert, 1.0, np.where(horiz, -1.0, 0.0))
    # Per block, sum_i sign_i n_i n_i^T: bincount adds in the samples' order as np.add.at
    # did (the same sums), at a tenth of its time; the outer product is symmetric.
    for i in range(3):
        for j in range(i, 3):
            Mb[:, i, j] = Mb[:, j, i] = np.bincount(block, N[:, i] * N[:, j] * sign, n_blocks)
    total = Mb.sum(axis=0)
    used = np.flatnonzero(Mb.reshape(n_blocks, 9).any(axis=1))
    if len(used) < 3:
        return math.inf
    angles = []
    # One stacked eigh: LAPACK runs on each block's matrix as it did one call at a time.
    for V in np.linalg.eigh(total - Mb[used])[1]:
        ub = V[:, 0] if V[:, 0] @ prior >= 0 else -V[:, 0]
        angles.append(ub - u)
    dev = np.array(angles)
    k = len(used)
    var = (k - 1) / k * float(np.sum(dev * dev))
    return math.degrees(math.sqrt(var))
