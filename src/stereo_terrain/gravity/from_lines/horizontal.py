"""The scene's dominant horizontal direction from its non-vertical segments
(:func:`horizontal_direction`), without those the disparity shows sloped
(:func:`sloped_segments`)."""

from __future__ import annotations

import math

import numpy as np

from ...rectify import Rectification
from .config import VerticalLinesConfig
from .segments import _tilt_deg, normalised_ends

#: Points along a segment at which :func:`sloped_segments` reads the disparity.
_SLOPE_SAMPLES = 8

#: A segment's two halves must lie this far apart in 3D (metres) for its slope to count.
_SLOPE_MIN_SPAN_M = 0.05


def _nanmedian_rows(a: np.ndarray) -> np.ndarray:
    """``np.nanmedian(a, axis=-1)``, NaN where a row is all NaN, without the warning that
    NumPy gives there (the warning filters are process-wide; the lines' thread runs beside
    the matcher)."""
    empty = np.isnan(a).all(axis=-1)
    out: np.ndarray = np.nanmedian(np.where(empty[..., None], 0.0, a), axis=-1)
    out[empty] = np.nan
    return out


def sloped_segments(
    segments: np.ndarray,
    rectification: Rectification,
    disparity: np.ndarray,
    up: np.ndarray,
    max_slope_deg: float,
) -> np.ndarray:
    """Which of ``segments`` are images of 3D lines rising more steeply than
    ``max_slope_deg``, by the disparity along them.

    Parameters
    ----------
    segments : (N, 4) float, (x1, y1, x2, y2) in pixels of the rectified left image
    rectification : Rectification of the pair (focal length, principal point, baseline,
        ``doffs_px``)
    disparity : (H, W) float, the rectified pair's disparity in pixels; NaN or <= 0 where
        unmatched
    up : (3,) float, up in the rectified left camera
    max_slope_deg : float

    Returns
    -------
    (N,) bool. At :data:`_SLOPE_SAMPLES` points between 10% and 90% of each segment, the
    median of the positive disparities in a 3x3 window is back-projected; the line's
    direction joins the median point of the samples on the segment's first half to that
    of those on its second half (robust to a stray disparity or two). A segment with fewer
    than three points on either half (unmatched, or outside the image), or whose halves
    lie less than :data:`_SLOPE_MIN_SPAN_M` apart, is not called sloped.
    """
    n = len(segments)
    out = np.zeros(n, dtype=bool)
    if n == 0:
        return out
    h, w = disparity.shape
    t = np.linspace(0.1, 0.9, _SLOPE_SAMPLES)
    x = segments[:, None, 0] + t[None, :] * (segments[:, None, 2] - segments[:, None, 0])
    y = segments[:, None, 1] + t[None, :] * (segments[:, None, 3] - segments[:, None, 1])
    xi, yi = np.round(x).astype(int), np.round(y).astype(int)
    inside = (xi >= 1) & (xi <= w - 2) & (yi >= 1) & (yi <= h - 2)
    xi, yi = np.clip(xi, 1, w - 2), np.clip(yi, 1, h - 2)
    window = np.stack([disparity[yi + dy, xi + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=-1)
    window = np.where(window > 0, window, np.nan).astype(np.float64)  # NaN: unmatched
    d = _nanmedian_rows(window)
    d[~inside] = np.nan
    Z = rectification.depth_from_disparity(d)  # NaN where d + doffs <= 0
    f = rectification.focal_px
    half = _SLOPE_SAMPLES // 2
    seen = np.isfinite(Z)
    enough = (seen[:, :half].sum(axis=1) >= 3) & (seen[:, half:].sum(axis=1) >= 3)
    if not enough.any():
        return out
    P = np.stack([(x - rectification.cx) * Z / f, (y - rectification.cy) * Z / f, Z], axis=-1)[enough]
    first = np.stack([_nanmedian_rows(P[:, :half, k]) for k in range(3)], axis=-1)
    second = np.stack([_nanmedian_rows(P[:, half:, k]) for k in range(3)], axis=-1)
    direction = second - first
    span = np.linalg.norm(direction, axis=1)
    unit_up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    rising = np.abs(direction @ unit_up) > math.sin(math.radians(max_slope_deg)) * span
    out[np.flatnonzero(enough)] = rising & (span >= _SLOPE_MIN_SPAN_M)
    return out


def level_turn_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two horizontal directions ``a`` and ``b`` modulo 90 deg (a built
    scene's two horizontal families are one for :func:`horizontal_direction`), degrees in
    [0, 45]."""
    cos = abs(float(a @ b)) / float(np.linalg.norm(a) * np.linalg.norm(b))
    turn = math.degrees(math.acos(min(cos, 1.0)))
    return min(turn, 90.0 - turn)


def horizontal_direction(
    segments: np.ndarray,
    rectification: Rectification,
    up: np.ndarray,
    config: VerticalLinesConfig,
    disparity: np.ndarray | None = None,
) -> np.ndarray | None:
    """The scene's dominant horizontal direction in the rectified left camera, modulo 90
    deg, from its non-vertical line segments, given ``up`` (same frame); None when fewer
    than ``config.min_inliers`` segments agree on one.

    A segment and the camera centre span a plane with normal ``m``; if the segment is the
    image of a horizontal 3D line, the line's direction is ``m x up``. Nosings, tread edges,
    skirting boards and door tops are such lines, along the staircase or across it: in a
    built (Manhattan) scene their directions fall in two families 90 deg apart, so the
    length-weighted histogram of the directions' angles in the horizontal plane, modulo 90
    deg, has one peak; the direction is the weighted circular mean of the segments within
    ``horizontal_window_deg`` of it. Grain falls elsewhere and does not move the peak;
    sloped lines (handrails, the staircase's slope line) mostly fall elsewhere too, but a
    few long ones can outweigh the step edges: given the ``disparity`` map of the
    rectified pair, the segments it shows rising more steeply than
    ``config.horizontal_max_slope_deg`` are left out (:func:`sloped_segments`).
    """
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    if len(segments) == 0:
        return None
    s = segments[_tilt_deg(segments) > config.max_tilt_deg]
    if disparity is not None and config.horizontal_max_slope_deg > 0 and len(s):
        s = s[~sloped_segments(s, rectification, disparity, up, config.horizontal_max_slope_deg)]
    d = s[:, 2:] - s[:, :2]
    if len(s) < config.min_inliers:
        return None
    p1, p2 = normalised_ends(s, rectification)
    m = np.cross(p1, p2)
    t = np.cross(m, up)
    norm = np.linalg.norm(t, axis=1)
    # A segment whose plane nearly contains up (a near-vertical line) fixes no horizontal
    # direction.
    keep = norm > 0.2 * np.linalg.norm(m, axis=1)
    t, length = t[keep] / norm[keep, None], np.hypot(d[keep, 0], d[keep, 1])
    if len(t) < config.min_inliers:
        return None
    e1 = np.cross(up, [0.0, 0.0, 1.0])
    if np.linalg.norm(e1) < 1e-6:  # a camera looking straight up or down
        e1 = np.cross(up, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    # Angles modulo 90 deg, as points on a circle (x4): the peak and the mean wrap.
    quad = 4.0 * np.arctan2(t @ e2, t @ e1)
    bins = np.bincount(np.round(np.degrees(quad) / 4.0).astype(int) % 90, weights=length, minlength=90)
    k = np.exp(-0.5 * (np.arange(-6, 7) / 2.0) ** 2)
    smooth = np.array([bins[(i + np.arange(-6, 7)) % 90] @ k for i in range(90)])
    peak = math.radians(4.0 * float(np.argmax(smooth)))
    off = np.angle(np.exp(1j * (quad - peak)))  # in (-pi, pi]: 4x the angle to the peak
    near = np.abs(off) <= math.radians(4.0 * config.horizontal_window_deg)
    if near.sum() < config.min_inliers:
        return None
    mean = peak + float(np.angle(np.sum(length[near] * np.exp(1j * off[near]))))
    a = mean / 4.0
    return math.cos(a) * e1 + math.sin(a) * e2
