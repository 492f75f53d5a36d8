"""The drift stage's settings (:class:`DriftConfig`) and the constants its parts share."""

from __future__ import annotations

from dataclasses import dataclass

from ..checks import check_fields, check_min
from ..errors import ConfigError

#: Robust scale: standard deviation of a normal distribution from its median absolute deviation.
MAD_TO_SIGMA = 1.4826

VERDICTS = ("ok", "degraded", "recalibrate", "unknown")


@dataclass(frozen=True)
class DriftConfig:
    """Feature matching, drift thresholds and the online correction.

    Attributes
    ----------
    online : bool
        Correct the rectification online in the pipeline (off by default: a frame that is
        matched costs about 15-20 ms more at 640x480, and it needs texture in view).
    every_frames : int
        The online correction matches one frame in this many (the first always): a rig
        drifts rarely and the window pools the evidence, so most frames need not pay.
    max_features : int
        ORB features detected in each rectified image.
    ratio : float
        Lowe's ratio test: best Hamming distance < ``ratio`` x second best.
    search_rows_px : float
        Largest vertical disparity a match may have, pixels (1.5 deg about the baseline
        at f = 550 px is 14 px).
    lk_window_px : int
        Lucas-Kanade window for the sub-pixel refinement, pixels (odd).
    fb_tolerance_px : float
        Largest forward-backward Lucas-Kanade disagreement kept, pixels.
    min_matches : int
        Fewer matches give verdict ``unknown`` and no correction.
    ok_px, recalibrate_px : float
        Verdict thresholds on the drift error (the largest of the median vertical
        disparity and the worst vertical and horizontal displacement over the image that
        the fitted rotation causes, see :class:`CalibrationCheck`), pixels. Below
        ``ok_px`` is ``ok`` (SGM with a 5-pixel block loses nothing measurable); up to
        ``recalibrate_px`` is ``degraded`` (depth bias of a few per cent at 1.5 m: correct
        online or recalibrate soon); above is ``recalibrate``.
    window_frames : int
        Matched frames whose matches the online estimate pools.
    min_significance : float
        Chi-square of the epipolar improvement (residual sum of squares over the noise
        variance, 3 degrees of freedom) a correction must reach; 25 makes a false
        correction of a perfect rig rarer than 1 in 50 000 under Gaussian noise.
    component_sigma : float
        A rotation component is kept only when larger than this many standard errors.
    yaw_frames : int
        The yaw (y) component is estimated only when at least this many views (matched
        frames of the window, or pairs given to the check) agree on it, see
        :func:`yaws_agree`. A true yaw of the camera is the same in every view; a
        lens-distortion residual that imitates one changes with the scene.
    min_yaw_deg : float
        A yaw smaller than this is not estimated even when the views agree (about three
        standard errors of one view's yaw on a textured 640x480 scene). The agreement test
        is what keeps false yaws out: on the real pairs of a well-calibrated rig (the
        OpenCV chessboard set with its own calibration) and on the OAK-D Lite scenes it
        confirms none even with no floor; an earlier, looser test let the chessboard
        views agree on 0.09 deg, whose correction made the triangulated 25 mm squares
        0.6 % wrong instead of 0.1 %.
    yaw_agreement : float
        Slack on the agreement test: the per-view yaws' chi-square about their weighted
        mean may reach this many times its 99.9 % quantile.
    max_correction_deg : float
        Larger rotations are not corrected online (the rig needs a checkerboard).
    update_tolerance_px : float
        The correction is changed only when the change moves some pixel of the rectified
        right image by more than this (worst over the image), pixels: smaller changes do
        not matter to the disparity and would only cost a map rebuild.
    """

    online: bool = False
    every_frames: int = 4
    max_features: int = 1500
    ratio: float = 0.8
    search_rows_px: float = 16.0
    lk_window_px: int = 15
    fb_tolerance_px: float = 0.2
    min_matches: int = 40
    ok_px: float = 0.5
    recalibrate_px: float = 1.5
    window_frames: int = 8
    min_significance: float = 25.0
    component_sigma: float = 3.0
    yaw_frames: int = 3
    min_yaw_deg: float = 0.05
    yaw_agreement: float = 1.0
    max_correction_deg: float = 3.0
    update_tolerance_px: float = 0.1

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "every_frames", "max_features", "min_matches", "window_frames", "yaw_frames")
        check_min(self, 0.0, "yaw_agreement", "min_yaw_deg")
        if not (3 <= self.lk_window_px <= 101 and self.lk_window_px % 2 == 1):
            raise ConfigError(
                f"DriftConfig.lk_window_px must be an odd number from 3 to 101, got {self.lk_window_px}"
            )
        check_min(self, 0.0, "min_significance", "component_sigma", "update_tolerance_px")
        if not 0.0 < self.ratio <= 1.0:
            raise ConfigError(f"DriftConfig.ratio must be in (0, 1], got {self.ratio}")
        for name in ("search_rows_px", "fb_tolerance_px", "ok_px", "max_correction_deg"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"DriftConfig.{name} must be > 0, got {getattr(self, name)}")
        if not self.recalibrate_px > self.ok_px:
            raise ConfigError(
                f"DriftConfig.recalibrate_px ({self.recalibrate_px}) must exceed ok_px ({self.ok_px})"
            )
