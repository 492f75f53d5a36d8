"""Stage 1b: how far the rig has drifted from its calibration, and the online correction.

The paper's main limitation (Section 6): "as soon as the cameras moved slightly from the
position they were calibrated in, the algorithms would return poor reconstructions". Two
cheap webcams on a trotting robot turn a little in their mounts. This module measures that
drift from the images themselves and undoes it:

* :func:`match_features` finds ORB features in the rectified left image, matches them in
  the rectified right one (ratio test, a band of rows) and refines the right position to
  sub-pixel with Lucas-Kanade (forward-backward checked). ORB alone gives whole pixels,
  too coarse for tenths of a pixel.
* The *vertical disparity* ``y_left - y_right`` of the matches is zero for a rig that
  still fits its calibration.
* :func:`estimate_right_rotation` fits the small rotation of the (rectified) right camera
  that explains the vertical disparities. A rotation of the right camera about its own
  centre leaves the baseline, hence depth and every frame, as calibrated; it is what a
  knock to a camera mostly is. A vertical shift of the right image (principal point) is,
  to first order, a rotation about the baseline (x) axis and is absorbed by it.
  The rotation about the vertical (y) axis -- the one that biases every disparity by
  ``f * angle`` and ruins depth -- shows in the vertical disparities only through a
  second-order term ``f * w_y * x * y``. That term is measurable with sub-pixel matches
  spread over the image, but in a single real view a lens-distortion residual imitates
  it (0.2-0.9 deg of apparent yaw on Middlebury and OAK-D scenes whose rectification is
  good). So the yaw is estimated only when several views agree on it (:func:`yaws_agree`),
  and every component only where statistically significant.
* :func:`check_calibration` turns that into a verdict with documented pixel thresholds.
* :class:`OnlineRectifier` keeps the matches of recent frames, re-estimates the rotation
  and corrects the rectification (``compute_rectification(..., right_correction=...)``),
  guarded by the epipolar error: a correction is adopted only when it is significant over
  the window *and* lowers the epipolar error of the current frame, so a good calibration
  is left alone.

The package's parts, data flowing one way:

* ``config.py``: :class:`DriftConfig` and the shared constants;
* ``matches.py``: :class:`FeatureMatches`, :func:`match_features`;
* ``rotation.py``: the right camera's rotation from the matches (:class:`RightRotation`);
* ``check.py``: the verdict (:class:`CalibrationCheck`, :func:`yaws_agree`);
* ``online.py``: the online correction (:class:`OnlineRectifier`).
"""

from .check import CalibrationCheck, check_calibration, check_matches, yaws_agree
from .config import MAD_TO_SIGMA, VERDICTS, DriftConfig
from .matches import FeatureMatches, match_features
from .online import CorrectionUpdate, OnlineRectifier
from .rotation import (
    RightRotation,
    estimate_right_rotation,
    rays_from_matches,
    rotation_effect_px,
    vertical_residuals_px,
)

__all__ = [
    "MAD_TO_SIGMA",
    "VERDICTS",
    "CalibrationCheck",
    "CorrectionUpdate",
    "DriftConfig",
    "FeatureMatches",
    "OnlineRectifier",
    "RightRotation",
    "check_calibration",
    "check_matches",
    "estimate_right_rotation",
    "match_features",
    "rays_from_matches",
    "rotation_effect_px",
    "vertical_residuals_px",
    "yaws_agree",
]
