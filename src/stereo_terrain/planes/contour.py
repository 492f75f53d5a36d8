"""The contour method (paper section 3.2.1): one plane per image region.

The rectified left image is smoothed and cut at several grey levels (the paper used
MATLAB's ``imcontour``; here OpenCV's border following on the thresholded image). Every
closed contour bounds a region; the regions are sorted by area and, of any pair that
overlaps with IoU > 0.3, only the larger is kept. Each region is projected into the
organized cloud (the grid samples whose pixel falls inside it) and one MSAC plane of any
orientation is fitted to those points. The polytope then follows the image's vertical
ordering of the planes (:func:`apply_ordering_rules`): a horizontal plane higher in the
image is higher in the scene, a vertical plane higher in the image is deeper.

The method needs faces that differ in brightness (shading by the light's direction) and
little texture inside a face: texture breaks a face into many small contours.

Parameters are chosen from the data where the paper's future work asks for it: MSAC
iterations from the inlier ratio of the best hypothesis so far and a confidence, the
inlier threshold from each point's depth noise and the residual scale of the region, the
grey levels from the image's histogram, the horizontal/vertical tolerance from each
plane's normal uncertainty, and the plane count from the regions whose best plane explains
enough of them. The values used are reported in ``PlaneSet.parameters``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..cloud import GridSample
from ..errors import ConfigError, InputError
from ..msac import Plane
from .orientation import (
    HORIZONTAL,
    VERTICAL,
    PlaneSegment,
    PlaneSet,
    classify_normal,
    grid_lookup,
    orient_plane,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ContourConfig:
    """Parameters of the contour method (SI units, angles in degrees where named).

    Attributes
    ----------
    levels : int
        Grey levels the smoothed image is cut at, at evenly spaced quantiles of its
        histogram (so they follow the exposure).
    blur_sigma_px : float
        Gaussian smoothing before contouring, at 640 px wide (scaled with the width); it
        washes out fine texture so that contours follow the faces' shading.
    min_area_frac : float
        Regions smaller than this fraction of the image are dropped.
    max_regions : int
        At most this many regions (the largest) get a plane.
    iou_threshold : float
        Of two regions overlapping with a larger IoU, only the larger is kept (paper: 0.3).
    min_plane_points : int
        A region's plane needs this many grid-sample inliers ...
    min_inlier_ratio : float
        ... and must explain this fraction of the region's samples; a region straddling
        two faces explains too little and gives no plane (the plane count thus follows
        the residuals, not a fixed number).
    confidence : float
        MSAC stops when an all-inlier sample has been drawn with this probability, given
        the inlier ratio of the best hypothesis so far.
    min_hypotheses, max_hypotheses : int
        Bounds of the MSAC iterations per region (drawn in batches of ``min_hypotheses``).
    score_points : int
        Points of a region each hypothesis is scored on (a random subset).
    threshold_sigmas : float
        Inlier threshold in units of each point's depth sigma and of the region's robust
        residual scale (the larger), clipped to ``[min_threshold_m, max_threshold_m]``.
    min_threshold_m, max_threshold_m : float
    normal_agreement_deg : float
        A point is an inlier only if its local normal is within this angle of the plane's.
    min_angle_tol_deg, max_angle_tol_deg : float
        Bounds of the tolerance within which a plane counts as horizontal or vertical; in
        between it is three standard errors of the plane's fitted normal.
    merge_angle_deg, merge_distance_m : float
        Planes of two regions closer than this in normal and offset are one plane.
    min_confidence : float
        Points whose disparity confidence is below this are not used (where the backend
        gives a confidence); the others are weighted by it in the least-squares refit.
    sample_radius_cells : int
        Second and third sample points are drawn within this many grid cells of the first.
    max_planes_per_region : int
        Planes taken out of one region, one after the other, while each explains at least
        ``min_inlier_ratio`` of what the ones before left.
    seed : int
    """

    levels: int = 10
    blur_sigma_px: float = 1.5
    min_area_frac: float = 0.003
    max_regions: int = 40
    iou_threshold: float = 0.3
    min_plane_points: int = 25
    min_inlier_ratio: float = 0.3
    confidence: float = 0.99
    min_hypotheses: int = 16
    max_hypotheses: int = 256
    score_points: int = 300
    threshold_sigmas: float = 1.5
    min_threshold_m: float = 0.012
    max_threshold_m: float = 0.03
    normal_agreement_deg: float = 20.0
    min_angle_tol_deg: float = 6.0
    max_angle_tol_deg: float = 12.0
    merge_angle_deg: float = 5.0
    merge_distance_m: float = 0.03
    min_confidence: float = 0.2
    sample_radius_cells: int = 4
    max_planes_per_region: int = 3
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 0, "seed")
        check_min(
            self,
            1,
            "levels",
            "max_regions",
            "min_plane_points",
            "min_hypotheses",
            "max_hypotheses",
            "score_points",
            "sample_radius_cells",
            "max_planes_per_region",
        )
        check_min(self, 0, "blur_sigma_px", "min_area_frac", "threshold_sigmas", "min_confidence")
        if not 0 < self.iou_threshold < 1:
            raise ConfigError(f"iou_threshold must be in (0, 1), got {self.iou_threshold}")
        if not 0 <= self.min_inlier_ratio <= 1:
            raise ConfigError(f"min_inlier_ratio must be in [0, 1], got {self.min_inlier_ratio}")
        if not 0 < self.confidence < 1:
            raise ConfigError(f"confidence must be in (0, 1), got {self.confidence}")
        if not 0 < self.min_threshold_m <= self.max_threshold_m:
            raise ConfigError("need 0 < min_threshold_m <= max_threshold_m")
        if not 0 < self.min_angle_tol_deg <= self.max_angle_tol_deg < 45:
            raise ConfigError("need 0 < min_angle_tol_deg <= max_angle_tol_deg < 45")
        if not 0 < self.normal_agreement_deg < 90:
            raise ConfigError(f"normal_agreement_deg must be in (0, 90), got {self.normal_agreement_deg}")
        if self.min_hypotheses > self.max_hypotheses:
            raise ConfigError("need min_hypotheses <= max_hypotheses")
        check_min(self, 0, "merge_angle_deg", "merge_distance_m")
        # Upper bounds that keep one frame's plane stage within seconds, not hours.
        for name, top in (("max_hypotheses", 10_000), ("levels", 255), ("blur_sigma_px", 50.0)):
            if getattr(self, name) > top:
                raise ConfigError(f"ContourConfig.{name} must be at most {top}, got {getattr(self, name)}")
        if not 0 < self.min_area_frac < 1:
            raise ConfigError(f"ContourConfig.min_area_frac must be in (0, 1), got {self.min_area_frac}")


@dataclass(frozen=True)
class Region:
    """One contour's region on the sample grid.

    Attributes
    ----------
    mask : (gh, gw) bool
        Grid cells inside the contour.
    area_px : float
        Area enclosed by the contour in full-resolution pixels.
    level : float
        Grey level of the contour.
    """

    mask: np.ndarray
    area_px: float
    level: float


def find_regions(
    image: np.ndarray,
    grid_shape: tuple[int, int],
    stride_px: int,
    config: ContourConfig | None = None,
) -> tuple[list[Region], list[float]]:
    """Contours of ``image`` at several grey levels, as regions on the sample grid.

    Parameters
    ----------
    image : (H, W) uint8 or (H, W, 3) uint8
        The rectified left image (BGR is converted to grey).
    grid_shape : (gh, gw)
        The :class:`GridSample` grid; cell ``(i, j)`` is pixel
        ``(stride // 2 + i * stride, stride // 2 + j * stride)``.
    stride_px : int
    config : ContourConfig

    Returns
    -------
    regions : list of Region, largest first, not deduplicated; regions covering no grid
        cell are dropped.
    levels : list of float, the grey levels used.
    """
    config = config or ContourConfig()
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    if img.ndim != 2 or img.size == 0:
        raise InputError(f"image must be (H, W) grey or (H, W, 3) BGR, got shape {img.shape}")
    h, w = img.shape
    # Contours are traced on a half-resolution image: the smoothing removes the detail the
    # full resolution would add, and the grid the regions are projected on is coarser still.
    scale = 2 if min(h, w) >= 200 else 1
    small = cv2.resize(img, (w // scale, h // scale), interpolation=cv2.INTER_AREA) if scale > 1 else img
    sigma = config.blur_sigma_px * w / 640.0 / scale
    smooth = cv2.GaussianBlur(small, (0, 0), sigma) if sigma > 0 else small
    qs = (np.arange(config.levels) + 0.5) / config.levels * 100.0
    levels = sorted({float(v) for v in np.percentile(smooth, qs)})
    min_area = config.min_area_frac * h * w
    gh, gw = grid_shape
    r0 = stride_px // 2
    shift = 4  # fixed-point bits of the polygon vertices on the grid
    found: list[Region] = []
    for level in levels:
        above = smooth >= level if level > smooth.min() else smooth > level
        # Both sides of the iso-line: a dark face touching the image border is closed
        # only as a region below the level.
        contours: list[np.ndarray] = []
        for binary in (above, ~above):
            if binary.all():
                continue  # the image frame itself is no contour (a uniform image has none)
            contours += cv2.findContours(binary.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[
                0
            ]
        for c in contours:
            area = cv2.contourArea(c) * scale * scale
            if area < min_area:
                continue
            # Contour vertices (small-image pixels) -> grid cell coordinates.
            xy = (c.reshape(-1, 2).astype(np.float64) * scale + (scale - 1) / 2.0 - r0) / stride_px
            poly = np.round(xy * (1 << shift)).astype(np.int32)
            mask = np.zeros((gh, gw), np.uint8)
            cv2.fillPoly(mask, [poly], 1, lineType=cv2.LINE_8, shift=shift)
            if mask.any():
                found.append(Region(mask.astype(bool), float(area), level))
    found.sort(key=lambda r: -r.area_px)
    return found, levels


def dedup_by_iou(masks: list[np.ndarray], threshold: float = 0.3) -> list[int]:
    """Indices of the regions kept when, of every pair with IoU > ``threshold``, only the
    larger survives (paper 3.2.1).

    Parameters
    ----------
    masks : list of (…) bool arrays of one shape, sorted largest first
    threshold : float

    Returns
    -------
    list of int, increasing.
    """
    kept: list[int] = []
    kept_flat: list[np.ndarray] = []
    areas: list[int] = []
    for i, m in enumerate(masks):
        flat = np.asarray(m, dtype=bool).reshape(-1)
        a = int(flat.sum())
        if a == 0:
            continue
        drop = False
        for k, ka in zip(kept_flat, areas, strict=True):
            inter = int(np.count_nonzero(flat & k))
            if inter and inter / (a + ka - inter) > threshold:
                drop = True
                break
        if not drop:
            kept.append(i)
            kept_flat.append(flat)
            areas.append(a)
    return kept


def _fit_region(
    P: np.ndarray,
    N: np.ndarray,
    thr_sigma: np.ndarray,
    weights: np.ndarray,
    lut: np.ndarray,
    gr: np.ndarray,
    gc: np.ndarray,
    inside: np.ndarray,
    rng: np.random.Generator,
    config: ContourConfig,
    agree_cos: float,
) -> tuple[Plane, np.ndarray, float, int, float] | None:
    """Adaptive MSAC on the samples of one region (any orientation).

    Returns ``(plane, inlier indices, inlier ratio in the region, trials, threshold)`` or
    None when no hypothesis could be drawn.
    """
    from ._kernels import region_msac

    idx = np.flatnonzero(inside)
    score = idx if len(idx) <= config.score_points else rng.choice(idx, config.score_points, replace=False)
    normal, offset, cost, trials = region_msac(
        P,
        N,
        (1.0 / thr_sigma).astype(np.float64),
        lut,
        gr,
        gc,
        inside,
        idx,
        score,
        config.sample_radius_cells,
        config.min_hypotheses,
        config.max_hypotheses,
        config.confidence,
        agree_cos,
        rng.random((4 * config.max_hypotheses, 5)),
    )
    if not np.isfinite(cost):
        return None
    plane = Plane(normal, offset)
    Pi, Ni, wi = P[idx], N[idx], weights[idx]
    thr = thr_sigma[idx]
    inl = (plane.residuals(Pi) < thr) & (np.abs(Ni @ plane.normal) >= agree_cos)
    if inl.sum() >= 3:
        # Inlier threshold from the data: the larger of the depth-noise model and the
        # region's own robust residual scale (SGBM noise can exceed the model).
        r = plane.residuals(Pi[inl])
        scale = 1.4826 * float(np.median(r))
        thr = np.clip(
            np.maximum(thr, config.threshold_sigmas * scale), config.min_threshold_m, config.max_threshold_m
        )
        inl = (plane.residuals(Pi) < thr) & (np.abs(Ni @ plane.normal) >= agree_cos)
    for _ in range(2):
        # Tukey-weighted refit, each point also weighted by its disparity confidence.
        if inl.sum() < 3:
            break
        ratio_r = plane.residuals(Pi[inl]) / thr[inl]
        wts = (np.clip(1.0 - ratio_r**2, 0.0, 1.0) ** 2 + 1e-6) * wi[inl]
        refit = Plane.estimate(Pi[inl], wts)
        if refit is None:
            break
        plane = refit
        inl = (plane.residuals(Pi) < thr) & (np.abs(Ni @ plane.normal) >= agree_cos)
    return plane, idx[inl], float(inl.mean()), trials, float(np.median(thr))


def normal_tolerance_deg(points: np.ndarray, rms_m: float, config: ContourConfig) -> float:
    """Angle within which a fitted plane counts as horizontal/vertical: three standard
    errors of its normal (``rms / (sqrt(n) * spread)``, spread = the points' smaller
    in-plane standard deviation), clipped to the configured bounds."""
    n = len(points)
    if n < 3:
        return config.max_angle_tol_deg
    q = points - points.mean(axis=0)
    ev = np.linalg.eigvalsh(q.T @ q / n)
    spread = math.sqrt(max(float(ev[1]), 1e-12))
    se_deg = math.degrees(math.atan(rms_m / (math.sqrt(n) * spread)))
    return float(np.clip(3.0 * se_deg, config.min_angle_tol_deg, config.max_angle_tol_deg))


def snap_to_gravity(plane: Plane, points: np.ndarray, up: np.ndarray, kind: str) -> Plane:
    """Refit a plane classified horizontal (vertical) with its normal exactly along
    (across) ``up``: gravity is known better than a plane fitted to a few hundred noisy
    samples, and disparity smoothing at a face's edges tilts the free fit by a few degrees.

    Parameters
    ----------
    plane : Plane
    points : (M, 3) float, its inliers
    up : (3,) float, unit
    kind : ``horizontal``, ``vertical`` or ``other`` (returned unchanged)
    """
    if kind == HORIZONTAL:
        return Plane(up, -float(np.median(points @ up)))
    if kind != VERTICAL or len(points) < 3:
        return plane
    n = plane.normal - (plane.normal @ up) * up  # the free fit's normal, levelled
    # Refine the horizontal direction by PCA of the points projected on the level plane.
    q = points - np.outer(points @ up, up)
    c = q.mean(axis=0)
    _, v = np.linalg.eigh((q - c).T @ (q - c))
    cand = [v[:, i] for i in range(3) if abs(v[:, i] @ up) < 0.5]
    if cand:
        best = min(cand, key=lambda e: float(np.sum(((q - c) @ e) ** 2)))
        if abs(best @ n) > 0.9 * np.linalg.norm(n):
            n = best
    n = n / np.linalg.norm(n)
    return Plane(n, -float(np.median(points @ n)))


def _merge_same_planes(
    found: list[tuple[Plane, np.ndarray]], P: np.ndarray, config: ContourConfig
) -> list[tuple[Plane, np.ndarray]]:
    """Planes of several regions that are one plane (normals within ``merge_angle_deg``,
    each one's points within ``merge_distance_m`` of the other, by the median) become one,
    refit once on the union. Each merged group is represented by its largest plane."""
    cos_m = math.cos(math.radians(config.merge_angle_deg))

    def near(plane: Plane, idx: np.ndarray) -> bool:
        # A median over every k-th point is plenty to tell two planes apart.
        sub = P[idx[:: max(1, len(idx) // 400)]]
        return bool(np.median(plane.residuals(sub)) <= config.merge_distance_m)

    planes: list[Plane] = []
    members: list[np.ndarray] = []  # (N,) bool per merged plane
    first_idx: list[np.ndarray] = []
    merged_any: list[bool] = []
    for plane, idx in sorted(found, key=lambda f: -len(f[1])):
        for k, p2 in enumerate(planes):
            if abs(float(plane.normal @ p2.normal)) < cos_m:
                continue
            if not near(p2, idx) or not near(plane, first_idx[k]):
                continue
            members[k][idx] = True
            merged_any[k] = True
            break
        else:
            mask = np.zeros(len(P), dtype=bool)
            mask[idx] = True
            planes.append(plane)
            members.append(mask)
            first_idx.append(idx)
            merged_any.append(False)
    out = []
    for p, m, again in zip(planes, members, merged_any, strict=True):
        idx = np.flatnonzero(m)
        out.append(((Plane.estimate(P[idx]) or p) if again else p, idx))
    return out


def extract_planes_contour(
    samples: GridSample,
    image: np.ndarray,
    config: ContourConfig | None = None,
    *,
    up: np.ndarray | None = None,
    camera_position: np.ndarray | None = None,
    rng: np.random.Generator | int | None = None,
) -> PlaneSet:
    """Decompose a cloud into planes, one per image region (the contour method).

    Parameters
    ----------
    samples : GridSample
        Grid subsample of the organized cloud, best in the gravity-aligned ``yaw`` frame.
    image : (H, W) uint8 or (H, W, 3) uint8
        The rectified left image the samples' pixels refer to.
    config : ContourConfig
    up : (3,) float, optional
        Gravity-up direction in the samples' frame (default +z).
    camera_position : (3,) float, optional
        Defaults to the samples' camera.
    rng : Generator or seed; defaults to ``config.seed``.

    Returns
    -------
    PlaneSet with ``method == "contour"``; planes of any orientation (kind ``other`` when
    neither horizontal nor vertical), after :func:`apply_ordering_rules`. Empty (with a
    ``stop_reason``) when no region gives a plane.

    Raises
    ------
    InputError
        When the image is not the size the samples were taken from.
    """
    config = config or ContourConfig()
    rng = np.random.default_rng(config.seed if rng is None else rng)
    up = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    cam = samples.camera_position if camera_position is None else camera_position
    cam = np.asarray(cam, dtype=np.float64)
    img = np.asarray(image)
    gh, gw = samples.grid_shape
    stride = samples.stride_px
    r0 = stride // 2
    if img.ndim < 2 or img.shape[0] < r0 + (gh - 1) * stride + 1 or img.shape[1] < r0 + (gw - 1) * stride + 1:
        raise InputError(
            f"image of shape {img.shape} is smaller than the grid the samples come from "
            f"({gh}x{gw} cells, {stride} px apart); pass the rectified left image"
        )
    params: dict[str, Any] = {"regions": 0, "regions_after_iou": 0}
    empty = PlaneSet((), samples, up, "", cam, "contour", params)
    if len(samples) < config.min_plane_points:
        return _with_stop(empty, f"cloud too small ({len(samples)} < {config.min_plane_points} points)")
    regions, levels = find_regions(img, samples.grid_shape, stride, config)
    params["grey_levels"] = [round(v, 1) for v in levels]
    params["regions"] = len(regions)
    keep = dedup_by_iou([r.mask for r in regions], config.iou_threshold)[: config.max_regions]
    params["regions_after_iou"] = len(keep)
    if not keep:
        return _with_stop(empty, "no image contour encloses enough area (a uniform image?)")

    P = samples.points.astype(np.float64)
    N = samples.normals.astype(np.float64)
    thr_sigma = np.clip(
        config.threshold_sigmas * samples.sigma_m, config.min_threshold_m, config.max_threshold_m
    )
    usable = np.ones(len(samples), dtype=bool)
    weights = np.ones(len(samples))
    if samples.confidence is not None:
        conf = np.nan_to_num(samples.confidence.astype(np.float64), nan=0.0)
        usable = conf >= config.min_confidence
        weights = np.clip(conf, 1e-3, 1.0)
    params["confidence_weighting"] = samples.confidence is not None
    params["points_below_min_confidence"] = int((~usable).sum())
    lut, gr, gc = grid_lookup(samples)
    agree_cos = math.cos(math.radians(config.normal_agreement_deg))
    found: list[tuple[Plane, np.ndarray]] = []
    trials_used: list[int] = []
    thresholds: list[float] = []
    rejected = 0
    for k in keep:
        inside = regions[k].mask.reshape(-1)[samples.grid_index] & usable
        # Planes are taken out of a region until the rest is small or the next plane
        # explains too little of it: a region that straddles a riser and a tread (same
        # shade) gives both, clutter gives none.
        for _ in range(config.max_planes_per_region):
            if inside.sum() < config.min_plane_points:
                break
            fit = _fit_region(P, N, thr_sigma, weights, lut, gr, gc, inside, rng, config, agree_cos)
            if fit is None:
                break
            plane, idx, ratio, trials, thr = fit
            trials_used.append(trials)
            if len(idx) < config.min_plane_points or ratio < config.min_inlier_ratio:
                rejected += 1
                break
            thresholds.append(thr)
            found.append((plane, idx))
            inside[idx] = False
    merged = _merge_same_planes(found, P, config)
    segments: list[PlaneSegment] = []
    tolerances: list[float] = []
    for plane, idx in merged:
        rms = float(np.sqrt(np.mean(plane.residuals(P[idx]) ** 2)))
        tol = normal_tolerance_deg(P[idx], rms, config)
        tolerances.append(tol)
        kind = classify_normal(plane.normal, up, tol)
        plane = snap_to_gravity(plane, P[idx], up, kind)
        rms = float(np.sqrt(np.mean(plane.residuals(P[idx]) ** 2)))
        segments.append(PlaneSegment(orient_plane(plane, up, cam, kind), kind, idx, rms))
    segments.sort(key=lambda s: -s.count)
    params.update(
        {
            "regions_fitted": len(trials_used),
            "regions_rejected_by_cost": rejected,
            "planes_before_merge": len(found),
            "msac_trials": {
                "min": min(trials_used, default=0),
                "median": float(np.median(trials_used)) if trials_used else 0.0,
                "max": max(trials_used, default=0),
            },
            "inlier_threshold_m_median": round(float(np.median(thresholds)), 4) if thresholds else None,
            "angle_tol_deg": [round(t, 2) for t in tolerances],
        }
    )
    ordered, dropped = apply_ordering_rules(segments, samples, up, cam)
    params["dropped_by_ordering"] = dropped
    stop = (
        f"{len(ordered)} plane(s) from {len(keep)} region(s); {rejected} region(s) explained too little"
        + (f"; {dropped} plane(s) broke the image ordering" if dropped else "")
    )
    if not ordered:
        stop = f"no region gave a plane ({len(keep)} region(s), {rejected} explained too little)"
    return PlaneSet(tuple(ordered), samples, up, stop, cam, "contour", params)


def _with_stop(ps: PlaneSet, reason: str) -> PlaneSet:
    return PlaneSet(ps.segments, ps.samples, ps.up, reason, ps.camera_position, ps.method, ps.parameters)


def image_order(segments: list[PlaneSegment] | tuple[PlaneSegment, ...], samples: GridSample) -> list[int]:
    """Indices of ``segments`` from the bottom of the image to the top (by the median image
    row of their inliers)."""
    rows = [float(np.median(samples.rows[s.indices])) if s.count else 0.0 for s in segments]
    return sorted(range(len(segments)), key=lambda i: -rows[i])


def _max_weight_monotone(values: list[float], weights: list[float], slack: float) -> list[int]:
    """Positions of the heaviest subsequence of ``values`` that never decreases by more
    than ``slack`` (O(n^2) dynamic programming; n is a few tens)."""
    n = len(values)
    best = list(weights)
    prev = [-1] * n
    for i in range(n):
        for j in range(i):
            if values[i] >= values[j] - slack and best[j] + weights[i] > best[i]:
                best[i], prev[i] = best[j] + weights[i], j
    if n == 0:
        return []
    i = int(np.argmax(best))
    out = []
    while i >= 0:
        out.append(i)
        i = prev[i]
    return out[::-1]


def apply_ordering_rules(
    segments: list[PlaneSegment],
    samples: GridSample,
    up: np.ndarray,
    camera_position: np.ndarray,
    *,
    slack_m: float = 0.03,
) -> tuple[list[PlaneSegment], int]:
    """The contour method's polytope ordering (paper 3.2.1), from the image's vertical order.

    Going up the image, horizontal planes must not get lower (median height of their
    points along ``up``) and vertical planes must not get nearer (distance of the plane
    from the camera). Planes that break the rule are dropped, keeping the order that
    explains the most samples (heaviest monotone subsequence); planes of other
    orientations are kept as they are.

    Returns
    -------
    (kept segments: horizontal ones bottom-to-top, then vertical ones near-to-far, then the
    others, and the number dropped)
    """
    up = np.asarray(up, dtype=np.float64)
    P = samples.points.astype(np.float64)
    cam = np.asarray(camera_position, dtype=np.float64)
    out: list[PlaneSegment] = []
    dropped = 0
    for kind in (HORIZONTAL, VERTICAL):
        group = [s for s in segments if s.kind == kind]
        order = image_order(group, samples)
        group = [group[i] for i in order]
        if kind == HORIZONTAL:
            vals = [float(np.median(P[s.indices] @ up)) for s in group]
        else:
            vals = [abs(float(s.plane.signed_distance(cam))) for s in group]  # depth of the plane
        keep = _max_weight_monotone(vals, [float(s.count) for s in group], slack_m)
        dropped += len(group) - len(keep)
        out += [group[i] for i in keep]
    out += [s for s in segments if s.kind not in (HORIZONTAL, VERTICAL)]
    return out, dropped
