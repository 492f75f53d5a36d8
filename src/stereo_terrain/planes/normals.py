"""Grid subsampling of an organized cloud and local normals from its image neighbourhood.

Normals come from the cross product of the cloud's tangents along image rows and
columns, taken on a box-filtered (NaN-aware) cloud: no k-d tree, a few box filters per
frame. Points near depth edges or creases get mixed normals, which is what lets the plane
stages refuse them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from ..cloud import PointCloud


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

    def __len__(self) -> int:
        return len(self.points)


def grid_stride(shape: tuple[int, int], target_points: int) -> int:
    """Pixel stride giving about ``target_points`` samples for an image of ``shape``."""
    h, w = shape
    return max(1, int(round(np.sqrt(h * w / max(target_points, 1)))))


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
    r0 = stride // 2
    rows = np.arange(r0, h, stride)
    cols = np.arange(r0, w, stride)
    gh, gw = len(rows), len(cols)
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    ru, rd = np.clip(rr - k, 0, h - 1), np.clip(rr + k, 0, h - 1)
    cl, cr = np.clip(cc - k, 0, w - 1), np.clip(cc + k, 0, w - 1)
    du = mean[rr, cr] - mean[rr, cl]
    dv = mean[rd, cc] - mean[ru, cc]
    n = np.cross(du, dv)
    norm = np.linalg.norm(n, axis=-1)
    dense = cnt > 0.6
    ok = (
        valid[rr, cc]
        & dense[rr, cl] & dense[rr, cr] & dense[ru, cc] & dense[rd, cc]
        & (norm > 0) & np.isfinite(norm)
    )
    n = n / np.where(ok, norm, 1.0)[..., None]
    flat = np.flatnonzero(ok.reshape(-1))
    sel_r, sel_c = rr.reshape(-1)[flat], cc.reshape(-1)[flat]
    conf = None if cloud.confidence is None else cloud.confidence[sel_r, sel_c].astype(np.float32)
    return GridSample(
        points=cloud.points[sel_r, sel_c].astype(np.float32),
        normals=n.reshape(-1, 3)[flat].astype(np.float32),
        sigma_m=cloud.sigma_m[sel_r, sel_c].astype(np.float32),
        rows=sel_r.astype(np.int32),
        cols=sel_c.astype(np.int32),
        grid_index=flat.astype(np.int32),
        grid_shape=(gh, gw),
        stride_px=stride,
        frame=cloud.frame,
        confidence=conf,
    )
