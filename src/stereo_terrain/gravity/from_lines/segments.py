"""The image's line segments: LSD on the rectified left image, clipped to the valid
region's interior (:func:`line_segments`), and their geometry in the camera."""

from __future__ import annotations

import cv2
import numpy as np

from ...rectify import Rectification, valid_interior
from .config import VerticalLinesConfig


def _segments(
    image: np.ndarray, valid: np.ndarray | None, min_length_px: float, scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """LSD segments ``(N, 4)`` (x1, y1, x2, y2, pixels of ``image``) found on ``image``
    resized by ``scale``, each clipped to its longest part on valid pixels away from the
    border of the valid region (whose outline is a straight edge of the rectified image,
    not of the scene) and at least ``min_length_px`` long after that; and which of them
    were whole (both ends and the middle there, not clipped).

    A segment along the valid region's outline lies wholly in the border band and is
    dropped. One that runs out of the view is a line of the scene up to the border: a
    staircase wider than the view has all its nosings so (issue 11, :func:`scene_lines`)."""
    small = image if scale == 1 else cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    found = cv2.createLineSegmentDetector().detect(small)[0]
    if found is None:
        return np.empty((0, 4)), np.zeros(0, dtype=bool)
    # Pixel centres: x_small = (x + 0.5) * scale - 0.5.
    s = (found.reshape(-1, 4).astype(np.float64) + 0.5) / scale - 0.5
    s = s[np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) >= min_length_px]
    h, w = image.shape
    inside = valid_interior(valid, (h, w))

    def on(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        xi = np.clip(np.round(x).astype(int), 0, w - 1)
        yi = np.clip(np.round(y).astype(int), 0, h - 1)
        ok: np.ndarray = inside[yi, xi]
        return ok

    whole = on(s[:, 0], s[:, 1]) & on(s[:, 2], s[:, 3]) & on((s[:, 0] + s[:, 2]) / 2, (s[:, 1] + s[:, 3]) / 2)
    keep = whole.copy()
    cut = np.flatnonzero(~whole)
    if len(cut):
        # Each cut segment's longest run of inside pixels, one pixel apart (all at once:
        # sample k of segment i at t = k / (n_i - 1), none past its own end).
        a, b = s[cut, :2], s[cut, 2:]
        length = np.hypot(*(b - a).T)
        n = np.ceil(length).astype(int) + 1
        k = np.arange(int(n.max()))
        t = k[None, :] / (n[:, None] - 1)
        along = t < 1.0 + 1e-9
        t = np.minimum(t, 1.0)
        flags = on(a[:, :1] + t * (b[:, :1] - a[:, :1]), a[:, 1:] + t * (b[:, 1:] - a[:, 1:])) & along
        last_out = np.maximum.accumulate(np.where(flags, -1, k[None, :]), axis=1)
        run = np.where(flags, k[None, :] - last_out, 0)  # length of the run ending here
        end = np.argmax(run, axis=1)
        longest = run[np.arange(len(cut)), end]
        t0 = (end - longest + 1) / (n - 1)
        t1 = end / (n - 1)
        ok = (longest > 0) & ((t1 - t0) * length >= min_length_px)
        lo, hi = a + t0[:, None] * (b - a), a + t1[:, None] * (b - a)
        s[cut[ok]] = np.column_stack([lo, hi])[ok]
        keep[cut[ok]] = True
    return s[keep], whole[keep]


def _tilt_deg(segments: np.ndarray) -> np.ndarray:
    """Each segment's angle to the image's vertical, degrees (0-90)."""
    d = segments[:, 2:] - segments[:, :2]
    return np.degrees(np.arctan2(np.abs(d[:, 0]), np.abs(d[:, 1])))


def normalised_ends(segments: np.ndarray, rectification: Rectification) -> tuple[np.ndarray, np.ndarray]:
    """The segments' two ends as rays ``K^-1 (x, y, 1)`` of the rectified camera, ``(N, 3)``
    each (normalised image coordinates)."""
    f, cx, cy = rectification.focal_px, rectification.cx, rectification.cy
    ones = np.ones(len(segments))
    p1 = np.column_stack([(segments[:, 0] - cx) / f, (segments[:, 1] - cy) / f, ones])
    p2 = np.column_stack([(segments[:, 2] - cx) / f, (segments[:, 3] - cy) / f, ones])
    return p1, p2


def unit_rows(a: np.ndarray) -> np.ndarray:
    """Rows of ``a`` normalised (NaN where a row is zero)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return a / np.linalg.norm(a, axis=1, keepdims=True)


def line_segments(
    image: np.ndarray, rectification: Rectification, config: VerticalLinesConfig, scale: float
) -> np.ndarray:
    """LSD segments ``(N, 4)`` (x1, y1, x2, y2 in pixels of ``image``, the rectified left
    image) found at ``scale``, at least ``config.min_length_px`` long (in pixels of a
    640-pixel-wide raw image), away from the border of the valid region (whole ones: not
    those that reach it)."""
    length = _in_raw_px(rectification, config.min_length_px)
    s, whole = _segments(image, rectification.valid_left, length, scale)
    return s[whole]


def _in_raw_px(rectification: Rectification, length_px: float) -> float:
    """A length given in pixels of a 640-pixel-wide raw image, in pixels of this one."""
    return length_px * rectification.raw_size[0] / 640.0
