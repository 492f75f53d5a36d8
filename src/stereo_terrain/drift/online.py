"""The online correction: :class:`OnlineRectifier` re-estimates the right camera's rotation
over recent frames and corrects the rectification when that lowers the epipolar error."""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..rectify import RECTIFY_FOVS, Rectification, RectifiedPair, compute_rectification
from .check import _view_yaw, yaws_agree
from .config import MAD_TO_SIGMA, DriftConfig
from .matches import match_features
from .rotation import estimate_right_rotation, rays_from_matches, rotation_effect_px, vertical_residuals_px

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CorrectionUpdate:
    """What one frame did to the online correction.

    Attributes
    ----------
    rectification : Rectification
        The rectification to use from this frame on.
    changed : bool
        True when it differs from the one the frame was rectified with.
    n_matches : int
        Matches found in this frame.
    epipolar_rms_px : float
        RMS vertical disparity of this frame's inlier matches under the rectification
        returned (NaN without matches).
    reason : str
        Why the correction was (not) changed.
    """

    rectification: Rectification
    changed: bool
    n_matches: int
    epipolar_rms_px: float
    reason: str


class OnlineRectifier:
    """Keeps the matches of recent frames and corrects the rectification from them.

    Parameters
    ----------
    base : Rectification
        The calibration's rectification (no correction); it must be of a raw
        (unrectified) calibration.
    config : DriftConfig, optional

    Notes
    -----
    Every ``every_frames``-th frame: match the pair rectified with the current correction, store its matches
    as rays of the *uncorrected* rectified cameras, fit the rotation over the window, and
    adopt it when (1) it is significant (``min_significance``), (2) no larger than
    ``max_correction_deg``, and (3) it lowers the epipolar error of the current frame's
    matches below that of the current correction. The third condition is the guard: a
    correction that does not make the current frame's rows line up better is never taken,
    so a good calibration is left alone. The window is cleared when the current frame
    disagrees with the current correction by more than ``ok_px`` (the rig moved again).
    """

    def __init__(self, base: Rectification, config: DriftConfig | None = None) -> None:
        if base.calibration.rectified or base.R2 is None:
            raise InputError(
                "online rectification correction needs the raw calibration (K, D, R, T) of the "
                "cameras; this calibration is of images rectified elsewhere"
            )
        self.config = config or DriftConfig()
        self.base = base
        self.current = base
        # Per matched frame: left rays, right rays, and that frame's own yaw and its
        # standard error (rad; None when it has none).
        self._window: deque[tuple[np.ndarray, np.ndarray, tuple[float, float] | None]] = deque(
            maxlen=self.config.window_frames
        )
        self._frames = 0

    @property
    def correction_rotvec_rad(self) -> np.ndarray:
        """(3,) float64: the correction now applied (rectified right camera frame)."""
        if self.current.right_correction is None:
            return np.zeros(3)
        rv, _ = cv2.Rodrigues(self.current.right_correction)
        return rv.ravel()

    def reset(self) -> None:
        """Forget the window and the correction."""
        self._window.clear()
        self.current = self.base
        self._frames = 0

    def update(self, pair: RectifiedPair) -> CorrectionUpdate:
        """Add a pair rectified with :attr:`current`; return the rectification to use."""
        cfg = self.config
        self._frames += 1
        if (self._frames - 1) % cfg.every_frames:
            return CorrectionUpdate(self.current, False, 0, float("nan"), "not matched (every_frames)")
        matches = match_features(pair, cfg)
        n = len(matches)
        if n < cfg.min_matches:
            return CorrectionUpdate(self.current, False, n, float("nan"), f"too few matches ({n})")
        left, right = rays_from_matches(matches, pair.rectification)
        f = self.base.focal_px
        now = self.correction_rotvec_rad
        r_now = vertical_residuals_px(now, left, right, f)
        if abs(float(np.median(r_now))) > cfg.ok_px and self._window:
            self._window.clear()  # the rig moved again: old matches describe another rig
        self._window.append((left, right, _view_yaw(left, right, f)))
        L = np.concatenate([a for a, _, _ in self._window])
        R = np.concatenate([b for _, b, _ in self._window])
        yaw_ok = yaws_agree([v for _, _, v in self._window if v is not None], cfg)
        rot = estimate_right_rotation(
            L, R, f, component_sigma=cfg.component_sigma, estimate=(True, yaw_ok, True)
        )
        rms_now = _inlier_rms(r_now)
        if rot is None:
            return CorrectionUpdate(self.current, False, n, rms_now, "no estimate")
        cand = rot.rotvec_rad
        if rot.significance < cfg.min_significance:
            cand = np.zeros(3)  # nothing significant: the calibration itself is the best guess
        if math.degrees(float(np.linalg.norm(cand))) > cfg.max_correction_deg:
            return CorrectionUpdate(
                self.current,
                False,
                n,
                rms_now,
                f"drift {rot.angle_deg:.2f} deg is too large to correct; recalibrate",
            )
        if max(rotation_effect_px(_compose(cand, -now), self.base)) <= cfg.update_tolerance_px:
            return CorrectionUpdate(self.current, False, n, rms_now, "unchanged")
        rms_cand = _inlier_rms(vertical_residuals_px(cand, left, right, f), like=r_now)
        if not rms_cand < rms_now:
            return CorrectionUpdate(
                self.current, False, n, rms_now, "guard: no lower epipolar error on this frame"
            )
        if np.any(cand):
            R_corr, _ = cv2.Rodrigues(cand.reshape(3, 1))
            self.current = compute_rectification(
                self.base.calibration, fov=_same_fov(self.base), right_correction=R_corr
            )
        else:
            self.current = self.base
        log.info(
            "rectification corrected: right camera rotvec %s deg, epipolar RMS %.3f -> %.3f px",
            np.round(np.degrees(cand), 4).tolist(),
            rms_now,
            rms_cand,
        )
        return CorrectionUpdate(self.current, True, n, rms_cand, "corrected")


def _same_fov(rect: Rectification) -> str:
    """The ``fov`` that rebuilds ``rect``'s rectified cameras (an explicit alpha of 0 is
    ``valid``'s; other alphas are rare and rebuilt as ``valid`` too)."""
    return rect.fov if rect.fov in RECTIFY_FOVS else "valid"


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation vector of ``Rodrigues(a) @ Rodrigues(b)``."""
    Ra, _ = cv2.Rodrigues(np.asarray(a, dtype=np.float64).reshape(3, 1))
    Rb, _ = cv2.Rodrigues(np.asarray(b, dtype=np.float64).reshape(3, 1))
    rv, _ = cv2.Rodrigues(Ra @ Rb)
    return rv.ravel()


def _inlier_rms(residuals: np.ndarray, like: np.ndarray | None = None) -> float:
    """RMS of residuals over the inliers of ``like`` (default: of ``residuals``), pixels.

    Inliers are within ``max(1 px, 4 sigma)`` of the median of ``like``; using the same
    set for two candidates compares them on equal terms.
    """
    ref = residuals if like is None else like
    med = float(np.median(ref))
    sigma = MAD_TO_SIGMA * float(np.median(np.abs(ref - med)))
    inl = np.abs(ref - med) <= max(1.0, 4.0 * sigma)
    if not inl.any():
        return float("nan")
    return float(np.sqrt(np.mean(residuals[inl] ** 2)))
