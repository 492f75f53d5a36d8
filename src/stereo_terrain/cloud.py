"""Stage 3: disparity -> organized point cloud, and moving it between frames.

The cloud keeps the image's (H, W) organisation so that later stages can use image
neighbourhoods (normals, contours, region growing) without a k-d tree.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

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
        pts.astype(np.float32), cloud.valid, T.to_frame, cloud.sigma_m,
        T.apply(cloud.camera_position[None, :].astype(np.float64))[0], cloud.confidence,
    )
