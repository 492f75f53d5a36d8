"""Gravity from the scene: "up" from its plane families (Manhattan structure).

Without a rig or an IMU the pipeline still needs the gravity-aligned ``yaw`` frame. A
floor alone is a poor guide on stairs (a level camera close to the first riser sees only
a thin strip of floor, or none). Built scenes are made of horizontal surfaces (floor,
treads, landings) and vertical ones (risers, walls), so "up" is the direction that is
*parallel* to the normals of the horizontal family and *orthogonal* to those of every
vertical family: a tread gives it directly, a riser and a side wall together give it as
the cross product of their normals. The only prior is a weak one: the camera is roughly
upright (``prior_cone_deg``).

Two stages, one on each side of the plane stage:

1. :func:`estimate_up` -- coarse, from the local normals of the grid sample
   (camera frame). MSAC over "up" hypotheses: a sample normal near the prior (a
   horizontal surface), or the cross product of two sample normals far from it (two
   vertical surfaces); each sample scores by the truncated squared sine of its angle to
   the nearest family (parallel or orthogonal to up). The winner is refined by weighted
   least squares (smallest eigenvector of ``sum_v n n^T - sum_h n n^T``) and its 1-sigma
   comes from a jackknife over image blocks (neighbouring samples share pixels, so the
   blocks, not the samples, are independent). Accurate to a few degrees: enough for the
   orientation method's 6 deg tolerance.
2. :func:`refine_up_from_planes` -- fine, from the extracted planes, each weighted by how
   well its fit fixes its normal (scatter of its inliers; a riser 0.17 m tall fixes its
   tilt about the horizontal axis poorly, a wall fixes it well), plus a per-plane
   structural floor (real floors slope, real walls lean) of ``structure_sigma_deg``.
   Gauss-Newton on the sphere; the covariance gives the reported uncertainty.

With a rig the same estimate checks the rig: a disagreement above
``rig_tolerance_deg`` is reported in the result (the rig is still used).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ._gravity_kernels import floor_inlier_counts, truncated_family_error_sums
from ._numeric import cross3, median
from .checks import check_fields, check_min
from .cloud import GridSample
from .errors import ConfigError
from .frames import Transform
from .msac import Plane, planes_from_triplets
from .planes.orientation import HORIZONTAL, VERTICAL, PlaneSet, grid_lookup, local_triplets


@dataclass(frozen=True)
class GravityConfig:
    """How "up" is found in the scene.

    Attributes
    ----------
    prior_cone_deg : float
        Up lies within this angle of the camera's up (-y of the optical frame, or the
        rig's up when a rig is given): the weak prior "camera roughly upright".
    prior_sigma_deg : float
        Within the cone, hypotheses are weighted by a Gaussian of this width on their angle
        to the camera's up.
    family_tol_deg : float
        A sample normal within this angle of up (or of the horizontal) belongs to the
        horizontal (vertical) family when hypotheses are scored.
    refine_tol_deg : float
        Tighter tolerance of the final least-squares passes.
    hypotheses : int
        Up hypotheses drawn (half from single normals, half from pairs).
    score_points : int
        Sample normals each hypothesis is scored on.
    rig_check_hypotheses : int
        With a rig, the local normals' estimate only has to catch a rig that is off by more
        than the orientation tolerance (smaller disagreements are measured on the planes):
        this many hypotheses, scored on half the points, are enough and cost a third.
    min_support : float
        A family counts when its share of the samples is at least this many times what
        isotropic clutter would put in it (``1 - cos t`` for the horizontal family, ``sin t``
        for the vertical one, ``t = refine_tol_deg``); with no family that counts, the scene
        has no gravity to see (slopes, clutter).
    max_sigma_deg : float
        An estimate less certain than this (e.g. one vertical family and no horizontal
        surface: up is free to turn about the wall's normal) is not used.
    structure_sigma_deg : float
        Floor on the normal's uncertainty, per plane and for the result: real surfaces are
        not exactly level or plumb, and a building's floors and walls share that.
    correlation_px : float
        Disparity errors are correlated over about this many pixels (the matching block,
        the aggregation paths, the planar fill), so a plane's ``N`` inliers on a grid of
        stride ``s`` fix its normal only as well as ``N (s / correlation_px)^2``
        independent points would (at least 3); a plane's scatter is at least the depth
        noise of its points.
    plane_pieces : float
        Most independent points a plane's inliers count as, however many: the errors of a
        face's disparities are correlated over the whole face where the matcher had
        little texture (a planar or Manhattan fill, a smooth painted tread) or the lens
        model is off, so its normal is known to its scatter over its extent, divided by
        ``sqrt(plane_pieces)`` at best, not by the root of its count. On realistic
        renders, planes 5-17 deg off then no longer claim a sigma of about 1 deg
        (docs/benchmarks.md); the default profile's planes, thin in scatter, are as sure
        as before.
    rig_tolerance_deg : float
        With a rig, a scene estimate further than this from the rig's up is reported.
    min_floor_drop_m : float
        Without a rig the frame's origin goes on the floor below the camera when the floor
        (lowest large horizontal plane) is at least this far below it; else at the camera.
    levelling_tol_deg : float
        Without a rig, the frame is levelled on planes extracted with this orientation
        tolerance around the local normals' estimate (wider than the plane stage's, so that
        a start a few degrees off still finds the planes), then the plane stage runs in the
        levelled frame.
    corroborated_deg : float
        When the local normals' estimate and the floor's normal agree within this angle,
        the levelling pass is skipped (the plane stage's final correction remains).
    blocks : int
        Image blocks per side for the jackknife uncertainty of the coarse stage.
    seed : int
    """

    prior_cone_deg: float = 45.0
    prior_sigma_deg: float = 25.0
    family_tol_deg: float = 10.0
    refine_tol_deg: float = 6.0
    hypotheses: int = 300
    score_points: int = 2000
    rig_check_hypotheses: int = 100
    min_support: float = 3.0
    max_sigma_deg: float = 4.0
    structure_sigma_deg: float = 0.3
    correlation_px: float = 16.0
    plane_pieces: float = 64.0
    rig_tolerance_deg: float = 3.0
    min_floor_drop_m: float = 0.1
    levelling_tol_deg: float = 12.0
    corroborated_deg: float = 1.0
    blocks: int = 4
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "hypotheses", "score_points", "rig_check_hypotheses")
        check_min(self, 2, "blocks")
        check_min(self, 0, "min_floor_drop_m")
        check_min(self, 1, "min_support")
        check_min(self, 1, "correlation_px", "plane_pieces")
        for name in (
            "prior_cone_deg",
            "prior_sigma_deg",
            "family_tol_deg",
            "refine_tol_deg",
            "levelling_tol_deg",
            "corroborated_deg",
        ):
            if not 0 < getattr(self, name) <= 60:
                raise ConfigError(f"GravityConfig.{name} must be in (0, 60] deg, got {getattr(self, name)}")
        for name in ("max_sigma_deg", "structure_sigma_deg", "rig_tolerance_deg"):
            if not 0 < getattr(self, name) <= 90:
                raise ConfigError(f"GravityConfig.{name} must be in (0, 90] deg, got {getattr(self, name)}")


@dataclass(frozen=True)
class GravityEstimate:
    """Gravity-up seen in the scene.

    Attributes
    ----------
    up : (3,) float64, unit
        Up in ``frame`` (NaN when not ``ok``).
    frame : str
    sigma_deg : float
        1-sigma angular uncertainty of ``up``, degrees (inf when unknown).
    ok : bool
        True when the scene fixes up well enough to be used (see ``reason``).
    horizontal_fraction, vertical_fraction : float
        Fractions of the scored samples (or plane inliers) in the two families.
    reason : str
    """

    up: np.ndarray = field(repr=False)
    frame: str
    sigma_deg: float
    ok: bool
    horizontal_fraction: float = 0.0
    vertical_fraction: float = 0.0
    reason: str = ""


@dataclass(frozen=True)
class GravityReport:
    """What a result says about its gravity-aligned frame.

    Attributes
    ----------
    source : str
        ``rig`` (the rig file or the state estimator), ``scene`` (the scene's plane
        families) or ``assumed-level`` (nothing in view fixes up: a level camera assumed).
    up_camera : (3,) float64
        The up used, in the rectified left camera frame.
    sigma_deg : float or None
        1-sigma of ``up_camera`` when it came from the scene.
    rig_disagreement_deg : float or None
        With a rig: angle between the rig's up and the scene's own estimate.
    note : str
    rig_check_sigma_deg : float or None
        1-sigma of the scene estimate behind ``rig_disagreement_deg``.
    """

    source: str
    up_camera: np.ndarray = field(repr=False)
    sigma_deg: float | None
    rig_disagreement_deg: float | None
    note: str
    rig_check_sigma_deg: float | None = None

    def to_json_dict(self) -> dict:
        def r(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else round(float(x), 3)

        return {
            "source": self.source,
            "up_camera": [round(float(v), 5) for v in self.up_camera],
            "sigma_deg": r(self.sigma_deg),
            "rig_disagreement_deg": r(self.rig_disagreement_deg),
            "rig_check_sigma_deg": r(self.rig_check_sigma_deg),
            "note": self.note,
        }


#: Scale of the Cauchy weights on a plane's normalised residual (in sigmas).
_CAUCHY_SCALE = 2.5

#: Fewest samples that make a plane family (a floor, or a second wall direction).
_MIN_FAMILY_SAMPLES = 50


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _failed(frame: str, reason: str, h: float = 0.0, v: float = 0.0) -> GravityEstimate:
    return GravityEstimate(np.full(3, np.nan), frame, math.inf, False, h, v, reason)


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
    prior = _unit(np.asarray((0.0, -1.0, 0.0) if prior_up is None else prior_up, dtype=np.float64))
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
    prior = _unit(np.asarray((0.0, -1.0, 0.0) if prior_up is None else prior_up, dtype=np.float64))
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
        normals @ pts[sub].T, offsets, thr[sub], normals @ samples.normals[sub].T.astype(np.float64), 0.9
    )
    best = int(np.argmax(counts))
    plane = Plane(normals[best], offsets[best])
    inl = (plane.residuals(pts) < thr) & (np.abs(samples.normals @ plane.normal) >= 0.9)
    if inl.sum() < 30:
        return None
    plane = Plane.estimate(pts[inl]) or plane
    if plane.normal @ prior < 0:
        plane = Plane(-plane.normal, -plane.offset)
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


def _tangent_basis(u: np.ndarray) -> np.ndarray:
    """(2, 3): two unit vectors orthogonal to ``u`` and to each other."""
    # np.linalg.norm of a vector is sqrt(x.dot(x)) (the same bits, without its wrapper).
    a = cross3(u, (1.0, 0.0, 0.0))
    if math.sqrt(a.dot(a)) < 0.5:
        a = cross3(u, (0.0, 1.0, 0.0))
    a /= math.sqrt(a.dot(a))
    out = np.empty((2, 3))
    out[0] = a
    out[1] = cross3(u, a)
    return out


def _sym2_eigen(a: float, b: float, d: float) -> tuple[float, float]:
    """Largest and smallest eigenvalue of the symmetric 2x2 ``[[a, b], [b, d]]`` (the
    smallest as the determinant over the largest, which keeps its digits near singular)."""
    big = 0.5 * (a + d + math.sqrt((a - d) ** 2 + 4.0 * b * b))
    return big, ((a * d - b * b) / big if big > 0 else 0.0)


def _irls_up(
    cons: list[tuple[str, np.ndarray, np.ndarray]], u0: tuple[float, float, float], floor: float
) -> tuple[np.ndarray, float] | None:
    """The iteratively reweighted Gauss-Newton of :func:`refine_up_from_planes` on the
    sphere, in Python floats (issue 13: its 2x2 and 3-vector NumPy calls, a dozen per plane
    and step, cost about 1 ms a frame; the same arithmetic written out is a tenth of it and
    agrees to rounding). Returns up and the largest variance of its tangent covariance
    widened by the weighted chi^2 (before the structural floor), or None when the planes
    do not fix up (``H``'s condition number above 1e8)."""
    rows = []  # (horizontal?, normal, covariance's 6 unique entries)
    for kind, n, c in cons:
        cl = c.tolist()
        rows.append(
            (
                kind == HORIZONTAL,
                (float(n[0]), float(n[1]), float(n[2])),
                (cl[0][0], cl[0][1], cl[0][2], cl[1][1], cl[1][2], cl[2][2]),
            )
        )
    k = len(rows)
    weights = [1.0] * k
    chi = [0.0] * k
    u0_, u1, u2 = u0
    h00 = h01 = h11 = 0.0
    for _ in range(8):
        # The tangent basis of _tangent_basis: a = u x e_x (or u x e_y), b = u x a.
        a0, a1, a2 = 0.0, u2, -u1
        if math.sqrt(a1 * a1 + a2 * a2) < 0.5:
            a0, a1, a2 = -u2, 0.0, u0_
        na = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        a0, a1, a2 = a0 / na, a1 / na, a2 / na
        b0, b1, b2 = u1 * a2 - u2 * a1, u2 * a0 - u0_ * a2, u0_ * a1 - u1 * a0
        h00 = h01 = h11 = g0 = g1 = 0.0
        for i, (horizontal, (n0, n1, n2), (c00, c01, c02, c11, c12, c22)) in enumerate(rows):
            r_a, r_b = a0 * n0 + a1 * n1 + a2 * n2, b0 * n0 + b1 * n1 + b2 * n2  # B n
            w = weights[i]
            if horizontal:  # up = n: W = (B C B^T + floor I)^-1, residual B n, J = I
                ca0, ca1, ca2 = (
                    c00 * a0 + c01 * a1 + c02 * a2,
                    c01 * a0 + c11 * a1 + c12 * a2,
                    c02 * a0 + c12 * a1 + c22 * a2,
                )
                cb0, cb1, cb2 = (
                    c00 * b0 + c01 * b1 + c02 * b2,
                    c01 * b0 + c11 * b1 + c12 * b2,
                    c02 * b0 + c12 * b1 + c22 * b2,
                )
                m00 = a0 * ca0 + a1 * ca1 + a2 * ca2 + floor  # B C B^T + floor I
                m01 = b0 * ca0 + b1 * ca1 + b2 * ca2
                m11 = b0 * cb0 + b1 * cb1 + b2 * cb2 + floor
                det = m00 * m11 - m01 * m01
                w00, w01, w11 = m11 / det, -m01 / det, m00 / det
                wr_a, wr_b = w00 * r_a + w01 * r_b, w01 * r_a + w11 * r_b
                chi[i] = math.sqrt(max(r_a * wr_a + r_b * wr_b, 0.0) / 2.0)
                h00 += w * w00
                h01 += w * w01
                h11 += w * w11
                g0 += w * wr_a
                g1 += w * wr_b
            else:  # n . up = 0: one residual, J = (B n)^T, W = 1 / (u C u + floor)
                ucu = (
                    u0_ * (c00 * u0_ + c01 * u1 + c02 * u2)
                    + u1 * (c01 * u0_ + c11 * u1 + c12 * u2)
                    + u2 * (c02 * u0_ + c12 * u1 + c22 * u2)
                )
                w_inv = 1.0 / (ucu + floor)
                r0 = -(n0 * u0_ + n1 * u1 + n2 * u2)
                chi[i] = math.sqrt(r0 * w_inv * r0)
                s_a, s_b = w * r_a * w_inv, w * r_b * w_inv
                h00 += s_a * r_a
                h01 += s_a * r_b
                h11 += s_b * r_b
                g0 += s_a * r0
                g1 += s_b * r0
        big, small = _sym2_eigen(h00, h01, h11)
        if not small > 0 or big / small > 1e8:
            return None
        det = h00 * h11 - h01 * h01
        d0, d1 = (h11 * g0 - h01 * g1) / det, (h00 * g1 - h01 * g0) / det
        u0_, u1, u2 = u0_ + a0 * d0 + b0 * d1, u1 + a1 * d0 + b1 * d1, u2 + a2 * d0 + b2 * d1
        nu = math.sqrt(u0_ * u0_ + u1 * u1 + u2 * u2)
        u0_, u1, u2 = u0_ / nu, u1 / nu, u2 / nu
        weights = [1.0 / (1.0 + (c / _CAUCHY_SCALE) ** 2) for c in chi]
        if math.sqrt(d0 * d0 + d1 * d1) < 1e-7:
            break
    # cov = H^-1: its largest eigenvalue is 1 / H's smallest.
    var_max = 1.0 / _sym2_eigen(h00, h01, h11)[1]
    # Residual scatter beyond the model (weighted chi^2 per degree of freedom) widens sigma.
    dof = sum(1 if horizontal else 0 for horizontal, _, _ in rows) + k - 2
    sw = sum(weights)
    chi2 = sum(w * c * c for w, c in zip(weights, chi, strict=True)) / max(sw, 1e-9) * (dof + 2)
    scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    return np.array([u0_, u1, u2]), scale * var_max


def refine_up_from_planes(planes: PlaneSet, config: GravityConfig | None = None) -> GravityEstimate:
    """Fine gravity-up from extracted planes (stage 2 above), in the planes' frame.

    Each horizontal plane says ``up = n``, each vertical one ``n . up = 0``; each with the
    covariance of its normal from the scatter of its inliers (``sigma^2 / lambda`` along
    each in-plane axis, ``sigma`` the plane's RMS) plus ``structure_sigma_deg``. Solved by
    iteratively reweighted Gauss-Newton on the sphere from ``planes.up``, with Cauchy
    weights on each plane's normalised residual: a plane fitted across two surfaces (its
    normal several degrees off) loses its say instead of tilting everything.

    Returns
    -------
    GravityEstimate in ``planes.frame``; ``ok`` False when the planes do not fix up (fewer
    than two independent constraints).
    """
    config = config or GravityConfig()
    frame = planes.frame
    u = np.asarray(planes.up, dtype=np.float64)
    u = u / np.linalg.norm(u)
    P = planes.samples.points.astype(np.float64)
    depth_sigma = planes.samples.sigma_m
    floor = math.radians(config.structure_sigma_deg) ** 2
    # Inliers per independent one (correlated disparity errors, see GravityConfig).
    per_independent = max(1.0, (config.correlation_px / max(planes.samples.stride_px, 1)) ** 2)
    cons: list[tuple[str, np.ndarray, np.ndarray]] = []  # (kind, normal, normal covariance)
    n_h = n_v = 0
    total = max(len(P), 1)
    for seg in planes.segments:
        if seg.kind not in (HORIZONTAL, VERTICAL) or seg.count < 10:
            continue
        q = P[seg.indices]
        q = q - q.mean(axis=0)
        lam, E = np.linalg.eigh(q.T @ q)
        sig = depth_sigma[seg.indices]
        # np.median's bits where nothing is NaN (nanmedian's own path then; _numeric.median
        # at a fifth of np.median's time)
        noise = float(np.nanmedian(sig) if np.isnan(sig).any() else median(sig))
        sigma2 = max(seg.rms_m, noise, 1e-3) ** 2
        inflate = min(per_independent, seg.count / 3.0) if seg.count > 3 else 1.0
        inflate = max(inflate, seg.count / config.plane_pieces)
        cov_n = inflate * sigma2 * sum(np.outer(E[:, k], E[:, k]) / max(lam[k], 1e-9) for k in (1, 2))
        n = seg.plane.normal if seg.kind == VERTICAL or seg.plane.normal @ u >= 0 else -seg.plane.normal
        cons.append((seg.kind, n, cov_n))
        n_h += seg.count if seg.kind == HORIZONTAL else 0
        n_v += seg.count if seg.kind == VERTICAL else 0
    h_frac, v_frac = n_h / total, n_v / total
    if sum(2 if kind == HORIZONTAL else 1 for kind, _, _ in cons) < 2:  # up has 2 degrees of freedom
        return _failed(frame, "too few planes to fix up", h_frac, v_frac)
    solved = _irls_up(cons, (float(u[0]), float(u[1]), float(u[2])), floor)
    if solved is None:
        return _failed(
            frame,
            "the planes do not fix up (need a horizontal plane or two wall directions)",
            h_frac,
            v_frac,
        )
    u, var_max = solved
    sigma = math.degrees(math.sqrt(var_max + floor))
    ok = sigma <= config.max_sigma_deg
    why = "planes of the scene" if ok else f"the planes fix up only to {sigma:.1f} deg"
    return GravityEstimate(u, frame, sigma, ok, h_frac, v_frac, why)


def rotation_between(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` to unit vector ``b``."""
    ua = np.asarray(a, dtype=np.float64)
    ua = ua / np.linalg.norm(ua)
    ub = np.asarray(b, dtype=np.float64)
    ub = ub / np.linalg.norm(ub)
    v = np.cross(ua, ub)
    c = float(ua @ ub)
    s = float(np.linalg.norm(v))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(ua, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(ua, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K * ((1.0 - c) / (s * s))


def levelling(up: np.ndarray, frame: str = "yaw") -> Transform:
    """``T_<frame>_<frame>``: the smallest rotation that takes ``up`` (in ``frame``) to +z."""
    return Transform.from_rt(rotation_between(up, [0.0, 0.0, 1.0]), np.zeros(3), frame, frame)


def angle_deg(a: ArrayLike, b: ArrayLike) -> float:
    """Angle between two vectors, degrees."""
    c = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def yaw_frame_from_up(up: np.ndarray, frame: str, camera_position: np.ndarray | None = None) -> Transform:
    """``T_yaw_<frame>`` for a camera-fixed ``frame`` whose gravity-up is ``up``: z along
    ``up``, x along the optical axis (+z of ``frame``) projected on the horizontal, origin at
    the camera (``camera_position``, default the frame's origin)."""
    z = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    x = np.array([0.0, 0.0, 1.0]) - z * z[2]
    if np.linalg.norm(x) < 1e-6:  # looking straight up or down: any heading will do
        x = np.array([1.0, 0.0, 0.0]) - z * z[0]
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.vstack([x, y, z])
    cam = np.zeros(3) if camera_position is None else np.asarray(camera_position, dtype=np.float64)
    return Transform.from_rt(R, -R @ cam, "yaw", frame)
