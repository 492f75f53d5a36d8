"""OpenCV StereoSGBM behind the :class:`DisparityBackend` interface."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..rectify import RectifiedPair
from . import DisparityMap, check_max_disparity
from ._disparity_kernels import disparity_from_fixed_point

#: An empty mask: the kernel applies none.
_NO_MASK = np.zeros((0, 0), dtype=bool)

_MODES = {
    "sgbm": cv2.STEREO_SGBM_MODE_SGBM,
    "hh": cv2.STEREO_SGBM_MODE_HH,
    "sgbm_3way": cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    "hh4": cv2.STEREO_SGBM_MODE_HH4,
}


@dataclass(frozen=True)
class OpenCVSGBMConfig:
    """Parameters of OpenCV's semi-global block matching.

    Attributes
    ----------
    block_size_px : int
        Odd matching block size (3-11).
    p1_per_px, p2_per_px : int
        SGM penalties per block pixel; OpenCV gets ``P = p * block_size**2`` (Hirschmüller's
        P1 for 1-px disparity changes, P2 for larger ones).
    uniqueness_ratio_pct : int
        Best cost must beat the second best by this margin (percent).
    speckle_window_px, speckle_range_px : int
        Speckle filter: components smaller than the window with disparity spread above the
        range are invalidated.
    mode : str
        ``sgbm`` (5 paths), ``sgbm_3way`` (fast), ``hh`` (full 8 paths), ``hh4``.
    """

    block_size_px: int = 5
    p1_per_px: int = 8
    p2_per_px: int = 32
    uniqueness_ratio_pct: int = 10
    speckle_window_px: int = 100
    speckle_range_px: int = 2
    disp12_max_diff_px: int = 1
    pre_filter_cap: int = 63
    mode: str = "sgbm_3way"

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(
            self,
            0,
            "uniqueness_ratio_pct",
            "speckle_window_px",
            "speckle_range_px",
            "disp12_max_diff_px",
            "pre_filter_cap",
        )
        if self.block_size_px < 1 or self.block_size_px % 2 == 0 or self.block_size_px > 11:
            raise ConfigError(f"block_size_px must be odd in [1, 11], got {self.block_size_px}")
        if not 0 < self.p1_per_px < self.p2_per_px:
            raise ConfigError(f"need 0 < p1_per_px < p2_per_px, got {self.p1_per_px}, {self.p2_per_px}")
        if self.mode not in _MODES:
            raise ConfigError(f"unknown SGBM mode '{self.mode}'; choose one of {sorted(_MODES)}")


def create_sgbm(config: OpenCVSGBMConfig, num_disparities: int, *, mode: str | None = None) -> cv2.StereoSGBM:
    """The ``cv2.StereoSGBM`` matcher of ``config`` for disparities ``[0, num_disparities)``
    (``mode`` overrides ``config.mode``; the bench times OpenCV's 3-way mode alone with it)."""
    c = config
    area = c.block_size_px * c.block_size_px
    return cv2.StereoSGBM.create(
        minDisparity=0,
        numDisparities=num_disparities,
        blockSize=c.block_size_px,
        P1=c.p1_per_px * area,
        P2=c.p2_per_px * area,
        disp12MaxDiff=c.disp12_max_diff_px,
        preFilterCap=c.pre_filter_cap,
        uniquenessRatio=c.uniqueness_ratio_pct,
        speckleWindowSize=c.speckle_window_px,
        speckleRange=c.speckle_range_px,
        mode=_MODES[mode or c.mode],
    )


class OpenCVSGBM:
    """Disparity with ``cv2.StereoSGBM``; invalid pixels become NaN."""

    name = "opencv"

    def __init__(self, config: OpenCVSGBMConfig | None = None) -> None:
        self.config = config or OpenCVSGBMConfig()
        self._matchers: dict[int, cv2.StereoSGBM] = {}

    def _matcher(self, n: int) -> cv2.StereoSGBM:
        if n not in self._matchers:
            self._matchers[n] = create_sgbm(self.config, n)
        return self._matchers[n]

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
        n = check_max_disparity(max_disparity_px, pair.left.shape[1])
        raw = self._matcher(n).compute(pair.left, pair.right)
        rect = pair.rectification
        # Scaled, OpenCV's invalid value and the sourceless pixels NaN
        # (invalidate_sourceless) in one compiled pass, the same bits (issue 13).
        disp = disparity_from_fixed_point(
            raw,
            _NO_MASK if rect.valid_left is None else rect.valid_left,
            _NO_MASK if rect.valid_right is None else rect.valid_right,
        )
        return DisparityMap(disp, n, rect, None, self.name)
