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
alone, and so are those whose outline shows a surface behind the plane (an outline holds
the face's own disparity or an occluder's, never one behind the face: such a plane is an
occluder's edge fattened by the matcher, see :func:`_occluded_support`).

Opt-in, for webcam photos of wood and paint (the renderer's ``realistic`` profile), all off
by default: ``invalidate`` NaNs the matcher's output where rows carry too little
``|dI/dx|`` or the texture is nearly horizontal (structure tensor), since SGM returns
confident streaks there; ``row_fill_max_gap_px`` then bridges those holes along rows
between anchors that agree (:func:`fill_rows`); ``texture="horizontal"`` builds the regions
from the ill-posed pixels, split at long horizontal edges. On 16 realistic scenes they cut
bad-2 of the valid pixels from 48% to 20% at the same count of correct pixels, but they
do not raise stair detection there (even the true disparity does not) and they cost
Middlebury density (84% -> 62-74%): see ``benchmarks/bench_fill_streaks.py``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..msac import plane_msac
from ._regions import connected_regions, edge_support, fill_region_plane

TEXTURE_MODES = ("total", "horizontal")
#: :func:`_fit_support`'s answer for a plane refused as an occluder's.
_OCCLUDED = np.full(3, np.nan)


#: The widest Gaussian the planar fill smooths the image with (``smooth_sigma_px``).
_MAX_SMOOTH_SIGMA_PX = 100.0


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
    texture : str
        What makes a pixel texture-poor: ``"total"`` (the smoothed gradient magnitude is
        below ``flat_gradient``) or ``"horizontal"`` (the local mean of the smoothed
        horizontal gradient ``|dI/dx|`` over ``texture_window_px`` is below
        ``horizontal_texture``: horizontal grain, plank gaps and near-uniform paint give a
        horizontal baseline nothing to match, whatever their vertical gradient).
    texture_window_px : int
        Side of the box over which ``|dI/dx|`` is averaged (``"horizontal"`` only).
    horizontal_texture : float
        Mean ``|dI/dx|`` (grey levels per pixel) below which matching along rows is
        ill-posed (``"horizontal"`` only).
    split_gradient : float
        ``|dI/dy|`` (grey levels per pixel) above which a pixel lies on a horizontal edge
        (nosing line, step edge) that separates two faces (``"horizontal"`` only).
    split_sigma_x_px : float
        Gaussian blur along rows before ``|dI/dy|`` is taken for the split: a step edge
        is long and straight, wood grain is not (``"horizontal"`` only).
    split_bridge_px : int
        Horizontal edges are dilated along rows by this many pixels, bridging the gaps of
        a faint step edge (``"horizontal"`` only; 1 = no bridging).
    close_px : int
        Ill-posed pixels are closed along rows by this many pixels, so that a narrow
        textured column inside a face (plank end, seam) joins the face's region and
        supports its plane (``"horizontal"`` only; 1 = no closing).
    orientation_ratio : float
        Also ill-posed: windows whose structure tensor has ``Jxx < orientation_ratio *
        Jyy`` (texture nearly horizontal; ``"horizontal"`` only; 0 = off).
    invalidate : bool
        Matcher output in ill-posed pixels (``horizontal_texture``, ``orientation_ratio``)
        that no plane fills becomes NaN: a confident value there is a streak, not a match.
        In the ``"total"`` mode this happens after the fill; in the ``"horizontal"`` mode
        before it (the NaN-ed pixels cannot support a plane).
    row_fill_max_gap_px : int
        With ``invalidate`` (``"total"`` mode): the NaN-ed pixels are filled along their
        row between the nearest finite disparities when those are at most this far apart
        (pixels; 0 = off), see :func:`fill_rows`.
    row_fill_max_step_px : float
        ... and differ by at most this (pixels).
    manhattan : bool
        Regions that no free plane explains (a face with one end in view: its support is
        one vertical segment) are filled by the Manhattan fill when up and a horizontal
        direction of the scene are known (:mod:`stereo_terrain.stereo.manhattan`).
    manhattan_reach_px : float
        A face's pixel takes the plane of the support cluster nearest to it along the
        face's horizontal lines, when that is at most this far (pixels across the lines).
    manhattan_min_support : int
        Fewest support disparities behind one plane of the Manhattan fill.
    manhattan_edge_deg : float
        An outline edge follows a face family's horizontal lines when within this angle of
        the direction to their vanishing point.
    manhattan_max_planes : int
        Most planes (support clusters) the Manhattan fill puts in one region (several
        risers of one shade merge into one region above the cameras).
    manhattan_max_up_sigma_deg : float
        Without a rig, when the image's vertical lines do not fix up, the Manhattan fill
        uses a first estimate from the planar-filled disparity's planes only when its
        sigma is at most this: its faces take that up's directions, and the planes then
        found in them would confirm a wrong up.
    manhattan_check_deg : float
        A region the planar fill filled with a plane more than this far from all three of
        the scene's directions is fitted again by the Manhattan fill (0 = never).
    manhattan_after_gravity : bool
        Without a rig, where the Manhattan fill had no up to work with (the image's
        vertical lines did not fix it and the first estimate was too unsure), run it once
        the frame's planes and lines have fixed up, and find the planes again from the
        filled disparity (the pipeline does this; default True).
    max_behind_ratio : float
        A region's plane is refused when more than this share of its support lies behind
        it (by more than twice ``inlier_threshold_px``), away from its inliers: an
        outline's disparity is the face's own or an occluder's, never behind the face, so
        such a plane is an occluder's (1 = off; see :func:`_occluded_support`).
    support_gap_px : int
        Support behind the plane within this many pixels of its inliers does not count
        against it: the ring of a face's own silhouette reaches the background there.
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
    texture: str = "total"
    texture_window_px: int = 11
    horizontal_texture: float = 0.45
    split_gradient: float = 0.6
    split_bridge_px: int = 15
    split_sigma_x_px: float = 6.0
    close_px: int = 41
    orientation_ratio: float = 0.1
    invalidate: bool = False
    row_fill_max_gap_px: int = 0
    row_fill_max_step_px: float = 2.0
    manhattan: bool = True
    manhattan_reach_px: float = 20.0
    manhattan_min_support: int = 8
    manhattan_edge_deg: float = 6.0
    manhattan_max_planes: int = 8
    manhattan_max_up_sigma_deg: float = 1.0
    manhattan_check_deg: float = 20.0
    manhattan_after_gravity: bool = True
    max_behind_ratio: float = 0.15
    support_gap_px: int = 8

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "manhattan_max_planes")
        check_min(self, 3, "manhattan_min_support")
        check_min(self, 0, "manhattan_reach_px", "manhattan_max_up_sigma_deg", "manhattan_check_deg")
        if not 0 < self.manhattan_edge_deg < 45:
            raise ConfigError(f"manhattan_edge_deg must be in (0, 45), got {self.manhattan_edge_deg}")
        check_min(self, 1, "ring_px", "max_support_points")
        check_min(self, 0, "support_gap_px")
        if not 0 <= self.max_behind_ratio <= 1:
            raise ConfigError(f"max_behind_ratio must be in [0, 1], got {self.max_behind_ratio}")
        check_min(self, 3, "hypotheses", "texture_window_px")
        check_min(self, 1, "split_bridge_px", "close_px")
        check_min(
            self, 0, "split_gradient", "orientation_ratio", "row_fill_max_gap_px", "row_fill_max_step_px"
        )
        if self.texture not in TEXTURE_MODES:
            raise ConfigError(f"texture must be one of {TEXTURE_MODES}, got {self.texture!r}")
        if self.split_sigma_x_px <= 0:
            raise ConfigError(f"split_sigma_x_px must be > 0, got {self.split_sigma_x_px}")
        if self.horizontal_texture <= 0:
            raise ConfigError(f"horizontal_texture must be > 0, got {self.horizontal_texture}")
        check_min(self, 0, "min_region_fraction", "edge_gradient")
        if self.smooth_sigma_px <= 0 or self.flat_gradient <= 0 or self.inlier_threshold_px <= 0:
            raise ConfigError("smooth_sigma_px, flat_gradient and inlier_threshold_px must be > 0")
        if self.smooth_sigma_px > _MAX_SMOOTH_SIGMA_PX:
            # A Gaussian wider than any image: seconds a frame at 1e4, memory without end
            # at 1e300, and nothing flat left to find.
            raise ConfigError(
                f"smooth_sigma_px must be <= {_MAX_SMOOTH_SIGMA_PX:g} px, got {self.smooth_sigma_px}"
            )
        if not 0 < self.min_inlier_ratio <= 1 or not 0 < self.min_span_ratio <= 1:
            raise ConfigError("min_inlier_ratio and min_span_ratio must be in (0, 1]")


@dataclass(frozen=True)
class FlatRegions:
    """The image-only half of the fill (:func:`find_flat_regions`): it needs the rectified
    left image, not the disparity, so the pipeline computes it while the matcher runs.

    Attributes
    ----------
    count : int
        Number of labels (0 = not flat).
    labels : (H, W) int32
    stats : (count, 5) int32, OpenCV's ``x, y, width, height, area``
    gx : (H, W) float32
        Sobel ``d/dx`` of the smoothed image (the fill's vertical edges come from it).
    ill_posed : (H, W) bool or None
        ``"horizontal"`` mode only (see :func:`flat_regions`).
    gy : (H, W) float32
        Sobel ``d/dy`` of the smoothed image (the Manhattan fill reads the faces' outline
        directions from ``gx`` and ``gy``, :mod:`stereo_terrain.stereo.manhattan`).
    """

    count: int
    labels: np.ndarray = field(repr=False)
    stats: np.ndarray = field(repr=False)
    gx: np.ndarray = field(repr=False)
    ill_posed: np.ndarray | None = field(repr=False)
    gy: np.ndarray = field(repr=False)

    def without(self, labels: list[int]) -> FlatRegions:
        """These regions less ``labels``: their area set to 0 in a copy of ``stats``, so
        that no fill takes them (``labels`` itself is shared, unchanged)."""
        stats = self.stats.copy()
        stats[labels, 4] = 0
        return dataclasses.replace(self, stats=stats)


def find_flat_regions(
    image: np.ndarray, config: PlanarFillConfig, valid: np.ndarray | None = None
) -> FlatRegions:
    """The texture-poor regions of the rectified left image that :func:`fill_planar_regions`
    fits (pass them as its ``regions``; ``valid`` as there)."""
    return FlatRegions(*_flat_regions(image, config, valid))


def flat_regions(
    image: np.ndarray, config: PlanarFillConfig, valid: np.ndarray | None = None
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Label connected texture-poor regions of a grey image (only ``valid`` pixels, when
    given, can be flat).

    Returns
    -------
    count, labels (H, W) int32 (0 = not flat), stats (count, 5) from OpenCV,
    vertical_edges (H, W) bool: pixels whose horizontal gradient is strong, where
    matching along rows is reliable, and ill_posed (H, W) bool or None: in the
    ``"horizontal"`` mode, the pixels whose rows carry too little ``|dI/dx|`` to match
    (before the split at horizontal edges); None in the ``"total"`` mode.
    """
    count, labels, stats, gx, ill_posed, _ = _flat_regions(image, config, valid)
    return count, labels, stats, _vertical_edges(gx, config), ill_posed


def _vertical_edges(gx: np.ndarray, config: PlanarFillConfig) -> np.ndarray:
    """Pixels whose horizontal gradient (Sobel ``gx`` of the smoothed image) is strong:
    ``|gx| > edge_gx(config)``."""
    return np.abs(gx) > edge_gx(config)


def edge_gx(config: PlanarFillConfig) -> np.float32:
    """The Sobel ``|gx|`` above which a pixel is on a vertical edge: ``|gx| / 8 >
    edge_gradient`` (8 = Sobel's 3x3 kernel gain; scaling by 8 is exact)."""
    return np.float32(8.0 * config.edge_gradient)


def large_regions(stats: np.ndarray, shape: tuple[int, ...], config: PlanarFillConfig) -> np.ndarray:
    """Which regions (rows of OpenCV's ``stats``) the fills fit: at least
    ``min_region_fraction`` of an image of ``shape``, 8 px wide and 4 px tall; never the
    background (label 0). One vectorised test (issue 13: textured images have thousands of
    tiny flat specks)."""
    h, w = shape[:2]
    large = (stats[:, 4] >= config.min_region_fraction * h * w) & (stats[:, 2] >= 8) & (stats[:, 3] >= 4)
    large[0] = False
    return large


def region_box(stat: np.ndarray, shape: tuple[int, ...], ring_px: int) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)``: a region's bounding box (its row of ``stats``) grown by the ring
    of ``ring_px`` pixels, within an image of ``shape``."""
    x, y, bw, bh = (int(a) for a in stat[:4])
    h, w = shape[:2]
    return max(0, x - ring_px), max(0, y - ring_px), min(w, x + bw + ring_px), min(h, y + bh + ring_px)


def _flat_regions(
    image: np.ndarray, config: PlanarFillConfig, valid: np.ndarray | None
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """:func:`flat_regions` with the Sobel ``gx`` in place of the edge mask (the fill needs
    the edges only around the regions it fits, not over the whole image; issue 13), and the
    Sobel ``gy`` last."""
    g = cv2.GaussianBlur(image.astype(np.float32), (0, 0), config.smooth_sigma_px)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    if config.texture == "horizontal":
        # Matching along rows needs |dI/dx|: averaged over a window, it says whether a
        # matching window has anything to lock onto (8 = Sobel's 3x3 kernel gain).
        k = config.texture_window_px
        ill_posed = cv2.boxFilter(np.abs(gx), -1, (k, k)) / 8.0 < config.horizontal_texture
        if config.orientation_ratio > 0:
            # Structure tensor: where the window's texture is nearly horizontal (grain),
            # Jxx << Jyy and a match along rows slides along the grain.
            jxx = cv2.boxFilter(gx * gx, -1, (k, k))
            jyy = cv2.boxFilter(gy * gy, -1, (k, k))
            ill_posed |= jxx < config.orientation_ratio * jyy
        if valid is not None:
            ill_posed &= valid
        # Split faces at horizontal edges (nosing lines, step edges): a riser and the
        # tread above it are two planes.
        # Step edges are straight and long; grain is neither: smooth along rows first.
        gs = cv2.GaussianBlur(
            image.astype(np.float32), (0, 0), config.split_sigma_x_px, sigmaY=config.smooth_sigma_px
        )
        split = (np.abs(cv2.Sobel(gs, cv2.CV_32F, 0, 1, ksize=3)) / 8.0 >= config.split_gradient).astype(
            np.uint8
        )
        if config.split_bridge_px > 1:
            # A faint step edge has gaps; one gap joins two faces into a region no plane
            # explains. Bridge gaps along rows (step edges are near-horizontal).
            split = np.asarray(cv2.dilate(split, np.ones((1, config.split_bridge_px), np.uint8)))
        band = ill_posed.astype(np.uint8)
        if config.close_px > 1:
            # A plank end or a seam is a narrow textured column inside an ill-posed face:
            # close it along rows so that the face stays one region and the column's
            # disparities (the best it has) support the face's plane.
            band = np.asarray(
                cv2.morphologyEx(band, cv2.MORPH_CLOSE, np.ones((1, config.close_px), np.uint8))
            )
        flat = band.astype(bool) & (split == 0)
        if valid is not None:
            flat &= valid
        flat = flat.astype(np.uint8)
    else:
        ill_posed = None
        # |grad| / 8 < flat_gradient (8 = Sobel's 3x3 kernel gain; scaling by 8 is exact), as
        # 0/1 bytes in one pass.
        flat = (cv2.magnitude(gx, gy) < np.float32(8.0 * config.flat_gradient)).view(np.uint8)
    if valid is not None:
        flat[~valid] = 0
    flat = cv2.erode(flat, np.ones((3, 3), np.uint8))
    count, labels, stats = connected_regions(flat)  # OpenCV's, faster (issue 13)
    return count, labels, stats, gx, ill_posed, gy


def fill_planar_regions(
    disparity: np.ndarray,
    left: np.ndarray,
    config: PlanarFillConfig | None = None,
    *,
    max_disparity_px: float | None = None,
    valid: np.ndarray | None = None,
    regions: FlatRegions | None = None,
    occluded: list[int] | None = None,
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
    regions : FlatRegions, optional
        :func:`find_flat_regions` of ``left`` with the same ``config`` and ``valid``, when
        already computed (found here otherwise).
    occluded : list of int, optional
        When given, the labels of the regions whose plane was refused as an occluder's
        (``max_behind_ratio``) are appended to it: their support holds no plane of their
        own, so no other fill should take them either (:meth:`FlatRegions.without`).

    Returns
    -------
    filled_disparity : (H, W) float32
    filled_mask : (H, W) bool, pixels whose value came from a plane
    """
    config = config or PlanarFillConfig()
    if not config.enabled:
        return disparity.copy(), np.zeros(disparity.shape, dtype=bool)
    if regions is None:
        regions = find_flat_regions(left, config, valid)
    out, filled, refused = _fill(disparity, config, max_disparity_px, regions)  # reads it, writes a copy
    if occluded is not None:
        occluded.extend(refused)
    if config.texture == "total" and config.invalidate:
        # A confident match where rows carry no horizontal texture is a streak: NaN it,
        # unless a plane filled the pixel; then bridge the holes along rows.
        ill = ill_posed_mask(left, config, valid) & ~filled
        out[ill] = np.nan
        if config.row_fill_max_gap_px > 0:
            out, rows = fill_rows(out, ill, config.row_fill_max_gap_px, config.row_fill_max_step_px)
            filled |= rows
    return out, filled


def _fill(disparity, config, max_disparity_px, regions: FlatRegions):
    """The fill of ``disparity`` (not written to) from ``regions``: ``(filled disparity,
    filled mask)``, new arrays, and the labels of the regions refused as occluded."""
    out = disparity.copy()
    occluded: list[int] = []
    filled = np.zeros(disparity.shape, dtype=bool)
    labels, stats, gx, ill_posed = (
        regions.labels,
        regions.stats,
        regions.gx,
        regions.ill_posed,
    )
    if ill_posed is not None and config.invalidate:
        # A confident match where rows carry no horizontal texture is a streak: drop it
        # before it can support a plane, and let only a supported plane put a value back.
        out[ill_posed] = np.nan
        disparity = out.copy()
    rng = np.random.default_rng(config.seed)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * config.ring_px + 1,) * 2)
    large = large_regions(stats, disparity.shape, config)
    edge_threshold = edge_gx(config)
    edges_only = ill_posed is None or not config.invalidate
    # NumPy compares a float32 plane with a Python number in float32: so does the kernel.
    max_d = np.float32(0 if max_disparity_px is None else max_disparity_px)
    for k in np.flatnonzero(large):
        bw, bh = stats[k, 2], stats[k, 3]
        # Work in the region's bounding box grown by the ring.
        x0, y0, x1, y1 = region_box(stats[k], disparity.shape, config.ring_px)
        box_labels = labels[y0:y1, x0:x1]
        # Only disparities on vertical edges are trusted: inside the face SGM has nothing to
        # match (its values there may be a ramp), and along horizontal edges the match is
        # ambiguous (the aperture problem). Without them when the invalidation already kept
        # only the disparities with horizontal texture around them (vertical edges, ends of
        # planks, texture next to the face).
        box = disparity[y0:y1, x0:x1]
        near = cv2.dilate((box_labels == k).view(np.uint8), kernel)
        vs, us = edge_support(near, box, gx[y0:y1, x0:x1], edge_threshold, edges_only)
        if len(us) < 20:
            continue
        ds = box[vs, us]
        uvd = np.column_stack([us + x0, vs + y0, ds]).astype(np.float64)
        if len(uvd) > config.max_support_points:
            uvd = uvd[rng.choice(len(uvd), config.max_support_points, replace=False)]
        trip = rng.integers(0, len(uvd), size=(config.hypotheses, 3))
        coef = _fit_support(uvd, trip, config, bw, bh)
        if coef is _OCCLUDED:
            occluded.append(int(k))
            continue
        if coef is None:
            continue
        # The face has no texture of its own: its matches carry no information, so the
        # whole face takes the plane supported by its outline.
        fill_region_plane(box_labels, int(k), x0, y0, coef, max_d, max_disparity_px is not None, out, filled)
    return out, filled, occluded


def _fit_support(uvd, trip, config: PlanarFillConfig, bw: int, bh: int) -> np.ndarray | None:
    """The plane ``d = a u + b v + c`` (``(a, b, c)``) that a region's support ``uvd``
    (N, 3: u, v, d) carries; None when no plane is supported across the region's box
    (``bw`` x ``bh``), ``_OCCLUDED`` when its support says it is an occluder's
    (:func:`_occluded_support`). ``trip`` (K, 3): MSAC's minimal samples."""
    res = plane_msac(uvd, config.inlier_threshold_px, trip, hypothesis_ok=lambda n: np.abs(n[:, 2]) > 0.3)
    if res.model is None:
        return None
    inl = res.inliers
    if inl.mean() < config.min_inlier_ratio:
        return None
    iu, iv = uvd[inl, 0], uvd[inl, 1]
    if np.ptp(iu) < config.min_span_ratio * bw or np.ptp(iv) < config.min_span_ratio * bh:
        return None
    n, c = res.model.normal, res.model.offset
    # Least-squares refit on the inliers: d = a u + b v + e.
    A = np.column_stack([iu, iv, np.ones(len(iu))])
    coef, *_ = np.linalg.lstsq(A, uvd[inl, 2], rcond=None)
    if not np.all(np.isfinite(coef)):
        coef = np.array([-n[0] / n[2], -n[1] / n[2], -c / n[2]])
    if _occluded_support(uvd, coef, config):
        return _OCCLUDED
    return coef


def _occluded_support(uvd, coef, config: PlanarFillConfig) -> bool:
    """Whether a region's support ``uvd`` shows a surface behind its plane ``coef``.

    An outline's disparity is the face's own (a crease, or the face's silhouette, which the
    matcher fattens outwards) or an occluder's, in front of the face (fattened onto the
    face's side of the edge); it is not behind the face. A plane that more than
    ``max_behind_ratio`` of the support lies behind (by more than twice the inlier
    threshold) is an occluder's: the face shows behind it. Behind points within
    ``support_gap_px`` of the plane's inliers do not count: they are the ring of the face's
    own silhouette reaching the background.
    """
    t = config.inlier_threshold_px
    resid = (uvd[:, 2] - uvd[:, 0] * coef[0] - uvd[:, 1] * coef[1] - coef[2]) / np.sqrt(
        1 + coef[0] ** 2 + coef[1] ** 2
    )
    behind = resid < -2 * t
    if behind.mean() <= config.max_behind_ratio:
        return False
    u = uvd[:, 0].astype(np.int32)
    v = uvd[:, 1].astype(np.int32)
    u0, v0 = u.min(), v.min()
    near = np.zeros((v.max() - v0 + 1, u.max() - u0 + 1), np.uint8)
    inl = np.abs(resid) < t
    near[v[inl] - v0, u[inl] - u0] = 1
    r = config.support_gap_px
    near = cv2.dilate(near, np.ones((2 * r + 1, 2 * r + 1), np.uint8))
    return bool(np.mean(behind & (near[v - v0, u - u0] == 0)) > config.max_behind_ratio)


def ill_posed_mask(
    image: np.ndarray, config: PlanarFillConfig, valid: np.ndarray | None = None
) -> np.ndarray:
    """Pixels where matching along rows is ill-posed, (H, W) bool: too little mean
    ``|dI/dx|`` in the ``texture_window_px`` window (``horizontal_texture``), or texture
    nearly horizontal (structure tensor ``Jxx < orientation_ratio * Jyy``)."""
    g = cv2.GaussianBlur(image.astype(np.float32), (0, 0), config.smooth_sigma_px)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    k = config.texture_window_px
    ill = cv2.boxFilter(np.abs(gx), -1, (k, k)) / 8.0 < config.horizontal_texture
    if config.orientation_ratio > 0:
        gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
        ill |= cv2.boxFilter(gx * gx, -1, (k, k)) < config.orientation_ratio * cv2.boxFilter(
            gy * gy, -1, (k, k)
        )
    if valid is not None:
        ill &= valid
    return ill


def fill_rows(
    disparity: np.ndarray, holes: np.ndarray, max_gap_px: int, max_step_px: float
) -> tuple[np.ndarray, np.ndarray]:
    """Fill ``holes`` pixels by linear interpolation along their row between the nearest
    finite disparities on either side.

    Along an image row a plane's disparity is affine in ``u``, so two anchors on the same
    face give it exactly. A run is filled only when the anchors are at most
    ``max_gap_px`` apart and differ by at most ``max_step_px`` (a larger jump is a depth
    edge, where a ramp would be wrong). Returns the filled disparity and the mask of
    filled pixels.
    """
    h, w = disparity.shape
    fin = np.isfinite(disparity)
    cols = np.arange(w, dtype=np.int32)[None, :]
    left_idx = np.maximum.accumulate(np.where(fin, cols, np.int32(-1)), axis=1)
    right_idx = np.minimum.accumulate(np.where(fin, cols, np.int32(w))[:, ::-1], axis=1)[:, ::-1]
    ok = holes & ~fin & (left_idx >= 0) & (right_idx < w) & (right_idx - left_idx <= max_gap_px)
    out = disparity.copy()
    if not ok.any():
        return out, ok
    r, c = np.nonzero(ok)
    li, ri = left_idx[r, c], right_idx[r, c]
    dl, dr = disparity[r, li], disparity[r, ri]
    keep = np.abs(dl - dr) <= max_step_px
    r, c, li, ri, dl, dr = r[keep], c[keep], li[keep], ri[keep], dl[keep], dr[keep]
    out[r, c] = dl + (c - li) / (ri - li) * (dr - dl)
    ok = np.zeros_like(ok)
    ok[r, c] = True
    return out, ok
