"""Riser positions refined on the images themselves (issue 11: the runs of real stairs).

A riser's plane comes from the grid samples of a disparity map, each quantised by the
matcher and biased at the riser's edges; its position along the stair axis is off by
2-3 cm at 1.5-2.5 m with a 7 cm baseline, and a run, the difference of two, by more.
The images hold more than the samples: the plane predicts, for every pixel of the riser,
where the right image sees it (a homography, here a disparity linear in the pixel), and
the plane's distance is the one that makes the two views of the riser's face agree.

:func:`refine_risers` searches that distance for each step (its normal kept) over
``TerrainConfig.photometric_span`` of it, scoring the zero-mean normalised
cross-correlation of the two images' horizontal gradients over the riser's face (the
gradients ignore an exposure difference between the cameras, and the horizontal ones
are what a horizontal baseline can match: wood grain and plank gaps along the riser add
nothing and take nothing). The best distance is kept only where the score falls off
clearly on both sides of it (``photometric_min_sharpness``; a near-uniform face, or a
riser whose top or foot is wrong so that its face region mixes in the tread, scores
flat), where the two views do match there (``photometric_max_cost``), and where the
face's thirds across the image, each searched alone, put their best near each other
(``photometric_max_spread``); else, or where the move would bring two risers nearer than
a run can be, the samples' position stands. docs/benchmarks.md, "Twenty-sixth session",
has the probe these tests were chosen on.

OpenCV's dense matchers give a disparity per pixel, not the one plane that best explains a
region; plane sweeps (OpenCV has none for a rectified pair) score whole planes of the
scene, not one face's offset with its normal fixed. The search is a few dozen gathers of
the face's pixels, written here with NumPy.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property

import cv2
import numpy as np

from ..msac import Plane
from ..stereo.subpixel import parabola_peak
from .model import RiserMove, Step, TerrainConfig
from .risers import riser_distance

#: Fraction of a riser's height left out at its top and foot, and of its lateral extent
#: at its sides (:func:`fit_riser`'s ``lateral``; the terrain stage passes the middle 80% of
#: the riser plane's inliers): the nosing, the foot's shadow and the stringers are other
#: faces.
_FACE_MARGIN = 0.15
_SIDE_MARGIN = 0.1

#: Fewest face pixels a refinement is scored on.
_MIN_FACE_PIXELS = 400

#: Most face pixels a refinement is scored on (a larger face is thinned by rows).
_MAX_FACE_PIXELS = 3000

#: Distances tried across the span (odd: the samples' own is one of them).
_TRIALS = 41

#: Sub-pixel precision of the face's outline (cv2.fillConvexPoly's ``shift``).
_SUBPIXEL_BITS = 4
_SUBPIXEL = float(1 << _SUBPIXEL_BITS)

#: Mean range of three draws of a normal variable, in its sigmas.
_RANGE_OF_THREE = 1.693

#: Least |cos| between a riser's normal and the stair axis for its face to be searched.
_MIN_FACING = 0.2

#: Nearest a face may be for the search (metres): nearer, a plane through the cameras.
_MIN_DEPTH_M = 0.2


@dataclass(frozen=True)
class StereoView:
    """The rectified pair the terrain's planes came from, and where its left camera is.

    Attributes
    ----------
    left, right : (H, W) uint8
        Rectified grey images (epipolar lines are rows).
    focal_px, cx, cy : float
        The rectified left camera.
    baseline_m, doffs_px : float
        As :class:`~stereo_terrain.rectify.Rectification`: ``Z = focal_px * baseline_m /
        (d + doffs_px)``.
    T_frame_camera : (4, 4) float64
        Rectified left camera to the terrain's (gravity-aligned) frame.
    valid_left, valid_right : (H, W) bool or None
        Rectified pixels that have a raw source pixel (None: all).
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    focal_px: float
    cx: float
    cy: float
    baseline_m: float
    doffs_px: float
    T_frame_camera: np.ndarray = field(repr=False)
    valid_left: np.ndarray | None = field(repr=False, default=None)
    valid_right: np.ndarray | None = field(repr=False, default=None)

    @cached_property
    def gradients(self) -> tuple[np.ndarray, np.ndarray]:
        """Horizontal gradients (Sobel after a 3x3 Gaussian) of the left and right images,
        float32."""
        left, right = (cv2.Sobel(smoothed(img), cv2.CV_32F, 1, 0) for img in (self.left, self.right))
        return left, right


def smoothed(image: np.ndarray) -> np.ndarray:
    """``image`` as float32 after the 3x3 Gaussian the gradients are taken after
    (:attr:`StereoView.gradients`, :func:`~.nosings.plumb.plumb_segments`)."""
    out: np.ndarray = cv2.GaussianBlur(np.asarray(image, dtype=np.float32), (3, 3), 0)
    return out


@dataclass(frozen=True)
class RiserFit:
    """One riser's search (:func:`fit_riser`).

    Attributes
    ----------
    scale : float
        The factor on ``d + doffs`` (the inverse of the depth's) at which the two images of
        the face agree best; 1 is the plane as given.
    cost : float
        1 - the normalised correlation there, in [0, 2].
    sharpness : float
        How much the cost rises ``0.3 * photometric_span`` away on both sides (their mean);
        0 where one side is out of the span.
    pixels : int
        Face pixels scored.
    kept : bool
        Inside the span and within ``TerrainConfig``'s ``photometric_*`` limits.
    spread : float
        How far apart the best scales of the face's thirds (across the image) are.
    scale_sigma : float
        1-sigma of ``scale`` from that spread (three draws span 1.69 sigma on average, and
        the whole face averages three thirds), at least half the trials' spacing.
    """

    scale: float
    cost: float
    sharpness: float
    pixels: int
    kept: bool
    spread: float
    scale_sigma: float


def fit_riser(
    view: StereoView,
    plane: Plane,
    z_range: tuple[float, float],
    lateral: tuple[float, float],
    v: np.ndarray,
    config: TerrainConfig,
) -> RiserFit | None:
    """Search the distance of a riser plane that best explains both images over its face.

    Parameters
    ----------
    view : StereoView
    plane : Plane
        The riser, terrain frame (normal toward the camera).
    z_range : (float, float)
        Heights of its foot and top, metres, terrain frame; ``_FACE_MARGIN`` of the height
        is left out at both.
    lateral : (float, float)
        Its extent across the stair, metres along ``v``; ``_SIDE_MARGIN`` of it is left out
        at both sides.
    v : (3,) float64
        The stair's lateral direction (horizontal, unit); the stair axis is ``v`` turned
        -90 deg about up.
    config : TerrainConfig
        ``photometric_span`` and the limits that make a fit ``kept``.

    Returns
    -------
    RiserFit, or None where the face is behind or too near the cameras, along the stair
    axis, or under ``_MIN_FACE_PIXELS`` in view.
    """
    T = np.asarray(view.T_frame_camera, dtype=np.float64)
    R, t = T[:3, :3], T[:3, 3]
    n_c = R.T @ plane.normal  # the plane in the camera frame: n_c . X + o_c = 0
    o_c = float(plane.offset + plane.normal @ t)
    if o_c <= 0:
        return None  # the camera is behind the face
    z0, z1 = z_range
    dz = z1 - z0
    l0, l1 = lateral
    dl = l1 - l0
    if dz <= 0 or dl <= 0:
        return None
    z0, z1 = z0 + _FACE_MARGIN * dz, z1 - _FACE_MARGIN * dz
    l0, l1 = l0 + _SIDE_MARGIN * dl, l1 - _SIDE_MARGIN * dl
    h, w = view.left.shape[:2]
    # The face's corners: on the plane, at the lateral positions and heights asked, found
    # along the stair axis (a riser turned from it keeps its lateral extent).
    u = np.array([v[1], -v[0], 0.0])
    along = float(plane.normal @ u)
    if abs(along) < _MIN_FACING:
        return None  # a plane along the stair axis is no riser of it
    corners = []
    for lat in (l0, l1):
        for z in (z0, z1):
            p = lat * v + np.array([0.0, 0.0, z])
            corners.append(p - (plane.offset + plane.normal @ p) / along * u)
    X = (np.asarray(corners) - t) @ R
    if np.any(X[:, 2] < _MIN_DEPTH_M):
        return None
    uv = view.focal_px * X[:, :2] / X[:, 2:3] + np.array([view.cx, view.cy])
    c0, r0 = np.floor(uv.min(axis=0)).astype(int)
    c1, r1 = np.ceil(uv.max(axis=0)).astype(int)
    c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1, w - 1), min(r1, h - 1)
    if c1 - c0 < 3 or r1 - r0 < 3:
        return None
    # The face is a quadrilateral on the plane, so in the image too.
    quad = np.rint((uv[[0, 1, 3, 2]] - np.array([c0, r0])) * _SUBPIXEL).astype(np.int32)
    mask = np.zeros((r1 - r0 + 1, c1 - c0 + 1), dtype=np.uint8)  # the bounding box's
    cv2.fillConvexPoly(mask, quad, 1, lineType=cv2.LINE_8, shift=_SUBPIXEL_BITS)
    face = mask.astype(bool)
    if view.valid_left is not None:
        face &= np.asarray(view.valid_left)[r0 : r1 + 1, c0 : c1 + 1]
    count = int(face.sum())
    if count < _MIN_FACE_PIXELS:
        return None
    if count > _MAX_FACE_PIXELS:
        # Every k-th row of a large face: the correlation needs thousands of pixels, not
        # tens of thousands (a near riser fills a fifth of the image).
        face[(np.arange(face.shape[0]) % math.ceil(count / _MAX_FACE_PIXELS)) != 0] = False
    r_rel, c_rel = np.nonzero(face)
    r_idx = (r_rel + r0).astype(np.intp)
    c_f = (c_rel + c0).astype(np.float64)
    rays = np.column_stack(
        [(c_f - view.cx) / view.focal_px, (r_idx - view.cy) / view.focal_px, np.ones(len(c_f))]
    )
    depth = -o_c / np.minimum(rays @ n_c, -1e-9)  # the corners are in front: so is the face
    d_plus = view.focal_px * view.baseline_m / depth  # d + doffs on the plane
    span = config.photometric_span
    scales = np.linspace(1.0 - span, 1.0 + span, _TRIALS)
    # Where the right image sees each face pixel at the span's two ends and at the samples'
    # distance: a pixel is scored where all three are inside the right image's valid part
    # (a row's valid part is one interval, and the column moves monotonically with scale).
    ends = c_f[None, :] - (scales[[0, _TRIALS // 2, _TRIALS - 1], None] * d_plus[None, :] - view.doffs_px)
    ok = (ends[2] >= 0) & (ends[0] <= w - 2)
    if view.valid_right is not None:
        # (Both columns the interpolation reads; the valid parts keep SOURCE_MARGIN_PX from
        # the black border, more than the gradients' 2 px reach.)
        vr = np.asarray(view.valid_right)
        x0 = np.clip(np.floor(ends).astype(np.intp), 0, w - 2)
        ok &= np.all(vr[r_idx[None, :], x0] & vr[r_idx[None, :], x0 + 1], axis=0)
    if int(ok.sum()) < _MIN_FACE_PIXELS:
        return None
    gl, gr = view.gradients
    c_ok, d_ok = c_f[ok], d_plus[ok]
    a = gl[r_idx[ok], c_ok.astype(np.intp)]
    x = (c_ok[None, :] - (scales[:, None] * d_ok[None, :] - view.doffs_px)).astype(np.float32)  # right column
    x0 = np.floor(x)
    frac = x - x0
    row = r_idx[ok][None, :]
    col = x0.astype(np.intp)
    b = gr[row, col] * (1.0 - frac) + gr[row, col + 1] * frac
    cost = _zncc_cost(a, b)
    scale, best, sharp, inside = _best_scale(cost, scales, span)
    # The face's thirds across the image, each on its own: a minimum that the whole face
    # shows because of one part of it (a baluster's edge, a repeated grain) is not where
    # the others put theirs.
    order = np.argsort(c_ok, kind="stable")
    thirds = [
        _best_scale(_zncc_cost(a[part], b[:, part]), scales, span)[0] for part in np.array_split(order, 3)
    ]
    spread = float(max(thirds) - min(thirds))
    kept = (
        inside
        and sharp >= config.photometric_min_sharpness
        and best <= config.photometric_max_cost
        and spread <= config.photometric_max_spread * span
    )
    sigma = max(spread / (_RANGE_OF_THREE * math.sqrt(3.0)), 0.5 * float(scales[1] - scales[0]))
    return RiserFit(scale, best, sharp, int(ok.sum()), kept, spread, sigma)


def _zncc_cost(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """1 - the zero-mean normalised cross-correlation of ``a`` (N,) with each row of
    ``b`` (K, N) (float64 out; float32 in is enough for correlations read to 1e-3)."""
    a = a - a.mean()
    b = b - b.mean(axis=1, keepdims=True)
    norm = math.sqrt(float(a @ a)) * np.sqrt(np.einsum("ij,ij->i", b, b, dtype=np.float64))
    out: np.ndarray = 1.0 - (b @ a).astype(np.float64) / np.maximum(norm, 1e-9)
    return out


def _best_scale(cost: np.ndarray, scales: np.ndarray, span: float) -> tuple[float, float, float, bool]:
    """The scale of least ``cost`` (a parabola through it and its neighbours), that cost,
    how much the cost rises ``0.3 * span`` away on either side (the mean of the two), and
    whether the least is inside the span."""
    j = int(np.argmin(cost))
    step = float(scales[1] - scales[0])
    scale = float(scales[j])
    inside = 0 < j < len(scales) - 1
    if inside:
        curve = cost[j - 1] - 2.0 * cost[j] + cost[j + 1]
        if curve > 0:
            scale += float(0.5 * (cost[j - 1] - cost[j + 1]) / curve) * step
    k = max(1, int(round(0.3 * span / step)))
    if j - k < 0 or j + k >= len(cost):
        return scale, float(cost[j]), 0.0, inside  # one side out of the span: not sure
    return scale, float(cost[j]), float(0.5 * (cost[j - k] + cost[j + k]) - cost[j]), inside


def refine_risers(
    steps: list[Step],
    u: np.ndarray,
    v: np.ndarray,
    laterals: list[tuple[float, float]],
    view: StereoView,
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """Move each step's riser to where both images of its face put it.

    Parameters
    ----------
    steps : list of Step
        The staircase's steps, nearest first, terrain frame.
    u, v : (3,) float64
        The stair axis (up the stairs) and its lateral direction.
    laterals : list of (float, float)
        Each step's riser face across the stair, metres along ``v``.
    view : StereoView
    config : TerrainConfig

    Returns
    -------
    steps : list of Step
        Those whose search is kept (:func:`fit_riser`) with their riser plane moved (the
        normal kept), their position along the axis and their distance with it, and the
        runs measured between them and their neighbours (a run that is no difference of
        two positions, a box's depth, stays); ``riser_move`` holds the plane and position
        their samples gave and the moved position's sigma. A move that would bring two
        risers nearer than ``min_run_m`` (or past each other) is not made. Steps placed a
        run beyond the step before by the image's lines (``position_inferred``) are not
        searched.
    moved : int
    """
    t = np.asarray(view.T_frame_camera, dtype=np.float64)[:3, 3]
    moves: list[RiserMove | None] = [None] * len(steps)
    planes = [s.riser for s in steps]
    pos = [s.axis_position_m for s in steps]
    for i, s in enumerate(steps):
        if s.position_inferred:
            continue
        fit = fit_riser(view, s.riser, (s.top_z_m - s.rise_m, s.top_z_m), laterals[i], v, config)
        if fit is None or not fit.kept:  # (None also for a plane along the stair axis)
            continue
        n = s.riser.normal
        o_c = float(s.riser.offset + n @ t)  # the offset in the camera frame
        offset = o_c / fit.scale - float(n @ t)  # depth scales as 1 / (d + doffs)
        planes[i] = Plane(n, offset)
        pos[i] = s.axis_position_m + (s.riser.offset - offset) / float(n @ u)
        moves[i] = RiserMove(s.riser, s.axis_position_m, o_c * fit.scale_sigma / fit.scale**2)
    # No move may bring two risers nearer than a run can be (a search that found the
    # neighbour's face, or the tread's edge): undone, until none does.
    undone = True
    while undone:
        undone = False
        for i in range(len(steps) - 1):
            gap, was = pos[i + 1] - pos[i], steps[i + 1].axis_position_m - steps[i].axis_position_m
            if gap < min(config.min_run_m, was):
                for k in (i, i + 1):
                    if moves[k] is not None:
                        moves[k], planes[k], pos[k] = None, steps[k].riser, steps[k].axis_position_m
                        undone = True
    moved = sum(m is not None for m in moves)
    if not moved:
        return steps, 0
    out: list[Step] = []
    for i, s in enumerate(steps):
        run = s.run_m
        if run is not None and i + 1 < len(steps):
            if abs(run - (steps[i + 1].axis_position_m - s.axis_position_m)) < 1e-6:
                run = pos[i + 1] - pos[i]
        out.append(
            dataclasses.replace(
                s,
                riser=planes[i],
                riser_move=moves[i] or s.riser_move,
                axis_position_m=float(pos[i]),
                distance_m=riser_distance(planes[i], pos[i], u),
                run_m=None if run is None else float(run),
            )
        )
    return out, moved


#: Pixels either side of an edge compared between the two images (:func:`edge_disparities`).
_EDGE_HALF_WIDTH = 4

#: Most rows of an edge compared (a longer one is thinned).
_EDGE_MAX_ROWS = 64

#: Fewest rows an edge is matched on.
_EDGE_MIN_ROWS = 6


def edge_disparities(
    view: StereoView, edges: np.ndarray, disparity_range: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """The disparity of each near-vertical edge of the left image in the right one, and
    how well the two images agree there.

    A vertical edge is what a horizontal baseline matches best: across it the grey levels
    step, along the rows they do not repeat. Each edge's strip (``_EDGE_HALF_WIDTH``
    pixels either side of it, row by row along the segment, its ends left out) of the
    left image's horizontal gradient is compared with the right image's at each whole
    disparity in ``disparity_range`` by zero-mean normalised correlation over the whole
    strip, and the best is refined by a parabola through its neighbours. A painted
    riser's end against a wall, or a stair's side against the room behind it, is such an
    edge where its face has nothing to match (issue 11).

    Parameters
    ----------
    view : StereoView
    edges : (N, 4) float64
        ``x1, y1, x2, y2`` in pixels of the rectified left image, each within a few
        degrees of vertical.
    disparity_range : (lo, hi), pixels

    Returns
    -------
    disparity : (N,) float64, NaN where the edge is too short or leaves either image
    score : (N,) float64, the correlation at it in [-1, 1] (NaN where not matched)
    """
    n = len(edges)
    disparity = np.full(n, np.nan)
    score = np.full(n, np.nan)
    grad_left, grad_right = view.gradients
    w = grad_left.shape[1]
    half = _EDGE_HALF_WIDTH
    for i, (x1, y1, x2, y2) in enumerate(np.asarray(edges, dtype=np.float64)):
        if y1 > y2:
            x1, y1, x2, y2 = x2, y2, x1, y1
        rows = np.arange(math.ceil(y1) + 1, math.floor(y2))
        if len(rows) < _EDGE_MIN_ROWS:
            continue
        if len(rows) > _EDGE_MAX_ROWS:
            rows = rows[np.linspace(0, len(rows) - 1, _EDGE_MAX_ROWS).astype(int)]
        x = x1 + (rows - y1) * (x2 - x1) / (y2 - y1)
        d_lo = max(0, int(math.floor(disparity_range[0])))
        d_hi = min(int(math.ceil(disparity_range[1])), int(np.floor(x.min())) - half - 1)
        if d_hi - d_lo < 2 or x.max() + half >= w - 1:
            continue
        offsets = np.arange(-half, half + 1, dtype=np.float64)
        ys = np.repeat(rows[:, None].astype(np.float32), len(offsets), axis=1)
        left = cv2.remap(grad_left, (x[:, None] + offsets).astype(np.float32), ys, cv2.INTER_LINEAR)
        left = left.astype(np.float64).ravel()
        left -= left.mean()
        norm_left = float(np.linalg.norm(left))
        if norm_left < 1e-6:
            continue
        # the right image's strip from x - d_hi - half to x - d_lo + half, once
        wide = np.arange(-d_hi - half, -d_lo + half + 1, dtype=np.float64)
        ys = np.repeat(rows[:, None].astype(np.float32), len(wide), axis=1)
        strip = cv2.remap(grad_right, (x[:, None] + wide).astype(np.float32), ys, cv2.INTER_LINEAR)
        windows = np.lib.stride_tricks.sliding_window_view(strip.astype(np.float64), len(offsets), axis=1)
        # windows[:, j] starts at x - d_hi - half + j: disparity d_hi - j
        flat = windows.transpose(1, 0, 2).reshape(windows.shape[1], -1)
        flat = flat - flat.mean(axis=1, keepdims=True)
        norms = np.linalg.norm(flat, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            zncc = (flat @ left) / (norms * norm_left)
        zncc[~np.isfinite(zncc)] = -1.0
        j = int(np.argmax(zncc))
        peak = float(j)
        if 0 < j < len(zncc) - 1:  # the parabola through the cost 1 - zncc and its neighbours
            peak = parabola_peak(j, -zncc[j - 1], -zncc[j], -zncc[j + 1])
        disparity[i] = d_hi - peak
        score[i] = zncc[j]
    return disparity, score
