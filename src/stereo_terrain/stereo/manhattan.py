"""Manhattan fill: texture-poor faces from the vertical edges at their ends.

The planar fill (:mod:`stereo_terrain.stereo.fill`) fits a free plane ``d = a u + b v + c``
to the disparities on a face's outline. A painted riser whose far end leaves the image,
or several risers of one shade merged into one region above the cameras, give it only
vertical segments (the ends of the steps) to fit: a vertical segment fixes no plane, and
the region is left to the matcher, whose values there are noise.

Built scenes are Manhattan: treads and floors are horizontal, risers and walls vertical,
and the vertical faces come in two families at right angles, along the staircase and
across it. Given up and one horizontal direction ``h`` of the scene (from the image's
lines, :func:`stereo_terrain.gravity.from_lines.horizontal_direction`), a face's normal is one of
``up``, ``h`` and ``up x h``, and a plane of known normal ``n`` has a single unknown: its
disparity is ``d + doffs = s g(u, v)`` with ``g = n . K^-1 (u, v, 1)`` (``s`` = f B over
the plane's distance from the camera). One support disparity fixes ``s``.

For each texture-poor region that the planar fill left:

1. the support: the matcher's disparities on vertical edges in it and beside it in its
   own rows (its ends; not the edges of the faces above and below it);
2. the face's family: its outline's non-vertical edges are the images of horizontal 3D
   lines in it, which point at the vanishing point of ``up x n``; the vertical family
   whose lines the edges follow is the face's candidate against the horizontal one;
3. per candidate normal (that vertical family, a tread, the other vertical family), the
   support split into planes by MSAC on ``s`` (one per cluster of support, at most
   ``manhattan_max_planes``), which must stack along the face's lines; of the candidates
   that explain about as much support as the best, the one with the fewest planes wins,
   unless its plane is that of a differently shaded neighbouring face (along a vertical
   segment a vertical face's disparity is constant and a tread's changes with the row,
   so the segment tells them apart);
4. each pixel of the region (and of its ring not claimed by another region) lies on one
   of the face's horizontal lines; it takes the plane whose support covers the nearest
   interval of those lines, within ``manhattan_reach_px``. So two risers of one shade
   merged into one region are split at their ends' heights.

This is what lets a riser with one end in view, or no texture at all, become a plane in
the cloud; it is not a matcher: where the support is wrong (an occluding edge whose
disparity belongs to the face behind), so is the fill.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .._numeric import cross3, median, percentile
from ..rectify import Rectification
from . import _regions
from ._manhattan_kernels import (
    fill_face,
    fill_targets,
    finite_samples,
    hypothesis_costs,
    mostly_filled,
    outline_edges,
)
from ._regions import edge_support
from .fill import FlatRegions, PlanarFillConfig, edge_gx, large_regions, region_box

#: Outline edges within this angle of the image's vertical are the faces' ends, not
#: their horizontal lines.
_VERTICAL_EDGE_DEG = 30.0
#: A support cluster must cover at least this many pixels across the face's lines.
_MIN_SPAN_PX = 5.0
#: Lines steeper than this in the image (|dv/du|) make the cross-line coordinate
#: ill-conditioned: such a face is left alone.
_MAX_LINE_SLOPE = 1.0
#: Candidates that explain at least this share of the best one's support tie.
_TIE_SHARE = 0.95
#: A face's family is known when at least this share of its outline's strong,
#: non-vertical edges follow that family's lines.
_MIN_ALIGNMENT = 0.3
#: Support disparities are subsampled to at most this many per region.
_MAX_SUPPORT = 300
#: MSAC hypotheses per plane (one unknown: a few dozen draws find a cluster of 8 of 300).
_HYPOTHESES = 32
#: The outline's edges are a statistic: every other pixel will do.
_OUTLINE_STRIDE = 2
#: Neighbouring faces whose mean grey levels differ by more than this are not one plane
#: ... (same normal: cosine above this).
_SHADE_STEP_GREY = 6.0
_SAME_NORMAL_COS = 0.999
#: Two planes of one face may share this much of the shorter one's interval of lines ...
_MAX_OVERLAP = 0.25
#: ... and are one when their disparities differ by at most this (pixels).
_MERGE_PX = 1.5


def fill_manhattan_faces(
    disparity: np.ndarray,
    filled_disparity: np.ndarray,
    filled: np.ndarray,
    regions: FlatRegions,
    image: np.ndarray,
    rectification: Rectification,
    up: np.ndarray,
    horizontal: np.ndarray,
    config: PlanarFillConfig,
    *,
    max_disparity_px: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Fill the texture-poor regions the planar fill left with Manhattan planes.

    Parameters
    ----------
    disparity : (H, W) float32
        The matcher's disparity (the support is read from it), NaN invalid.
    filled_disparity, filled : (H, W) float32, (H, W) bool
        The planar fill's output and mask (not written to).
    regions : FlatRegions
        The planar fill's regions of the rectified left image.
    image : (H, W) uint8
        The rectified left image (the faces' shading).
    rectification : Rectification
        Intrinsics of the rectified pair (``focal_px``, ``cx``, ``cy``, ``doffs_px``).
    up, horizontal : (3,) arrays
        Up and one horizontal direction of the scene in the rectified left camera.
    config : PlanarFillConfig
    max_disparity_px : float, optional
        Filled values stay in ``(0, max_disparity_px)``.

    Returns
    -------
    filled_disparity : (H, W) float32, a new array
    filled : (H, W) bool, a new array: the planar fill's mask and the pixels filled here
    """
    out, mask = filled_disparity.copy(), filled.copy()
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    h = np.asarray(horizontal, dtype=np.float64)
    h = h - (h @ up) * up
    if not np.linalg.norm(h) > 1e-6:
        return out, mask
    h /= np.linalg.norm(h)
    line_dirs = (h, cross3(up, h))  # the horizontal lines of the two vertical families
    risers = tuple(cross3(line_dir, up) for line_dir in line_dirs)  # their faces' normals
    normals = np.array([up, h, line_dirs[1]])  # the scene's three plane normals
    stats, labels = regions.stats, regions.labels
    large = large_regions(stats, disparity.shape, config)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * config.ring_px + 1,) * 2)
    row_kernel = np.ones((1, 2 * config.ring_px + 1), np.uint8)
    wide_kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (6 * config.ring_px + 1,) * 2)
    edge_threshold = edge_gx(config)
    rng = np.random.default_rng(config.seed)
    # The faces filled here, largest region first: their planes (normal, s) and shading,
    # and which pixels hold which.
    face_of = np.full(disparity.shape, -1, np.int32)
    camera = np.array([rectification.focal_px, rectification.cx, rectification.cy, rectification.doffs_px])
    faces: list[tuple[np.ndarray, float, float]] = []
    order = np.flatnonzero(large)
    for k in order[np.argsort(-stats[order, 4], kind="stable")]:
        x, bw = int(stats[k, 0]), int(stats[k, 2])
        x0, y0, x1, y1 = region_box(stats[k], disparity.shape, config.ring_px)
        box_labels = labels[y0:y1, x0:x1]
        region = box_labels == k
        region_u8 = region.view(np.uint8)  # OpenCV's morphology takes bytes
        refit = False
        if mostly_filled(mask[y0:y1, x0:x1], region):
            # The planar fill's free plane: kept when it is one of the scene's directions,
            # fitted again here when it is not (a painted riser whose outline support holds
            # a railing in front of it slopes the wrong way).
            if config.manhattan_check_deg <= 0 or _is_manhattan(
                out[y0:y1, x0:x1], region, x0, y0, rectification, normals, config.manhattan_check_deg
            ):
                continue
            refit = True
        # The support: vertical edges beside the face in its own rows (its ends), not those
        # of the faces above and below it.
        beside = cv2.dilate(region_u8, row_kernel)
        box = disparity[y0:y1, x0:x1]
        vs, us = edge_support(beside, box, regions.gx[y0:y1, x0:x1], edge_threshold, True)
        if len(us) < 2 * config.manhattan_min_support:
            continue
        u, v = us + float(x0), vs + float(y0)
        d = box[vs, us].astype(np.float64)
        if len(u) > _MAX_SUPPORT:
            pick = rng.choice(len(u), _MAX_SUPPORT, replace=False)
            u, v, d = u[pick], v[pick], d[pick]
        ring_u8 = cv2.dilate(region_u8, kernel)
        scores = _outline_alignment(
            ring_u8,
            cv2.erode(region_u8, kernel),
            regions.gx[y0:y1, x0:x1],
            regions.gy[y0:y1, x0:x1],
            x0,
            y0,
            line_dirs,
            rectification,
            config,
        )
        if max(scores) < _MIN_ALIGNMENT:
            continue  # its outline follows neither family's lines: its family is unknown
        # The pixels to fill: the region and its ring, not another region's or a filled
        # pixel (a refitted region's own pixels are refilled).
        ext = fill_targets(ring_u8, box_labels, k, large, mask[y0:y1, x0:x1], refit)
        x_ref = x + bw / 2.0
        # Candidates: the vertical family the outline follows, a tread with the same
        # horizontal lines, the other vertical family. Support on concave corners lies on
        # both vertical families (the ends of several steps on the side wall): of the
        # candidates that explain about as much support, the one with the fewest planes
        # wins (a uniform wall is one plane, not a stack of risers).
        first = int(np.argmax(scores))
        candidates = [
            (line_dirs[first], risers[first]),
            (line_dirs[first], up),
            (line_dirs[1 - first], risers[1 - first]),
        ]
        found = []
        for line_dir, normal in candidates:
            lam, slope = _line_coordinate(u, v, line_dir, rectification, x_ref)
            if float(median(slope)) > _MAX_LINE_SLOPE:
                continue
            g = _normal_gain(normal, u, v, rectification)
            if np.any(np.abs(g) < 1e-3):
                continue  # the plane passes (nearly) through the camera
            planes, explained = _support_planes(u, v, d, g, lam, rectification.doffs_px, rng, config)
            # Planes whose disparities differ by less than the merge tolerance are one.
            s_tol = _MERGE_PX / float(median(np.abs(g)))
            planes = _stacked(planes, s_tol)
            if planes and explained >= config.min_inlier_ratio * len(u):
                found.append((explained, len(planes), line_dir, normal, planes, s_tol))
        if not found:
            continue
        # A concave corner's support (the ends of steps against a side wall) lies on the
        # wall's plane too: a face across an edge from a face already filled, shaded
        # differently, is not that face's plane.
        shade = float(image[y0:y1, x0:x1][region].mean())
        nearby: set[int] = set()
        if faces:
            around = cv2.dilate(region_u8, wide_kernel).astype(bool) & ~region
            nearby = {int(i) for i in np.unique(face_of[y0:y1, x0:x1][around]) if i >= 0}
        found = [f for f in found if not _repeats_a_neighbour(f[3], f[4], shade, nearby, faces, f[5])]
        if not found:
            continue
        most = max(f[0] for f in found)
        _, _, line_dir, normal, planes, _ = min(
            (f for f in found if f[0] >= _TIE_SHARE * most), key=lambda f: f[1]
        )
        fill_face(
            ext,
            x0,
            y0,
            np.array([p[0] for p in planes]),
            np.array([p[1] for p in planes]),
            np.array([p[2] for p in planes]),
            normal,
            line_dir,
            camera,
            x_ref,
            float(config.manhattan_reach_px),
            np.inf if max_disparity_px is None else float(max_disparity_px),
            out,
            mask,
            face_of,
            len(faces),
        )
        faces.extend((normal, p[0], shade) for p in planes)
    return out, mask


def _repeats_a_neighbour(
    normal: np.ndarray,
    planes: list[tuple[float, float, float]],
    shade: float,
    nearby: set[int],
    faces: list[tuple[np.ndarray, float, float]],
    s_tol: float,
) -> bool:
    """Whether one of ``planes`` (of ``normal``) is the plane (``s`` within ``s_tol``) of a
    neighbouring face in ``faces`` whose mean grey level differs from ``shade`` by more
    than ``_SHADE_STEP_GREY`` (one plane of one paint is shaded alike)."""
    for i in nearby:
        n_i, s_i, shade_i = faces[i]
        if abs(shade - shade_i) <= _SHADE_STEP_GREY or float(normal @ n_i) < _SAME_NORMAL_COS:
            continue
        if any(abs(p[0] - s_i) <= s_tol for p in planes):
            return True
    return False


def _stacked(planes: list[tuple[float, float, float]], s_tol: float) -> list[tuple[float, float, float]]:
    """The planes of one face as a stack along its lines, or [] when they contradict: along
    each of a face's horizontal lines there is one plane, so two planes (``s``, interval
    of lines) whose intervals overlap by more than ``_MAX_OVERLAP`` of the shorter one
    claim the same lines at two distances. Planes whose ``s`` differ by at most ``s_tol``
    (one plane's support split by the inlier threshold) are one."""
    merged: list[tuple[float, float, float]] = []
    for s, lo, hi in sorted(planes, key=lambda p: p[0]):
        if merged and abs(s - merged[-1][0]) <= s_tol:
            s0, lo0, hi0 = merged[-1]
            merged[-1] = (s0, min(lo0, lo), max(hi0, hi))
        else:
            merged.append((s, lo, hi))
    by_line = sorted(merged, key=lambda p: p[1])
    for a, b in zip(by_line, by_line[1:], strict=False):
        overlap = min(a[2], b[2]) - b[1]
        if overlap > _MAX_OVERLAP * min(a[2] - a[1], b[2] - b[1]):
            return []
    return merged


def _is_manhattan(
    values: np.ndarray,
    region: np.ndarray,
    x0: int,
    y0: int,
    rect: Rectification,
    normals: np.ndarray,
    tol_deg: float,
) -> bool:
    """Whether the plane of the filled ``values`` on ``region`` (a box at ``x0, y0``) is
    within ``tol_deg`` of one of the scene's plane ``normals``. A plane ``d = a u + b v + c``
    has the normal ``(a f, b f, c + doffs + a cx + b cy)`` in the camera."""
    vs, us = finite_samples(region, values, 300)  # every step-th of them: at most ~300
    if len(us) < 3:
        return True
    A = np.column_stack([us + float(x0), vs + float(y0), np.ones(len(us))])
    (a, b, c), *_ = np.linalg.lstsq(A, values[vs, us].astype(np.float64), rcond=None)
    f = rect.focal_px
    n = np.array([a * f, b * f, c + rect.doffs_px + a * rect.cx + b * rect.cy])
    norm = float(np.linalg.norm(n))
    if not norm > 0:
        return True
    return float(np.max(np.abs(normals @ (n / norm)))) >= math.cos(math.radians(tol_deg))


def _normal_gain(normal: np.ndarray, u: np.ndarray, v: np.ndarray, rect: Rectification) -> np.ndarray:
    """``g = n . K^-1 (u, v, 1)``: a plane of normal ``n`` has ``d + doffs = s g``."""
    f = rect.focal_px
    return normal[0] * (u - rect.cx) / f + normal[1] * (v - rect.cy) / f + normal[2]


def _line_image_direction(
    u: np.ndarray, v: np.ndarray, line_dir: np.ndarray, rect: Rectification
) -> tuple[np.ndarray, np.ndarray]:
    """The image direction ``(du, dv)`` (not normalised) at pixel ``(u, v)`` of the 3D line
    along ``line_dir`` through it: d/dl of the projection of ``X + l line_dir``, pointing
    at the lines' vanishing point (``_manhattan_kernels.fill_face`` writes it out again)."""
    f = rect.focal_px
    return f * line_dir[0] - (u - rect.cx) * line_dir[2], f * line_dir[1] - (v - rect.cy) * line_dir[2]


def _line_coordinate(
    u: np.ndarray, v: np.ndarray, line_dir: np.ndarray, rect: Rectification, x_ref: float
) -> tuple[np.ndarray, np.ndarray]:
    """Which of the 3D lines along ``line_dir`` each pixel's image line is: the row at which
    the image line through ``(u, v)`` towards their vanishing point crosses column
    ``x_ref``; and the line's slope ``|dv/du|`` there."""
    du, dv = _line_image_direction(u, v, line_dir, rect)
    slope = dv / np.where(np.abs(du) < 1e-9, 1e-9, du)
    return v + (x_ref - u) * slope, np.abs(slope)


def _outline_alignment(
    ring: np.ndarray,
    core: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    x0: int,
    y0: int,
    line_dirs: tuple[np.ndarray, ...],
    rect: Rectification,
    config: PlanarFillConfig,
) -> list[float]:
    """For each of ``line_dirs``: the gradient-weighted share of the strong, non-vertical
    edges of a face's outline (the band ``ring & ~core`` around its boundary, 0/1 bytes: the
    face dilated and eroded, in a box at ``x0, y0``) that follow the image lines of that
    direction."""
    # The strong edges not within _VERTICAL_EDGE_DEG of the image's vertical.
    vs, us, gxs, gys, m = outline_edges(
        ring,
        core,
        gx,
        gy,
        _OUTLINE_STRIDE,
        np.float32(8.0 * config.edge_gradient),
        np.float32(math.cos(math.radians(_VERTICAL_EDGE_DEG))),
    )
    if not len(m):
        return [0.0] * len(line_dirs)
    ex, ey = -gys / m, gxs / m  # along the edge: (-gy, gx) / |g|
    u, v = us + float(x0), vs + float(y0)
    total = float(np.sum(m))
    cos_tol = math.cos(math.radians(config.manhattan_edge_deg))
    shares = []
    for line_dir in line_dirs:
        du, dv = _line_image_direction(u, v, line_dir, rect)
        cos = np.abs(ex * du + ey * dv) / (np.hypot(du, dv) + 1e-12)
        shares.append(float(np.sum(m[cos > cos_tol])) / total)
    return shares


def _support_planes(
    u: np.ndarray,
    v: np.ndarray,
    d: np.ndarray,
    g: np.ndarray,
    lam: np.ndarray,
    doffs: float,
    rng: np.random.Generator,
    config: PlanarFillConfig,
) -> tuple[list[tuple[float, float, float]], int]:
    """The support split into planes of one normal (``g`` per support pixel): greedy MSAC
    on ``s``, each plane refit by least squares on its inliers. Returns ``(s, lam_lo,
    lam_hi)`` per plane (the interval of the face's lines its support covers, 2nd-98th
    percentile) and the number of support pixels they explain."""
    thr = config.inlier_threshold_px
    target = d + doffs
    free = np.ones(len(u), dtype=bool)
    planes: list[tuple[float, float, float]] = []
    explained = 0
    for _ in range(config.manhattan_max_planes):
        idx = np.flatnonzero(free)
        if len(idx) < config.manhattan_min_support:
            break
        draws = idx[rng.integers(0, len(idx), min(_HYPOTHESES, len(idx)))]
        hyp = target[draws] / g[draws]
        s = float(hyp[np.argmin(hypothesis_costs(target, g, idx, hyp, thr**2))])
        inl = free & (np.abs(target - s * g) < thr)
        if inl.sum() < config.manhattan_min_support:
            break
        s = float(np.sum(g[inl] * target[inl]) / np.sum(g[inl] ** 2))
        inl = free & (np.abs(target - s * g) < thr)
        free &= ~inl
        count = int(inl.sum())
        if count < config.manhattan_min_support:
            continue
        lo, hi = (float(q) for q in percentile(lam[inl], [2, 98]))
        if hi - lo < _MIN_SPAN_PX:
            continue  # a speck, not a face's end
        planes.append((s, lo, hi))
        explained += count
    return planes, explained


def warm_up() -> None:
    """Load (or compile) the fill's compiled kernel now, not in the first frame that needs it
    (the pipeline's warm-up pair need not have a face for it), and the planar fill's (the
    same holds for it), for the array layouts the fills pass (boxes are slices)."""
    _regions.warm_up()
    hypothesis_costs(np.ones(2), np.ones(2), np.arange(2), np.ones(2), 1.0)
    on = np.ones((2, 2), bool)
    for box in _regions._box_layouts(np.float32):
        finite_samples(on, box, 300)
        outline_edges(
            on.view(np.uint8), np.zeros((2, 2), np.uint8), box, box, 2, np.float32(1), np.float32(1)
        )
    for filled, labels in zip(_regions._box_layouts(np.bool_), _regions._box_layouts(np.int32), strict=True):
        mostly_filled(filled, on)
        fill_targets(on.view(np.uint8), labels, 1, on[0], filled, True)
    one = np.ones(1)
    fill_face(
        np.ones((2, 2), bool),
        0,
        0,
        one,
        one,
        one,
        np.array([0.0, 0.0, 1.0]),
        np.array([1.0, 0.0, 0.0]),
        np.array([100.0, 1.0, 1.0, 0.0]),
        1.0,
        1.0,
        10.0,
        np.zeros((2, 2), np.float32),
        np.zeros((2, 2), bool),
        np.zeros((2, 2), np.int32),
        0,
    )
