"""Stage 3: disparity -> point cloud (organized, and a grid subsample with normals).

The cloud keeps the image's (H, W) organisation so that later stages can use image
neighbourhoods (normals, contours, region growing) without a k-d tree.

The plane stage works on a :class:`GridSample`: a regular subsample of the pixels with a
local normal each. Normals come from the cross product of the surface's tangents along
image rows and columns, taken on a box-filtered (NaN-aware) neighbourhood: no k-d tree, a
few box filters per frame. Points near depth edges or creases get mixed normals, which is
what lets the plane stage refuse them. :func:`sample_disparity` builds it straight from
the disparity (a plane is affine in disparity, so filtering there is exact on planes) and
never forms the full-resolution cloud.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import cv2
import numpy as np

from ._cloud_kernels import grid_cells_normals
from .checks import check_fields
from .errors import ConfigError, FrameError
from .frames import Transform
from .stereo import DisparityMap


@dataclass(frozen=True)
class CloudConfig:
    """Which reprojected points to keep.

    Attributes
    ----------
    min_depth_m, max_depth_m : float
        Points outside this depth range (rectified camera Z) are invalid.
    """

    min_depth_m: float = 0.3
    max_depth_m: float = 4.0

    def __post_init__(self) -> None:
        check_fields(self)
        if not 0 < self.min_depth_m < self.max_depth_m:
            raise ConfigError(
                f"need 0 < min_depth_m < max_depth_m, got {self.min_depth_m}, {self.max_depth_m}"
            )


@dataclass(frozen=True)
class PointCloud:
    """An organized point cloud.

    Attributes
    ----------
    points : (H, W, 3) float32, metres
        Point of each pixel in ``frame``; NaN where invalid.
    valid : (H, W) bool
    frame : str
        Frame name (``camera_rect``, ``yaw``, ...).
    sigma_m : (H, W) float32, metres
        1-sigma depth uncertainty of each point from a disparity error of
        ``disparity_sigma_px`` (``sigma_Z = Z**2 sigma_d / (f B)``); NaN where invalid.
    camera_position : (3,) float64
        Centre of the rectified left camera in ``frame`` (to orient plane normals).
    confidence : (H, W) float32 or None
        Disparity confidence in [0, 1] where the backend gives one.
    """

    points: np.ndarray = field(repr=False)
    valid: np.ndarray = field(repr=False)
    frame: str
    sigma_m: np.ndarray = field(repr=False)
    camera_position: np.ndarray = field(repr=False)
    confidence: np.ndarray | None = field(default=None, repr=False)

    @property
    def shape(self) -> tuple[int, int]:
        return self.valid.shape  # type: ignore[return-value]

    @property
    def count(self) -> int:
        return int(self.valid.sum())


def disparity_to_cloud(
    disparity: DisparityMap,
    config: CloudConfig | None = None,
    *,
    disparity_sigma_px: float = 0.25,
) -> PointCloud:
    """Reproject a disparity map into the rectified left camera frame (``camera_rect``).

    ``Z = f B / (d + doffs)``, ``X = (u - cx) Z / f``, ``Y = (v - cy) Z / f``. Pixels
    with NaN disparity or a depth outside ``[min_depth_m, max_depth_m]`` become NaN.

    Returns
    -------
    PointCloud in frame ``camera_rect``.
    """
    config = config or CloudConfig()
    rect = disparity.rectification
    z = rect.depth_from_disparity(disparity.disparity)
    valid = np.isfinite(z) & (z >= config.min_depth_m) & (z <= config.max_depth_m)
    h, w = z.shape
    f = np.float32(rect.focal_px)
    u = (np.arange(w, dtype=np.float32) - np.float32(rect.cx)) / f
    v = (np.arange(h, dtype=np.float32) - np.float32(rect.cy)) / f
    pts = np.empty((h, w, 3), dtype=np.float32)
    pts[:, :, 0] = u[None, :] * z
    pts[:, :, 1] = v[:, None] * z
    pts[:, :, 2] = z
    pts[~valid] = np.nan
    sigma = (z * z) * np.float32(disparity_sigma_px / (rect.focal_px * rect.baseline_m))
    sigma[~valid] = np.nan
    conf = disparity.confidence
    return PointCloud(pts, valid, "camera_rect", sigma.astype(np.float32), np.zeros(3), conf)


def transform_cloud(cloud: PointCloud, T: Transform) -> PointCloud:
    """Express ``cloud`` in ``T.to_frame``; ``T.from_frame`` must be ``cloud.frame``."""
    if T.from_frame != cloud.frame:
        raise FrameError(f"cannot apply {T.name} to a cloud in frame '{cloud.frame}'")
    pts = T.apply(cloud.points)
    return PointCloud(
        pts.astype(np.float32),
        cloud.valid,
        T.to_frame,
        cloud.sigma_m,
        T.apply(cloud.camera_position[None, :].astype(np.float64))[0],
        cloud.confidence,
    )


@dataclass(frozen=True)
class GridSample:
    """A regular subsample of an organized cloud with local normals.

    Attributes
    ----------
    points : (N, 3) float32, metres, the cloud's frame
    normals : (N, 3) float32, unit, sign arbitrary
    sigma_m : (N,) float32, depth 1-sigma of each point
    rows, cols : (N,) int32
        Pixel of each sample in the full image.
    grid_index : (N,) int32
        Flat index into the ``grid_shape`` grid.
    grid_shape : (gh, gw)
    stride_px : int
    frame : str
    confidence : (N,) float32 or None
    camera_position : (3,) float64
        Centre of the rectified left camera in ``frame``.
    normal_sigma_rad : (N,) float32 or None
        Expected error of each normal from the disparity's noise (radians), where the
        sample was taken from a disparity map (:func:`sample_disparity`); None otherwise.
    source_rows : (2, gw) int32 or None
        Per grid column, the first and last pixel rows that have a source pixel in both
        raw images (``Rectification.valid_left`` and ``valid_right``): a rectification
        that keeps the raw view (``fov="keep"``) has rows outside it at the top and
        bottom, more at the middle of the width than at the corners. None: every row has
        one. The view's top and bottom edges are these rows (:meth:`grid_rows_below_top`,
        :meth:`rows_above_bottom`). Its sides are not kept: a right pixel's column is the
        left one's less its disparity, so where the view's side cuts a face depends on the
        face's depth (the terrain stage takes the samples' outermost columns).
    """

    points: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    sigma_m: np.ndarray = field(repr=False)
    rows: np.ndarray = field(repr=False)
    cols: np.ndarray = field(repr=False)
    grid_index: np.ndarray = field(repr=False)
    grid_shape: tuple[int, int]
    stride_px: int
    frame: str
    confidence: np.ndarray | None = field(default=None, repr=False)
    camera_position: np.ndarray = field(default_factory=lambda: np.zeros(3), repr=False)
    normal_sigma_rad: np.ndarray | None = field(default=None, repr=False)
    source_rows: np.ndarray | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.points)

    def grid_rows_below_top(self) -> np.ndarray:
        """(N,) int: each sample's grid row, less the grid rows above it whose centres
        have no source pixel in its column (the view's top edge is row 0 of the grid in
        every column)."""
        grid_row = self.grid_index // self.grid_shape[1]
        if self.source_rows is None:
            return grid_row
        r0 = self.stride_px // 2
        lost = np.maximum(-(-(self.source_rows[0] - r0) // self.stride_px), 0)
        return grid_row - lost[self.grid_index % self.grid_shape[1]]

    def rows_above_bottom(self) -> np.ndarray:
        """(N,) int: each sample's pixel rows above the view's bottom edge in its column
        (the last row with a source pixel there; None ``source_rows``: the same row in
        every column), less the fewest any sample has: 0 for the samples that reach as low
        in the view as any does."""
        rows = np.asarray(self.rows)
        if self.source_rows is None:
            return rows.max(initial=0) - rows
        above = self.source_rows[1][self.grid_index % self.grid_shape[1]] - rows
        return above - above.min() if len(above) else above


def grid_stride(shape: tuple[int, int], target_points: int) -> int:
    """Pixel stride giving about ``target_points`` samples for an image of ``shape``."""
    h, w = shape
    return max(1, int(round(np.sqrt(h * w / max(target_points, 1)))))


def _grid_cells(valid: np.ndarray, density: np.ndarray, stride: int, k: int):
    """Centres of a ``stride`` grid and their four neighbours ``k`` px away, kept where the
    centre is valid and every neighbour's box is mostly valid (``density > 0.6``).

    Returns flat ``(rr, cc, ru, rd, cl, cr, flat_index, (gh, gw))``.
    """
    rr, cc, ru, rd, cl, cr, grid_shape = _grid_layout(*valid.shape, stride, k)
    dense = density > 0.6
    ok = valid[rr, cc] & dense[rr, cl] & dense[rr, cr] & dense[ru, cc] & dense[rd, cc]
    idx = np.flatnonzero(ok)
    return rr[idx], cc[idx], ru[idx], rd[idx], cl[idx], cr[idx], idx, grid_shape


@functools.lru_cache(maxsize=8)
def _grid_layout(h: int, w: int, stride: int, k: int):
    """Grid centres of an (h, w) image and their neighbours' rows and columns (the same
    every frame, so built once: read-only arrays)."""
    r0 = stride // 2
    rows = np.arange(r0, h, stride)
    cols = np.arange(r0, w, stride)
    grid_r, grid_c = np.meshgrid(rows, cols, indexing="ij")
    rr, cc = grid_r.reshape(-1), grid_c.reshape(-1)
    ru, rd = np.clip(rr - k, 0, h - 1), np.clip(rr + k, 0, h - 1)
    cl, cr = np.clip(cc - k, 0, w - 1), np.clip(cc + k, 0, w - 1)
    for a in (rr, cc, ru, rd, cl, cr):
        a.flags.writeable = False
    return rr, cc, ru, rd, cl, cr, (len(rows), len(cols))


def sample_grid(cloud: PointCloud, *, target_points: int = 12000, smooth_px: int | None = None) -> GridSample:
    """Subsample ``cloud`` on a regular grid and estimate a normal at each sample.

    Parameters
    ----------
    cloud : PointCloud
    target_points : int
        About this many grid cells (valid or not).
    smooth_px : int, optional
        Half-size of the neighbourhood used for normals; default scales with image width
        (4 px at 640 wide).

    Returns
    -------
    GridSample of the valid samples whose neighbourhood is mostly valid.
    """
    h, w = cloud.shape
    stride = grid_stride((h, w), target_points)
    k = smooth_px if smooth_px is not None else max(2, int(round(4 * w / 640)))
    valid = cloud.valid
    pts = np.where(valid[:, :, None], cloud.points, 0.0).astype(np.float32)
    ksize = (2 * k + 1, 2 * k + 1)
    cnt = cv2.boxFilter(valid.astype(np.float32), -1, ksize, normalize=True, borderType=cv2.BORDER_CONSTANT)
    acc = cv2.boxFilter(pts, -1, ksize, normalize=True, borderType=cv2.BORDER_CONSTANT)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = acc / cnt[:, :, None]
    rr, cc, ru, rd, cl, cr, idx, (gh, gw) = _grid_cells(valid, cnt, stride, k)
    n = np.cross(mean[rr, cr] - mean[rr, cl], mean[rd, cc] - mean[ru, cc])
    norm = np.linalg.norm(n, axis=-1)
    good = (norm > 0) & np.isfinite(norm)
    n = n[good] / norm[good, None]
    sel_r, sel_c, flat = rr[good], cc[good], idx[good]
    conf = None if cloud.confidence is None else cloud.confidence[sel_r, sel_c].astype(np.float32)
    return GridSample(
        points=cloud.points[sel_r, sel_c].astype(np.float32),
        normals=n.astype(np.float32),
        sigma_m=cloud.sigma_m[sel_r, sel_c].astype(np.float32),
        rows=sel_r.astype(np.int32),
        cols=sel_c.astype(np.int32),
        grid_index=flat.astype(np.int32),
        grid_shape=(gh, gw),
        stride_px=stride,
        frame=cloud.frame,
        confidence=conf,
        camera_position=np.asarray(cloud.camera_position, dtype=np.float64),
    )


def _box_means(
    disparity: DisparityMap, config: CloudConfig, target_points: int, smooth_px: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int]:
    """What :func:`sample_disparity` filters over the whole image: ``dd`` (disparity plus
    ``doffs``), ``valid`` (in the depth range), the box means ``density`` of ``valid`` and
    ``acc`` of the valid disparities, the grid stride and the box half-size ``k``."""
    rect = disparity.rectification
    d = disparity.disparity
    fb = rect.focal_px * rect.baseline_m
    dd = d + np.float32(rect.doffs_px) if rect.doffs_px else d
    # In the depth range: one OpenCV pass (NaN is outside every range), as 0/1 bytes whose
    # bool view is the mask (issue 13: a third of this function's time went to the masks).
    lo, hi = np.float32(fb / config.max_depth_m), np.float32(fb / config.min_depth_m)
    in_range = cv2.inRange(dd, float(lo), float(hi))
    # Valid disparities, 0 elsewhere: the float32 bits masked by OpenCV (a tenth of
    # np.where's time; the same bits, +0.0 outside the mask).
    masked = cv2.bitwise_and(dd, dd, mask=in_range)
    cv2.threshold(in_range, 0, 1, cv2.THRESH_BINARY, dst=in_range)  # 0/255 -> 0/1 bytes
    valid = in_range.view(bool)
    # Stride and normal scale per raw pixel: a rectification that keeps more of the view
    # than the raw size (fov="keep") gives more samples, not a sparser grid.
    raw_w, raw_h = rect.raw_size
    stride = grid_stride((raw_h, raw_w), target_points)
    k = smooth_px if smooth_px is not None else max(2, int(round(4 * raw_w / 640)))
    ksize = (2 * k + 1, 2 * k + 1)
    density = cv2.boxFilter(
        in_range.astype(np.float32), -1, ksize, normalize=True, borderType=cv2.BORDER_CONSTANT
    )
    acc = cv2.boxFilter(masked, -1, ksize, normalize=True, borderType=cv2.BORDER_CONSTANT)
    return dd, valid, density, acc, stride, k


def sample_disparity(
    disparity: DisparityMap,
    T: Transform,
    config: CloudConfig | None = None,
    *,
    target_points: int = 12000,
    smooth_px: int | None = None,
    disparity_sigma_px: float = 0.25,
    box_disparity_sigma_px: float = 0.1,
) -> GridSample:
    """Grid subsample with normals straight from a disparity map, in ``T.to_frame``.

    Equivalent to ``sample_grid(transform_cloud(disparity_to_cloud(...), T))`` but
    smooths in disparity space (exact for planes, which are affine there) and reprojects
    only the samples and their four neighbours: a few milliseconds at 640x480.

    Parameters
    ----------
    disparity : DisparityMap
    T : Transform
        ``T_<frame>_camera_rect``.
    config : CloudConfig
        Depth range of the points kept.
    target_points : int
        About this many grid cells for an image of the raw size (a larger rectified image,
        ``fov="keep"``, gets more at the same stride).
    smooth_px : int, optional
        Half-size of the neighbourhood used for normals (default 4 px at 640 raw pixels
        wide).
    disparity_sigma_px : float
        1-sigma of one pixel's disparity (the samples' ``sigma_m``).
    box_disparity_sigma_px : float
        1-sigma of a box mean's disparity (the matcher's errors are correlated over a box,
        so far above a pixel's over the box's count): gives ``normal_sigma_rad``.

    Returns
    -------
    GridSample in ``T.to_frame``.
    """
    if T.from_frame != "camera_rect":
        raise FrameError(f"sample_disparity needs T_<frame>_camera_rect, got {T.name}")
    config = config or CloudConfig()
    rect = disparity.rectification
    h, w = disparity.disparity.shape
    fb = rect.focal_px * rect.baseline_m
    dd, valid, cnt, acc, stride, k = _box_means(disparity, config, target_points, smooth_px)
    rr, cc, ru, rd, cl, cr, (gh, gw) = _grid_layout(h, w, stride, k)
    # The cells, their normals (cross product of the tangents between the neighbours' box
    # means, reprojected) and points: one compiled pass (issue 13), NumPy's arithmetic.
    cells, n, pts = grid_cells_normals(
        valid,
        cnt,
        acc,
        dd,
        rr,
        cc,
        ru,
        rd,
        cl,
        cr,
        float(fb),
        float(rect.cx),
        float(rect.cy),
        float(rect.focal_px),
    )
    rr, cc, idx = rr[cells], cc[cells], cells
    source_rows = _source_rows(rect.valid_left, rect.valid_right, stride)
    sigma = (pts[:, 2] ** 2) * (disparity_sigma_px / fb)
    # A normal is the cross product of two tangents 2k px long, Z 2k / f metres, each the
    # difference of two box means whose depths err by Z^2 sigma_box / (f B): it tilts by
    # about atan(sqrt(2) Z sigma_box / (2k B)), growing with depth. Far, where a riser is
    # a few boxes tall, that is tens of degrees (docs/benchmarks.md, "Stairs 2-4 m ahead").
    tilt = np.arctan(np.sqrt(2.0) * box_disparity_sigma_px * pts[:, 2] / (2 * k * rect.baseline_m))
    conf = None if disparity.confidence is None else disparity.confidence[rr, cc].astype(np.float32)
    return GridSample(
        points=T.apply(pts).astype(np.float32),
        normals=T.apply_vectors(n).astype(np.float32),
        sigma_m=sigma.astype(np.float32),
        rows=rr.astype(np.int32),
        cols=cc.astype(np.int32),
        grid_index=idx.astype(np.int32),
        grid_shape=(gh, gw),
        stride_px=stride,
        frame=T.to_frame,
        confidence=conf,
        camera_position=T.translation.copy(),
        normal_sigma_rad=tilt.astype(np.float32),
        source_rows=source_rows,
    )


def _source_rows(
    valid_left: np.ndarray | None, valid_right: np.ndarray | None, stride: int
) -> np.ndarray | None:
    """(2, gw) int32: the first and last rows with a source pixel in both rectified images
    in each grid column (``GridSample.source_rows``; a column without one gets rows ``h``
    and ``-1``); None where every pixel has one. Both images: a pixel is matched only
    where the right image has one on its row too, and the right camera's outline is
    another curve (on a rendered default scene its top row was 10 px below the left's at
    the middle of the width). The same column of each: a disparity moves a pixel along
    its row, and the outlines' rows change slowly across the width."""
    masks = [m[:, stride // 2 :: stride] for m in (valid_left, valid_right) if m is not None]
    if not masks:
        return None
    cols = np.logical_and.reduce(masks)  # the grid's columns of both, not the whole images
    h = cols.shape[0]
    first = np.argmax(cols, axis=0)
    last = h - 1 - np.argmax(cols[::-1], axis=0)
    none = ~cols.any(axis=0)
    first[none], last[none] = h, -1
    return np.stack([first, last]).astype(np.int32)


def transform_sample(sample: GridSample, T: Transform) -> GridSample:
    """Express a grid sample in ``T.to_frame``; ``T.from_frame`` must be ``sample.frame``."""
    if T.from_frame != sample.frame:
        raise FrameError(f"cannot apply {T.name} to a grid sample in frame '{sample.frame}'")
    return dataclasses.replace(
        sample,
        points=T.apply(sample.points).astype(np.float32),
        normals=T.apply_vectors(sample.normals).astype(np.float32),
        frame=T.to_frame,
        camera_position=T.apply(sample.camera_position[None, :])[0],
    )
