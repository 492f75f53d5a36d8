"""The orientation method (paper section 3.2.2): MSAC with orientation-constrained samples.

Planes are taken out of the cloud one at a time. For each, many minimal samples are drawn
(three points close together in the image, so that most samples lie on one surface), a
hypothesis is kept only if its normal is within ``angle_tol_deg`` of horizontal or
vertical, and the hypotheses are ranked by the MSAC truncated quadratic cost. A point only
counts as an inlier when its local normal agrees with the plane: this is what keeps a
plane from slanting through all the step edges. The loop stops when the rest of the cloud
is too small or the best plane explains too little of it -- not after a fixed count.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..checks import check_fields, check_min
from ..cloud import GridSample, PointCloud, sample_grid, transform_sample
from ..errors import ConfigError, FrameError
from ..frames import Transform
from ..msac import Plane, required_trials

HORIZONTAL, VERTICAL, OTHER = "horizontal", "vertical", "other"


@dataclass(frozen=True)
class OrientationConfig:
    """Parameters of the orientation method (SI units, angles in degrees where named).

    Attributes
    ----------
    angle_tol_deg : float
        A hypothesis normal must be within this angle of vertical (horizontal plane) or of
        horizontal (vertical plane).
    normal_agreement_deg : float
        A point is an inlier only if its local normal is within this angle of the plane's ...
    normal_noise_sigmas : float
        ... or, where the cloud stage gives each normal's expected error from the disparity's
        noise (``GridSample.normal_sigma_rad``, growing with depth over baseline), within
        this many of those errors (as tangents), if that is wider; such far samples also
        seed hypotheses within it. 0 (default): off, the fixed angles everywhere. 1.1 finds
        more stairs 2-4 m ahead (at 640x480 and a 7.5 cm baseline the test widens from
        about 1.4 m and reaches its cap from 2.7 m; at 3 m a riser 25 px tall leaves its
        samples' normals a median 40 deg off) and more on the seed-11 sets, but it is not
        the default: it also finds more fragments of walls near ``cloud.max_depth_m``, which
        the stair model can take for steps, and the real scenes' results flip between
        neighbouring values (docs/benchmarks.md, "Stairs 2-4 m ahead").
    max_noise_tolerance_deg : float
        Cap of that widening, well short of half-way between a riser's normal and a
        tread's, so that a riser's plane still refuses the treads' samples.
    threshold_sigmas : float
        Inlier threshold in units of each point's depth sigma, clipped to
        ``[min_threshold_m, max_threshold_m]``.
    hypotheses_per_plane : int
        Minimal samples drawn at once in an MSAC round.
    max_hypotheses_per_plane : int
        More batches are drawn, up to this many samples, until a sample wholly on the best
        plane has been drawn with probability ``confidence``; the chance of such a sample
        is estimated from the samples drawn so far (iterations chosen from the data).
        Equal to ``hypotheses_per_plane`` (default): one batch, no adaptation (measured:
        adapting upward lost a scene of the end-to-end set, see docs/benchmarks.md).
    confidence : float
    min_confidence : float
        Where the disparity backend gives a confidence (``sgm``), samples below it do not
        seed hypotheses. Default 0: off (measured on 13 ``sgm`` staircases it gained
        nothing and moved one riser by 7 mm; see docs/benchmarks.md).
    confidence_weights : bool
        Multiply each sample's refit weight by its disparity confidence (off by default,
        same measurement).
    score_points : int
        Points each hypothesis is scored on (a random subset of the rest).
    min_plane_points : int
        Stop when the best plane has fewer grid-sample inliers than this ...
    min_inlier_ratio : float
        ... or explains less than this fraction of the scored rest (its cost is too high).
    max_planes : int
        Safety bound on the loop.
    min_threshold_m, max_threshold_m : float
        Bounds of the per-point inlier threshold.
    refine_iterations : int
        IRLS (Tukey) refinement passes on each extracted plane.
    max_rounds : int
        MSAC rounds (of ``hypotheses_per_plane`` each) tried for one plane before the loop
        concludes that no acceptable plane is left.
    sample_radius_cells : int
        Second and third sample points are drawn within this many grid cells of the first.
    target_points : int
        Grid subsample size.
    seed : int
        Seeds the sampling: a given seed gives the same planes.
    """

    angle_tol_deg: float = 6.0
    normal_agreement_deg: float = 20.0
    normal_noise_sigmas: float = 0.0
    max_noise_tolerance_deg: float = 35.0
    threshold_sigmas: float = 3.0
    min_threshold_m: float = 0.012
    max_threshold_m: float = 0.05
    hypotheses_per_plane: int = 100
    max_hypotheses_per_plane: int = 100
    confidence: float = 0.99
    min_confidence: float = 0.0
    confidence_weights: bool = False
    score_points: int = 800
    min_plane_points: int = 40
    min_inlier_ratio: float = 0.01
    max_planes: int = 16
    sample_radius_cells: int = 5
    target_points: int = 12000
    refine_iterations: int = 2
    max_rounds: int = 3
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "max_rounds")
        check_min(self, 0, "refine_iterations", "min_inlier_ratio", "threshold_sigmas", "min_confidence")
        if self.max_hypotheses_per_plane < self.hypotheses_per_plane:
            raise ConfigError("need max_hypotheses_per_plane >= hypotheses_per_plane")
        if not 0 < self.confidence < 1:
            raise ConfigError(f"confidence must be in (0, 1), got {self.confidence}")
        if not 0 < self.angle_tol_deg < 45:
            raise ConfigError(f"angle_tol_deg must be in (0, 45), got {self.angle_tol_deg}")
        if not 0 < self.normal_agreement_deg < 90:
            raise ConfigError(f"normal_agreement_deg must be in (0, 90), got {self.normal_agreement_deg}")
        check_min(self, 0, "normal_noise_sigmas")
        if not self.normal_agreement_deg <= self.max_noise_tolerance_deg < 45:
            raise ConfigError(
                "max_noise_tolerance_deg must be at least normal_agreement_deg and below 45 "
                f"(a wider test lets every normal seed both families), got {self.max_noise_tolerance_deg}"
            )
        if not 0 < self.min_threshold_m <= self.max_threshold_m:
            raise ConfigError("need 0 < min_threshold_m <= max_threshold_m")
        for name in (
            "hypotheses_per_plane",
            "max_hypotheses_per_plane",
            "score_points",
            "min_plane_points",
            "max_planes",
            "sample_radius_cells",
            "target_points",
        ):
            if getattr(self, name) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}")

    def inlier_threshold_m(self, sigma_m: np.ndarray) -> np.ndarray:
        """Each point's inlier threshold: ``threshold_sigmas`` times its depth sigma,
        clipped to ``[min_threshold_m, max_threshold_m]`` (float64 like ``sigma_m``)."""
        return np.clip(self.threshold_sigmas * sigma_m, self.min_threshold_m, self.max_threshold_m)


@dataclass(frozen=True)
class PlaneSegment:
    """One extracted plane and the grid samples that support it.

    Attributes
    ----------
    plane : Plane
        Normal up (horizontal) or toward the camera (vertical, other).
    kind : str
        ``horizontal``, ``vertical`` or ``other``.
    indices : (M,) int
        Inliers as indices into the :class:`GridSample`.
    rms_m : float
        RMS point-to-plane distance of the inliers.
    """

    plane: Plane
    kind: str
    indices: np.ndarray = field(repr=False)
    rms_m: float

    @property
    def count(self) -> int:
        return len(self.indices)


@dataclass(frozen=True)
class PlaneSet:
    """The planes found in a cloud, in extraction order (largest cost reduction first).

    Attributes
    ----------
    segments : tuple of PlaneSegment
    samples : GridSample
        The subsampled cloud the segments index into.
    up : (3,) float64
        Gravity-up direction in the cloud's frame.
    stop_reason : str
    method : str
        ``orientation``, ``contour`` or ``combined`` (``auto``).
    parameters : dict
        The parameters the method chose from the data, and counts of what it did (JSON
        serialisable; reported in the result's ``plane_stage``).
    """

    segments: tuple[PlaneSegment, ...]
    samples: GridSample = field(repr=False)
    up: np.ndarray = field(repr=False)
    stop_reason: str
    camera_position: np.ndarray = field(repr=False)
    method: str = "orientation"
    parameters: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def frame(self) -> str:
        return self.samples.frame


def transform_planes(planes: PlaneSet, T: Transform, *, up: np.ndarray | None = None) -> PlaneSet:
    """Express a plane set (its samples, planes, up and camera) in ``T.to_frame``.

    ``T.from_frame`` must be ``planes.frame``. The segments keep their kinds and inliers;
    a rigid motion keeps the sign conventions (normal up, or toward the camera). ``up``
    replaces the moved up direction when ``T`` is a correction of gravity itself.
    """
    if T.from_frame != planes.frame:
        raise FrameError(f"cannot apply {T.name} to planes in frame '{planes.frame}'")
    R, t = T.rotation, T.translation
    segments = tuple(dataclasses.replace(s, plane=s.plane.moved(R, t)) for s in planes.segments)
    return dataclasses.replace(
        planes,
        segments=segments,
        samples=transform_sample(planes.samples, T),
        up=R @ np.asarray(planes.up, dtype=np.float64) if up is None else np.asarray(up, dtype=np.float64),
        camera_position=T.apply(np.asarray(planes.camera_position, dtype=np.float64)[None, :])[0],
    )


def classify_normal(normal: np.ndarray, up: np.ndarray, angle_tol_deg: float) -> str:
    """``horizontal`` / ``vertical`` / ``other`` for a plane normal."""
    c = abs(float(np.dot(normal, up)))
    if c >= np.cos(np.radians(angle_tol_deg)):
        return HORIZONTAL
    if c <= np.sin(np.radians(angle_tol_deg)):
        return VERTICAL
    return OTHER


def orient_plane(plane: Plane, up: np.ndarray, camera_position: np.ndarray, kind: str) -> Plane:
    """Sign convention: normal up for horizontal planes, toward the camera otherwise."""
    if kind == HORIZONTAL:
        return plane if float(plane.normal @ up) >= 0 else Plane(-plane.normal, -plane.offset)
    return plane.oriented_toward(camera_position)


def grid_lookup(samples: GridSample) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(lut, row, col)``: grid cell -> sample index (-1 if none), and each sample's cell."""
    gh, gw = samples.grid_shape
    lut = np.full(gh * gw, -1, dtype=np.int64)
    lut[samples.grid_index] = np.arange(len(samples))
    return lut.reshape(gh, gw), samples.grid_index // gw, samples.grid_index % gw


def local_triplets(
    grid_lut: np.ndarray,
    gr: np.ndarray,
    gc: np.ndarray,
    first: np.ndarray,
    remaining: np.ndarray,
    radius: int,
    count: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """Draw up to ``count`` index triplets: a first point from ``first``, two more within
    ``radius`` grid cells of it (so that most triplets lie on one surface)."""
    from ._kernels import triplets_from_draws

    i0 = rng.choice(first, size=count * 2)
    off = rng.integers(-radius, radius + 1, size=(count * 2, 2, 2))
    return triplets_from_draws(grid_lut, gr, gc, i0, off, remaining, count)


def noise_widened(samples: GridSample, config: OrientationConfig, base_deg: float) -> np.ndarray | None:
    """Per sample, an angle tolerance (radians) of at least ``base_deg``, widened to
    ``normal_noise_sigmas`` of the sample's normal noise (``samples.normal_sigma_rad``, from
    the cloud stage: far, where a riser's normal is the small difference of two box means a
    few centimetres apart, tens of degrees), up to ``max_noise_tolerance_deg``. None where
    nothing widens (the option is off, or the samples carry no noise)."""
    if config.normal_noise_sigmas <= 0 or samples.normal_sigma_rad is None:
        return None
    base = float(np.radians(base_deg))
    wide = np.arctan(config.normal_noise_sigmas * np.tan(samples.normal_sigma_rad.astype(np.float64)))
    return np.clip(wide, base, max(base, float(np.radians(config.max_noise_tolerance_deg))))


def normal_agreement_cos(samples: GridSample, config: OrientationConfig) -> np.ndarray:
    """Per sample, the cosine a plane's normal and the sample's own must reach to agree:
    ``normal_agreement_deg``, widened where the sample's normal is uncertain
    (:func:`noise_widened`)."""
    return _agreement_cos(noise_widened(samples, config, config.normal_agreement_deg), config, len(samples))


def _agreement_cos(wide: np.ndarray | None, config: OrientationConfig, n: int) -> np.ndarray:
    """:func:`normal_agreement_cos` from the widened tolerances ``wide`` already found."""
    out = np.full(n, float(np.cos(np.radians(config.normal_agreement_deg))))
    if wide is not None:
        out = np.where(wide > np.radians(config.normal_agreement_deg), np.cos(wide), out)
    return out


def _best_plane(P, N, thr, lut, gr, gc, first, remaining, rest_view, rng, config, orient, agree_cos):
    """One MSAC round: local hypotheses, scored on a subset of the rest, refined by IRLS.

    ``rest_view`` is ``(rest indices, P[rest], N[rest], thr[rest], confidence[rest] or
    None)``; ``orient`` is ``(up, cos_tol, sin_tol, 1 / thr)``. Scoring, inliers and
    refinement are compiled (``_kernels``); the sampling stays here, on ``rng``. Returns
    ``(plane, inliers (N,) bool, inlier ratio on the scored subset, samples drawn)`` or
    None.
    """
    from ._kernels import best_oriented_hypothesis, oriented_inliers, refine_oriented_plane

    rest, Pr, Nr, thr_r, conf_r = rest_view
    agree_r = agree_cos[rest]
    up, cos_tol, sin_tol, inv_thr = orient
    radius = config.sample_radius_cells

    batch = config.hypotheses_per_plane
    trip = local_triplets(lut, gr, gc, first, remaining, radius, batch, rng)
    score = rng.choice(len(rest), size=min(config.score_points, len(rest)), replace=False)
    drawn: list[np.ndarray] = []
    requested = batch  # samples asked for (fewer come back where the grid has holes)
    best: tuple[np.ndarray, float] | None = None
    best_cost = np.inf
    inl_r = np.zeros(len(rest), dtype=bool)
    scored = rest[score]
    while True:
        drawn.append(trip)
        n, d, cost = best_oriented_hypothesis(P, N, inv_thr, trip, scored, up, cos_tol, sin_tol, agree_cos)
        if cost < best_cost:
            best, best_cost = (n, d), cost
            inl_r = oriented_inliers(Pr, Nr, thr_r, n, d, agree_r)
        if requested >= config.max_hypotheses_per_plane or len(trip) == 0:
            break
        if best is not None:
            # Iterations from the data: the fraction of the local samples drawn so far that
            # lie wholly on the best plane is the chance of a good sample; stop once one has
            # been drawn with probability ``confidence`` (Fischler & Bolles' rule applied
            # to the local sampler instead of the global inlier ratio cubed).
            on_best = np.zeros(len(P), dtype=bool)
            on_best[rest[inl_r]] = True
            p_good = float(np.mean(on_best[np.concatenate(drawn)].all(axis=1)))
            if sum(len(t) for t in drawn) >= required_trials(p_good, 1, config.confidence):
                break
        size = min(batch, config.max_hypotheses_per_plane - requested)
        requested += size
        trip = local_triplets(lut, gr, gc, first, remaining, radius, size, rng)
    hypotheses = sum(len(t) for t in drawn)
    if best is None:
        return None
    # Refine: iteratively reweighted least squares (Tukey weights) on the inliers, so that a
    # hypothesis tilted across two levels settles on the better supported one; the
    # orientation constraint is kept. Weighted by the disparity confidence if asked.
    use_conf = conf_r is not None and config.confidence_weights
    weights = conf_r if use_conf else np.ones(len(rest))
    n, d, inl_r = refine_oriented_plane(
        Pr, Nr, thr_r, weights, best[0], best[1], up, cos_tol, sin_tol, agree_r, config.refine_iterations
    )
    plane = Plane(n, d)
    ratio = float(np.mean(inl_r[score])) if len(score) else 0.0
    inl = np.zeros(len(P), dtype=bool)
    inl[rest[inl_r]] = True
    return plane, inl, ratio, hypotheses


def _one_batch_round(P, N, thr, weights, lut, gr, gc, first, remaining, rest, rng, config, orient, agree_cos):
    """:func:`_best_plane` for one batch of hypotheses per round (``max_hypotheses_per_plane
    == hypotheses_per_plane``, the default): the same draws from ``rng`` in the same order,
    then the round in one compiled call (:func:`._kernels.oriented_round`), the same plane
    and inliers bit for bit. Returns ``(plane, inlier indices (ascending), inlier ratio on
    the scored subset, samples drawn)`` or None."""
    from ._kernels import oriented_round

    up, cos_tol, sin_tol, inv_thr = orient
    batch = config.hypotheses_per_plane
    radius = config.sample_radius_cells
    # local_triplets' draws, then the scored subset's (the order of _best_plane).
    # rng.choice(first, size) with replacement is first[rng.integers(0, len(first), size)]
    # (NumPy's own definition: the same draws), without choice's Python overhead.
    i0 = first[rng.integers(0, len(first), size=batch * 2)]
    off = rng.integers(-radius, radius + 1, size=(batch * 2, 2, 2))
    score = rng.choice(len(rest), size=min(config.score_points, len(rest)), replace=False)
    ok, n, d, idx, ratio, drawn = oriented_round(
        P,
        N,
        thr,
        inv_thr,
        weights,
        lut,
        gr,
        gc,
        i0,
        off,
        remaining,
        batch,
        rest,
        score,
        up,
        cos_tol,
        sin_tol,
        agree_cos,
        config.refine_iterations,
    )
    if not ok:
        return None
    return Plane(n, d), idx, ratio, drawn


def extract_planes_orientation(
    cloud: PointCloud | GridSample,
    config: OrientationConfig | None = None,
    *,
    up: np.ndarray | None = None,
    camera_position: np.ndarray | None = None,
    rng: np.random.Generator | int | None = None,
) -> PlaneSet:
    """Decompose a cloud into horizontal and vertical planes (the orientation method).

    Parameters
    ----------
    cloud : PointCloud (organized) or an already computed GridSample
        Best in a gravity-aligned frame (``yaw``), where ``up`` is +z.
    config : OrientationConfig
    up : (3,) float, optional
        Gravity-up direction in the cloud's frame (default +z).
    camera_position : (3,) float, optional
        Used to orient normals toward the camera; defaults to the cloud's camera.
    rng : Generator or seed; defaults to ``config.seed`` (deterministic).

    Returns
    -------
    PlaneSet; an empty one (``stop_reason`` says why) when no plane is found.
    """
    config = config or OrientationConfig()
    rng = np.random.default_rng(config.seed if rng is None else rng)
    up = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    if isinstance(cloud, PointCloud):
        samples = sample_grid(cloud, target_points=config.target_points)
        cam = cloud.camera_position if camera_position is None else camera_position
    else:
        samples = cloud
        cam = samples.camera_position if camera_position is None else camera_position
    cam = np.asarray(cam, dtype=np.float64)
    n_pts = len(samples)
    P = samples.points
    N = samples.normals
    thr = config.inlier_threshold_m(samples.sigma_m).astype(np.float32)
    lut, gr, gc = grid_lookup(samples)
    cos_tol, sin_tol = np.cos(np.radians(config.angle_tol_deg)), np.sin(np.radians(config.angle_tol_deg))
    # Far samples' normal tests, widened by their noise (None: nothing widens).
    wide = noise_widened(samples, config, config.normal_agreement_deg)
    agree_cos = _agreement_cos(wide, config, len(samples))
    upf = up.astype(np.float32)
    nz = np.abs(N @ upf)
    # First sample points: local normal near horizontal or vertical (with some slack).
    slack = np.radians(10.0)
    conf = None
    if samples.confidence is not None and (config.min_confidence > 0 or config.confidence_weights):
        conf = np.clip(np.nan_to_num(samples.confidence, nan=0.0), 1e-3, 1.0).astype(np.float64)
    seedable = (nz >= np.cos(np.radians(config.angle_tol_deg) + slack)) | (
        nz <= np.sin(np.radians(config.angle_tol_deg) + slack)
    )
    # Far samples, whose normals are too noisy for that test, seed within their noise where
    # the agreement test is widened for them (the same angle).
    if wide is not None:
        far = wide > np.radians(config.normal_agreement_deg)
        seedable |= far & ((nz >= np.cos(wide)) | (nz <= np.sin(wide)))
    n_low = 0
    if conf is not None:
        # Low-confidence disparities (ambiguous matches) do not seed hypotheses; they are
        # still scored and can be inliers, with a small weight in the refit.
        low = conf < config.min_confidence
        n_low = int((low & seedable).sum())
        seedable &= ~low

    orient = (up, float(cos_tol), float(sin_tol), (1.0 / thr).astype(np.float32))
    # One batch per round (the default): the whole round in one compiled call.
    one_batch = config.max_hypotheses_per_plane == config.hypotheses_per_plane
    use_conf = conf is not None and config.confidence_weights
    weights = conf if use_conf else np.ones(n_pts)
    remaining = np.ones(n_pts, dtype=bool)
    segments: list[PlaneSegment] = []
    rounds_used = 0
    hypotheses: list[int] = []
    stop = f"reached max_planes={config.max_planes}"
    for _ in range(config.max_planes):
        rest = np.flatnonzero(remaining)
        if len(rest) < config.min_plane_points:
            stop = f"rest of the cloud too small ({len(rest)} < {config.min_plane_points} points)"
            break
        first = np.flatnonzero(remaining & seedable)
        if len(first) == 0:
            stop = "no remaining point has a horizontal or vertical normal"
            break
        # MSAC rounds: a round whose best plane is too small or too costly is retried with
        # fresh samples (the inlier ratio of the rest can be low when clutter dominates it)
        # before the loop stops; the number of hypotheses thus grows with need.
        found = None
        rest_view = None
        for _round in range(config.max_rounds):
            rounds_used += 1
            if one_batch:
                found = _one_batch_round(
                    P, N, thr, weights, lut, gr, gc, first, remaining, rest, rng, config, orient, agree_cos
                )
            else:
                if rest_view is None:
                    rest_view = (rest, P[rest], N[rest], thr[rest], None if conf is None else conf[rest])
                found = _best_plane(
                    P, N, thr, lut, gr, gc, first, remaining, rest_view, rng, config, orient, agree_cos
                )
                if found is not None:
                    found = (found[0], np.flatnonzero(found[1]), found[2], found[3])
            if found is not None:
                hypotheses.append(found[3])
            if (
                found is not None
                and len(found[1]) >= config.min_plane_points
                and found[2] >= config.min_inlier_ratio
            ):
                break
        if found is None:
            stop = "no hypothesis satisfied the orientation constraint"
            break
        plane, idx, ratio, _ = found
        count = len(idx)
        if count < config.min_plane_points:
            stop = f"best plane too small ({count} < {config.min_plane_points} points)"
            break
        if ratio < config.min_inlier_ratio:
            stop = f"best plane too costly (explains {ratio:.1%} of the rest)"
            break
        kind = classify_normal(plane.normal, up, config.angle_tol_deg)
        plane = orient_plane(plane, up, cam, kind)
        rms = float(np.sqrt(np.mean(plane.residuals(P[idx]) ** 2)))
        segments.append(PlaneSegment(plane, kind, idx, rms))
        remaining[idx] = False
    params = {
        "angle_tol_deg": config.angle_tol_deg,
        "inlier_threshold_m_median": round(float(np.median(thr)), 4) if n_pts else None,
        "msac_rounds": rounds_used,
        "msac_hypotheses": {
            "total": int(sum(hypotheses)),
            "per_round_median": float(np.median(hypotheses)) if hypotheses else 0.0,
            "per_round_max": int(max(hypotheses, default=0)),
            "confidence": config.confidence,
        },
        "confidence_weighting": conf is not None,
        "low_confidence_seeds_excluded": int(n_low),
    }
    return PlaneSet(tuple(segments), samples, up, stop, cam, "orientation", params)
