"""Nosings and riser feet in the image's grey levels, where no line segment shows them: a
step edge along the predicted line (the package docstring, ``nosing_edge_contrast``)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import cv2
import numpy as np

from ..model import TerrainConfig
from .view import FOOT_VISIBLE_M, HORIZON_DEG, ImageLines, StairView, visible_span


def foot_in_grey_levels(
    view: StairView,
    smoothed: Callable[[], np.ndarray],
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    best: float,
    config: TerrainConfig,
) -> bool:
    """Whether the nosing at pitch position ``best`` shows as an edge in the smoothed image
    (``smoothed()``) and the foot of the riser below it too (:func:`edge_foot_shows`)."""
    width = visible_span(view, a_k + best * run, top_k + best * rise)
    if width is None:
        return False
    nosing = line_pixels(view, a_k + best * run, top_k + best * rise, width)
    if nosing is None:
        return False
    image = smoothed()
    edge = edge_cover(image, nosing, config.nosing_edge_contrast)
    if abs(edge) < config.nosing_min_cover:
        return False
    return edge_foot_shows(view, image, a_k, top_k, rise, run, best, edge, width, config)


#: Grey levels are compared this far (pixels) either side of a predicted nosing's image
#: (:func:`edge_cover`): past a dark strip or a plank gap's half width, so that a thin
#: line (the same face on both sides) shows no step edge.
_EDGE_OFFSET_PX = 2.5


#: The image is smoothed with this Gaussian sigma (pixels) before (JPEG blocks, noise).
_EDGE_SMOOTH_PX = 1.0


#: The grey levels either side of a nosing must differ by more than they vary along it:
#: by this many times the larger side's spread (its median absolute deviation, scaled to
#: a standard deviation). A face's texture, or its blotches, vary along the line as much
#: as across it.
_EDGE_ALONG_SCALE = 1.5


#: Positions along the pitch line tried for the next nosing, in steps.
_EDGE_LAM_STEP = 0.02


#: A predicted line's image must be at least this long (pixels) to be judged.
_EDGE_MIN_PX = 12


#: A riser's foot must lie at least this far (pixels) from the nosings above and below it
#: in the image to be told from them as an edge (twice the comparison's reach, with the
#: smoothing).
_FOOT_APART_PX = 8.0


def smoothed_image(lines: ImageLines) -> np.ndarray:
    """The rectified left image (``lines.image``, which must be there), float32 and
    smoothed, for :func:`edge_cover`."""
    img = np.asarray(lines.image, dtype=np.float32)
    if img.ndim == 3:
        img = img.mean(axis=2, dtype=np.float32)
    return cv2.GaussianBlur(img, (0, 0), _EDGE_SMOOTH_PX)


def _lines_pixels(
    view: StairView, s: np.ndarray, z: np.ndarray, span: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Pixels about one apart along the images of the lines at ``s`` along ``u`` and
    heights ``z`` (each ``(K,)``) over the lateral ``span``: ``(K, n, 2)``, one count
    ``n`` for all (the longest image's length), and which of them count (in front of the
    camera, at least ``_EDGE_MIN_PX`` long). A 3D line's image is straight: its pixels
    lie evenly between its ends' images."""
    lines, u, v = view.lines, view.u, view.v
    base = s[:, None] * u + z[:, None] * np.array([0.0, 0.0, 1.0])
    ends = np.stack([base + t * v for t in span], axis=1)  # (K, 2, 3)
    uv, depth = lines.project(ends.reshape(-1, 3))
    uv, depth = uv.reshape(-1, 2, 2), depth.reshape(-1, 2)
    length = np.hypot(*(uv[:, 1] - uv[:, 0]).T)
    ok = (depth > 0.2).all(axis=1) & np.isfinite(length) & (length >= _EDGE_MIN_PX)
    n = int(np.max(length[ok])) + 1 if ok.any() else 2
    f = np.linspace(0.0, 1.0, n)[None, :, None]
    px = uv[:, :1] + f * (uv[:, 1:] - uv[:, :1])
    return px, ok


def line_pixels(view: StairView, s: float, z: float, span: tuple[float, float]) -> np.ndarray | None:
    """:func:`_lines_pixels` of one line, ``(n, 2)``; None where it does not count."""
    px, ok = _lines_pixels(view, np.array([s]), np.array([z]), span)
    return px[0] if ok[0] else None


def _edge_covers(smoothed: np.ndarray, px: np.ndarray, contrast: float) -> np.ndarray:
    """How much of each straight image line through the pixels ``px`` (``(K, n, 2)``) is
    a step edge (a tread and a riser lit differently), signed: the share of its pixels
    where the grey levels ``_EDGE_OFFSET_PX`` to the left of the line (from its first
    pixel to its last) exceed those to the right by the threshold or more, less the share
    where they fall short of them so. The threshold is ``contrast``, or more where the
    grey levels vary along the line (``_EDGE_ALONG_SCALE``). Texture differs either way
    about as often (its net share is near 0); a thin line (a plank gap, a dark strip's
    middle) has the same face on both sides."""
    d = px[:, -1] - px[:, 0]
    d = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    normal = np.stack([d[:, 1], -d[:, 0]], axis=1)[:, None, :] * _EDGE_OFFSET_PX
    sides = []
    for off in (normal, -normal):
        p = (px + off).astype(np.float32)
        sides.append(
            cv2.remap(
                smoothed,
                np.ascontiguousarray(p[..., 0]),
                np.ascontiguousarray(p[..., 1]),
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=float("nan"),
            )
        )
    diff = sides[0] - sides[1]
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: lines out of the image
        # Each side's grey levels vary along the line too: on a textured face they do by
        # as much as across it, and a step edge must stand out of that.
        spread = [
            1.4826 * np.nanmedian(np.abs(side - np.nanmedian(side, axis=1, keepdims=True)), axis=1)
            for side in sides
        ]
        threshold = np.maximum(contrast, _EDGE_ALONG_SCALE * np.fmax(spread[0], spread[1]))[:, None]
        up = np.count_nonzero(diff >= threshold, axis=1)
        down = np.count_nonzero(diff <= -threshold, axis=1)
    out: np.ndarray = (up - down) / diff.shape[1]
    return out


def edge_cover(smoothed: np.ndarray, px: np.ndarray, contrast: float) -> float:
    """:func:`_edge_covers` of one line's pixels ``(n, 2)``."""
    return float(_edge_covers(smoothed, px[None], contrast)[0])


def edge_nosing(
    view: StairView,
    smoothed: np.ndarray,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    config: TerrainConfig,
) -> float | None:
    """The pitch-line position of the next nosing after the step at ``(a_k, top_k)``
    where the image's grey levels show it as a step edge (:func:`edge_cover`), for when
    its line segments show none; None where they do not either (the package docstring).

    The position within ``nosing_run_tolerance`` where the edge covers most of the
    visible width, ``nosing_min_cover`` of it at least, with the sign of the last
    nosing's edge where that shows (the same faces, tread over riser, lit alike). Where
    the cameras see the last tread from above, the next riser's foot must show too, over
    ``nosing_min_foot_cover`` of the width, with the opposite sign (riser over tread),
    and apart from both nosings in the image (``_FOOT_APART_PX``: a tread seen so flat
    that its two ends are one edge does not tell a step from a landing's far end)."""
    span = visible_span(view, a_k + run, top_k + rise)
    if span is None:
        return None
    contrast = config.nosing_edge_contrast
    tol = config.nosing_run_tolerance
    last = line_pixels(view, a_k, top_k, span)
    last_cover = 0.0 if last is None else edge_cover(smoothed, last, contrast)
    sign = math.copysign(1.0, last_cover) if abs(last_cover) >= config.nosing_min_cover else 0.0
    c = view.lines.centre
    lam = np.arange(1.0 - tol, 1.0 + tol + 1e-9, _EDGE_LAM_STEP)
    s_lam, z_lam = a_k + lam * run, top_k + lam * rise
    ahead = s_lam - float(c @ view.u)
    # Not at the cameras' height: the horizon, a far wall's foot, the sky's edge.
    keep = (ahead > 0) & (np.degrees(np.arctan2(np.abs(z_lam - c[2]), ahead)) >= HORIZON_DEG)
    if not keep.any():
        return None
    px, ok = _lines_pixels(view, s_lam[keep], z_lam[keep], span)
    lam, cover = lam[keep][ok], _edge_covers(smoothed, px[ok], contrast) if ok.any() else np.empty(0)
    if sign != 0.0:
        lam, cover = lam[cover * sign > 0], cover[cover * sign > 0]
    if len(lam) == 0:
        return None
    widest = np.abs(cover) == np.max(np.abs(cover))
    pick = np.flatnonzero(widest)[np.argmin(np.abs(lam[widest] - 1.0))]
    best, best_cover = float(lam[pick]), float(cover[pick])
    if abs(best_cover) < config.nosing_min_cover:
        return None
    if c[2] > top_k + FOOT_VISIBLE_M and not edge_foot_shows(
        view, smoothed, a_k, top_k, rise, run, best, best_cover, span, config
    ):
        return None
    return best


def edge_foot_shows(
    view: StairView,
    smoothed: np.ndarray,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    best: float,
    nosing_cover: float,
    span: tuple[float, float],
    config: TerrainConfig,
) -> bool:
    """Whether the foot of the riser under the nosing found at pitch position ``best``
    (its edge's signed cover ``nosing_cover``) shows in the image's grey levels: the
    opposite edge (riser over tread) over ``nosing_min_foot_cover`` of the width, at least
    ``_FOOT_APART_PX`` from that nosing and from the last one in the image (a tread seen
    so flat that its two ends are one edge does not tell a step from a landing's far
    end)."""
    foot = line_pixels(view, a_k + best * run, top_k, span)
    nosing = line_pixels(view, a_k + best * run, top_k + best * rise, span)
    last = line_pixels(view, a_k, top_k, span)
    if foot is None or nosing is None or last is None:
        return False
    if min(_apart_px(foot, nosing), _apart_px(foot, last)) < _FOOT_APART_PX:
        return False
    opposite = -math.copysign(1.0, nosing_cover) * edge_cover(smoothed, foot, config.nosing_edge_contrast)
    return opposite >= config.nosing_min_foot_cover


def _apart_px(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between the middles of two image lines sampled over one lateral span."""
    return float(np.hypot(*(a[len(a) // 2] - b[len(b) // 2])))
