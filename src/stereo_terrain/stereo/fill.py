"""Planar fill of texture-poor regions: disparity from the edges of a painted face.

Semi-global matching has nothing to match inside a uniformly painted riser: it leaves
holes or smooths the face into a ramp, and the step disappears from the cloud. The face's
*outline* is still there: risers and treads are shaded differently, so their borders are
strong image edges, and the face's ends (the sides of the staircase) carry reliable
disparities. A plane face is a plane in (u, v, d) space, so:

1. smooth the rectified left image and mark *flat* pixels (gradient below
   ``flat_gradient``); connected flat regions are candidate faces;
2. for each large region, take the valid disparities inside it and in a thin ring around
   it, and fit ``d = a u + b v + c`` with MSAC;
3. when the fit is supported across the whole region (inliers spread over its width and
   height), every disparity inside the region becomes the plane's.

Textured regions are not flat, so they are never touched. Regions whose disparities do not
agree on one plane (two faces of the same shade, a textureless background) are left
alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..planes.msac import plane_msac


@dataclass(frozen=True)
class PlanarFillConfig:
    """Parameters of the texture-poor fill.

    Attributes
    ----------
    enabled : bool
    smooth_sigma_px : float
        Gaussian blur before the gradient (suppresses sensor noise).
    flat_gradient : float
        Grey levels per pixel below which a smoothed pixel is flat.
    edge_gradient : float
        Horizontal gradient (grey levels per pixel) above which a pixel is on a vertical
        edge; only such pixels support a region's plane.
    min_region_fraction : float
        Smallest region worth filling, as a fraction of the image.
    ring_px : int
        Width of the ring around a region whose disparities also support the fit.
    inlier_threshold_px : float
        MSAC threshold on the plane in (u, v, d) space (orthogonal distance, pixels; the
        disparity tolerance is this divided by the normal's d component).
    min_inlier_ratio : float
        The plane must explain this fraction of the support points (the valid disparities
        on vertical edges in and around the region).
    min_span_ratio : float
        Inliers must span this fraction of the region's width and height.
    hypotheses : int
        MSAC hypotheses per region.
    max_support_points : int
        Support disparities are subsampled to at most this many.
    """

    enabled: bool = True
    smooth_sigma_px: float = 2.0
    flat_gradient: float = 0.5
    edge_gradient: float = 1.5
    min_region_fraction: float = 0.002
    ring_px: int = 4
    inlier_threshold_px: float = 0.75
    min_inlier_ratio: float = 0.5
    min_span_ratio: float = 0.7
    hypotheses: int = 64
    max_support_points: int = 1000
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "ring_px", "max_support_points")
        check_min(self, 3, "hypotheses")
        check_min(self, 0, "min_region_fraction", "edge_gradient")
        if self.smooth_sigma_px <= 0 or self.flat_gradient <= 0 or self.inlier_threshold_px <= 0:
            raise ConfigError("smooth_sigma_px, flat_gradient and inlier_threshold_px must be > 0")
        if not 0 < self.min_inlier_ratio <= 1 or not 0 < self.min_span_ratio <= 1:
            raise ConfigError("min_inlier_ratio and min_span_ratio must be in (0, 1]")


def flat_regions(
    image: np.ndarray, config: PlanarFillConfig, valid: np.ndarray | None = None
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """Label connected texture-poor regions of a grey image (only ``valid`` pixels, when
    given, can be flat).

    Returns
    -------
    count, labels (H, W) int32 (0 = not flat), stats (count, 5) from OpenCV, and
    vertical_edges (H, W) bool: pixels whose horizontal gradient is strong, where
    matching along rows is reliable.
    """
    g = cv2.GaussianBlur(image.astype(np.float32), (0, 0), config.smooth_sigma_px)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    mag = cv2.magnitude(gx, gy) / 8.0  # Sobel's 3x3 kernel gain
    flat = mag < config.flat_gradient
    if valid is not None:
        flat &= valid
    flat = cv2.erode(flat.astype(np.uint8), np.ones((3, 3), np.uint8))
    count, labels, stats, _ = cv2.connectedComponentsWithStats(flat, connectivity=4)
    vertical_edges = np.abs(gx) / 8.0 > config.edge_gradient
    return count, labels, stats, vertical_edges


def fill_planar_regions(
    disparity: np.ndarray,
    left: np.ndarray,
    config: PlanarFillConfig | None = None,
    *,
    max_disparity_px: float | None = None,
    valid: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Fill texture-poor planar regions of ``disparity`` from their supported plane.

    Parameters
    ----------
    disparity : (H, W) float32, NaN invalid
    left : (H, W) uint8, the rectified left image
    config : PlanarFillConfig
    max_disparity_px : float, optional
        Filled values must stay in ``[0, max_disparity_px)``.
    valid : (H, W) bool, optional
        Pixels of ``left`` that have a source (``Rectification.valid_left``); the others
        (the black border of a rectification that keeps the field of view, flat and
        edge-bounded like a painted face) are neither filled nor part of any region.

    Returns
    -------
    filled_disparity : (H, W) float32
    filled_mask : (H, W) bool, pixels whose value came from a plane
    """
    config = config or PlanarFillConfig()
    out = disparity.copy()
    filled = np.zeros(disparity.shape, dtype=bool)
    if not config.enabled:
        return out, filled
    h, w = disparity.shape
    count, labels, stats, edges = flat_regions(left, config, valid)
    min_area = config.min_region_fraction * h * w
    rng = np.random.default_rng(config.seed)
    valid = np.isfinite(disparity)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * config.ring_px + 1,) * 2)
    for k in range(1, count):
        x, y, bw, bh, area = stats[k]
        if area < min_area or bw < 8 or bh < 4:
            continue
        # Work in the region's bounding box grown by the ring.
        x0, y0 = max(0, x - config.ring_px), max(0, y - config.ring_px)
        x1, y1 = min(w, x + bw + config.ring_px), min(h, y + bh + config.ring_px)
        region = labels[y0:y1, x0:x1] == k
        # Only disparities on vertical edges are trusted: inside the face SGM has nothing to
        # match (its values there may be a ramp), and along horizontal edges the match is
        # ambiguous (the aperture problem).
        support = (
            cv2.dilate(region.astype(np.uint8), kernel).astype(bool)
            & valid[y0:y1, x0:x1]
            & edges[y0:y1, x0:x1]
        )
        vs, us = np.nonzero(support)
        if len(us) < 20:
            continue
        ds = disparity[y0:y1, x0:x1][vs, us]
        uvd = np.column_stack([us + x0, vs + y0, ds]).astype(np.float64)
        if len(uvd) > config.max_support_points:
            uvd = uvd[rng.choice(len(uvd), config.max_support_points, replace=False)]
        trip = rng.integers(0, len(uvd), size=(config.hypotheses, 3))
        res = plane_msac(uvd, config.inlier_threshold_px, trip, hypothesis_ok=lambda n: np.abs(n[:, 2]) > 0.3)
        if res.model is None:
            continue
        inl = res.inliers
        if inl.mean() < config.min_inlier_ratio:
            continue
        iu, iv = uvd[inl, 0], uvd[inl, 1]
        if np.ptp(iu) < config.min_span_ratio * bw or np.ptp(iv) < config.min_span_ratio * bh:
            continue
        n, c = res.model.normal, res.model.offset
        # Least-squares refit on the inliers: d = a u + b v + e.
        A = np.column_stack([iu, iv, np.ones(len(iu))])
        coef, *_ = np.linalg.lstsq(A, uvd[inl, 2], rcond=None)
        if not np.all(np.isfinite(coef)):
            coef = np.array([-n[0] / n[2], -n[1] / n[2], -c / n[2]])
        rv, ru = np.nonzero(region)
        plane_d = (coef[0] * (ru + x0) + coef[1] * (rv + y0) + coef[2]).astype(np.float32)
        # The face has no texture of its own: its matches carry no information, so the
        # whole face takes the plane supported by its outline.
        replace = plane_d > 0
        if max_disparity_px is not None:
            replace &= plane_d < max_disparity_px
        out[rv[replace] + y0, ru[replace] + x0] = plane_d[replace]
        filled[rv[replace] + y0, ru[replace] + x0] = True
    return out, filled
