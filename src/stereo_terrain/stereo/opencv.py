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
        P1 for 1-px disparity changes, P2 for larger ones), times ``width /
        penalty_width_px`` when that is set. Wood grain and plank gaps are horizontal
        texture, which a horizontal baseline cannot match row by row: with these (OpenCV's
        usual 8 and 32) each row of a plank face picks its own match, and 24 and 200 hold
        the face together (issue 11; README, "Wooden stairs").
    penalty_width_px : int
        When > 0, the penalties are scaled by ``image width / penalty_width_px``. A face
        spans half as many pixels in an image half as wide, so the matching cost its pixels
        add up along a path halves while a jump's penalty does not: unscaled, the same
        penalties smooth a 320 px image twice as hard as a 640 px one. 0 (default): not
        scaled.
    uniqueness_ratio_pct : int
        Best cost must beat the second best by this margin (percent).
    speckle_window_px, speckle_range_px : int
        Speckle filter: components smaller than the window with disparity spread above the
        range are invalidated.
    mode : str
        ``sgbm`` (5 paths), ``sgbm_3way`` (fast), ``hh`` (full 8 paths), ``hh4``.
    match_exposure : bool
        Map the right image's grey levels onto the left's (gain and offset from the two
        images' means and standard deviations over the pixels with a source) before
        matching (default False; see :func:`match_exposure`).
    downsample : int
        1 (default): match the pair as given. 2: match it at half size (``cv2.pyrDown``,
        half the disparity range: an eighth of the work) and give the disparity at full
        size (doubled, each half-size pixel's value on its 2x2 pixels, within ``[0, n)``).
        The smoothness reaches twice as far across a texture-poor face, at half the
        sub-pixel precision; ``penalty_width_px`` scales the penalties to the half-size
        width as to any other. The pipeline uses it only as a last rematch
        (``PipelineConfig.rematch_coarse``).
    """

    block_size_px: int = 5
    p1_per_px: int = 8
    p2_per_px: int = 32
    penalty_width_px: int = 0
    uniqueness_ratio_pct: int = 10
    speckle_window_px: int = 100
    speckle_range_px: int = 2
    disp12_max_diff_px: int = 1
    pre_filter_cap: int = 63
    mode: str = "sgbm_3way"
    match_exposure: bool = False
    downsample: int = 1

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
            "penalty_width_px",
        )
        if self.block_size_px < 1 or self.block_size_px % 2 == 0 or self.block_size_px > 11:
            raise ConfigError(f"block_size_px must be odd in [1, 11], got {self.block_size_px}")
        if not 0 < self.p1_per_px < self.p2_per_px:
            raise ConfigError(f"need 0 < p1_per_px < p2_per_px, got {self.p1_per_px}, {self.p2_per_px}")
        if self.mode not in _MODES:
            raise ConfigError(f"unknown SGBM mode '{self.mode}'; choose one of {sorted(_MODES)}")
        if self.downsample not in (1, 2) or isinstance(self.downsample, bool):
            raise ConfigError(f"downsample must be 1 or 2, got {self.downsample!r}")


def create_sgbm(
    config: OpenCVSGBMConfig,
    num_disparities: int,
    *,
    mode: str | None = None,
    width: int | None = None,
) -> cv2.StereoSGBM:
    """The ``cv2.StereoSGBM`` matcher of ``config`` for disparities ``[0, num_disparities)``
    and images ``width`` pixels wide (None: the penalties as given); ``mode`` overrides
    ``config.mode`` (the bench times OpenCV's 3-way mode alone with it)."""
    c = config
    scale = float(c.block_size_px * c.block_size_px)
    if width is not None and c.penalty_width_px > 0:
        scale *= width / c.penalty_width_px
    p1 = max(1, round(c.p1_per_px * scale))
    return cv2.StereoSGBM.create(
        minDisparity=0,
        numDisparities=num_disparities,
        blockSize=c.block_size_px,
        P1=p1,
        P2=max(p1 + 1, round(c.p2_per_px * scale)),
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
        self._matchers: dict[tuple[int, int], cv2.StereoSGBM] = {}

    def _matcher(self, n: int, width: int) -> cv2.StereoSGBM:
        if (n, width) not in self._matchers:
            self._matchers[n, width] = create_sgbm(self.config, n, width=width)
        return self._matchers[n, width]

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
        n = check_max_disparity(max_disparity_px, pair.left.shape[1])
        rect = pair.rectification
        right = pair.right
        if self.config.match_exposure:
            right = match_exposure(pair.left, right, rect.valid_left, rect.valid_right)
        if self.config.downsample == 2:
            raw = self._half_size(pair.left, right, n)
        else:
            raw = self._matcher(n, pair.left.shape[1]).compute(pair.left, right)
        # Scaled, OpenCV's invalid value and the sourceless pixels NaN
        # (invalidate_sourceless) in one compiled pass, the same bits (issue 13).
        disp = disparity_from_fixed_point(
            raw,
            _NO_MASK if rect.valid_left is None else rect.valid_left,
            _NO_MASK if rect.valid_right is None else rect.valid_right,
        )
        return DisparityMap(disp, n, rect, None, self.name)

    def _half_size(self, left: np.ndarray, right: np.ndarray, n: int) -> np.ndarray:
        """OpenCV's fixed-point disparity of the full-size pair, matched at half size: the
        half-size values doubled, each on its 2x2 full-size pixels (invalid stays < 0)."""
        h, w = left.shape
        small_left, small_right = cv2.pyrDown(left), cv2.pyrDown(right)
        n_small = max(16, -(-n // 32) * 16)  # half the range, a multiple of 16
        if n_small >= small_left.shape[1]:
            # Too narrow to match at half size (OpenCV needs the range below the width):
            # no disparity, as where nothing matches (a 32-pixel-wide image).
            return np.full((h, w), -1, np.int16)
        raw = self._matcher(n_small, small_left.shape[1]).compute(small_left, small_right)
        # Doubled; invalid where the half-size range (rounded up to 16) went past n.
        doubled = np.where((raw >= 0) & (raw < n * 8), raw * 2, -1).astype(np.int16)
        return cv2.resize(doubled, (w, h), interpolation=cv2.INTER_NEAREST)


def match_exposure(
    left: np.ndarray,
    right: np.ndarray,
    valid_left: np.ndarray | None = None,
    valid_right: np.ndarray | None = None,
) -> np.ndarray:
    """The right image with the left one's exposure: ``right * gain + offset`` such that its
    mean and standard deviation (over the pixels with a source) are the left image's.

    Two webcams expose on their own: a right image 20 % brighter changes every matching
    cost (OpenCV's cost adds the intensity difference to that of the x derivatives, and
    both scale with the gain), and on faces whose only texture is weak wood grain the
    wrong match then wins. Both cameras see mostly the same scene, so the images' global
    statistics give the gain and offset.

    Parameters
    ----------
    left, right : (H, W) uint8
        Rectified images.
    valid_left, valid_right : (H, W) bool or None
        Pixels with a raw source (others are not counted).

    Returns
    -------
    (H, W) uint8, a new array (``right`` itself when either image is flat).
    """
    ml, sl = cv2.meanStdDev(left, mask=_mask(valid_left, left.shape))
    mr, sr = cv2.meanStdDev(right, mask=_mask(valid_right, right.shape))
    if not (sl[0, 0] > 1.0 and sr[0, 0] > 1.0):
        return right
    gain = float(sl[0, 0] / sr[0, 0])
    grey = np.arange(256, dtype=np.float64) * gain + float(ml[0, 0] - gain * mr[0, 0])
    return cv2.LUT(right, np.clip(np.rint(grey), 0, 255).astype(np.uint8))


def _mask(valid: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray | None:
    """``valid`` as an OpenCV mask, or None when it does not fit the image."""
    return None if valid is None or valid.shape != shape else valid.view(np.uint8)
