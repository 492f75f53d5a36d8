"""Stage 2: disparity from a rectified pair, behind one interface.

Every backend is a callable object with ``compute(pair, max_disparity_px) ->
DisparityMap``; :func:`make_backend` builds one by name. Backends: ``opencv``
(OpenCV StereoSGBM). The project's own SGM engine plugs in here under ``sgm``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..errors import ConfigError, InputError
from ..rectify import Rectification, RectifiedPair


@dataclass(frozen=True)
class DisparityMap:
    """Disparity of the rectified left image.

    Attributes
    ----------
    disparity : (H, W) float32, pixels
        ``x_left - x_right``; NaN where invalid (never 0).
    max_disparity_px : int
        Search range used (disparities in ``[0, max_disparity_px)``).
    rectification : Rectification
        Geometry needed to turn disparities into depth.
    confidence : (H, W) float32 in [0, 1] or None
        Per-pixel confidence where the backend gives one.
    backend : str
    filled : (H, W) bool or None
        Pixels whose disparity came from a plane fit (texture-poor fill), not matching.
    """

    disparity: np.ndarray = field(repr=False)
    max_disparity_px: int
    rectification: Rectification = field(repr=False)
    confidence: np.ndarray | None = field(default=None, repr=False)
    backend: str = ""
    filled: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        d = self.disparity
        if d.ndim != 2 or d.dtype != np.float32:
            raise InputError(f"disparity must be (H, W) float32, got {d.shape} {d.dtype}")

    @property
    def valid(self) -> np.ndarray:
        """(H, W) bool, finite disparities."""
        return np.isfinite(self.disparity)

    @property
    def density(self) -> float:
        """Share of the pixels with a depth: a finite disparity above zero. OpenCV's SGBM
        gives a blank or uniform pair (a covered lens, a dead camera) disparity 0, at
        infinity, nearly everywhere; counted, it read as healthy as a good frame."""
        d = self.disparity
        return float(np.mean(np.isfinite(d) & (d > 0)))


class DisparityBackend(Protocol):
    """What the pipeline needs of a disparity engine."""

    name: str

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap: ...


def choose_max_disparity(rectification: Rectification, min_depth_m: float, multiple: int = 16) -> int:
    """Smallest multiple of ``multiple`` pixels that sees down to ``min_depth_m``.

    ``d = f B / Z - doffs``; e.g. f = 540 px, B = 0.08 m, Z = 0.7 m -> 64 px.
    """
    if not min_depth_m > 0:
        raise ConfigError(f"min_depth_m must be > 0, got {min_depth_m}")
    d = rectification.focal_px * rectification.baseline_m / min_depth_m - rectification.doffs_px
    n = int(np.ceil(max(d, multiple) / multiple)) * multiple
    return n


def default_max_disparity(rectification: Rectification, min_depth_m: float) -> int:
    """The disparity range used when none is given: the calibration's own (Middlebury
    ``ndisp``) rounded up to a multiple of 16, else enough to see ``min_depth_m``; never more
    than half the rectified image's width."""
    calib = rectification.calibration
    if calib.ndisp:
        n = -(-calib.ndisp // 16) * 16
    else:
        n = choose_max_disparity(rectification, min_depth_m)
    return min(n, (rectification.image_size[0] // 2) // 16 * 16)


def check_max_disparity(max_disparity_px: int, width: int, multiple: int = 16) -> int:
    """Validate a disparity range: a positive multiple of ``multiple`` below the width."""
    if isinstance(max_disparity_px, bool) or not isinstance(max_disparity_px, (int, np.integer)):
        raise ConfigError(f"max_disparity_px must be an integer, got {max_disparity_px!r}")
    n = int(max_disparity_px)
    if n <= 0 or n % multiple != 0:
        raise ConfigError(
            f"max_disparity_px must be a positive multiple of {multiple}, got {n}; "
            f"try {max(multiple, (n + multiple - 1) // multiple * multiple)}"
        )
    if n >= width:
        raise ConfigError(f"max_disparity_px={n} must be smaller than the image width {width}")
    return n


def invalidate_sourceless(disparity: np.ndarray, rectification: Rectification) -> np.ndarray:
    """Make NaN, in place, every disparity whose left pixel or matched right pixel
    ``(x - d, y)`` has no raw source pixel (``Rectification.valid_left/valid_right``: the
    black border of a rectification that keeps the whole field of view, where a matcher
    would find false matches). Returns ``disparity``.

    Parameters
    ----------
    disparity : (H, W) float32, pixels, NaN invalid
    rectification : Rectification
    """
    vl, vr = rectification.valid_left, rectification.valid_right
    if vl is not None and vl.shape == disparity.shape:
        disparity[~vl] = np.nan
    if vr is not None and vr.shape == disparity.shape:
        ys, xs = np.nonzero(np.isfinite(disparity))
        xr = np.rint(xs - disparity[ys, xs]).astype(np.intp)
        inside = (xr >= 0) & (xr < disparity.shape[1])
        bad = ~inside
        bad[inside] = ~vr[ys[inside], xr[inside]]
        disparity[ys[bad], xs[bad]] = np.nan
    return disparity


def make_backend(name: str, **options) -> DisparityBackend:
    """Build a disparity backend by name (``opencv``, ``sgm``)."""
    if name == "opencv":
        from .opencv import OpenCVSGBM, OpenCVSGBMConfig

        return OpenCVSGBM(OpenCVSGBMConfig(**options))
    if name == "sgm":
        from .sgm import SGM, SGMConfig

        return SGM(SGMConfig(**options))
    raise ConfigError(f"unknown disparity backend '{name}'; choose one of: opencv, sgm")
