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
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from .checks import check_fields, check_min
from .errors import ConfigError, InputError
from .rectify import RECTIFY_FOVS, Rectification, RectifiedPair, compute_rectification

log = logging.getLogger(__name__)

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


@dataclass(frozen=True)
class FeatureMatches:
    """Sub-pixel feature matches of a rectified pair.

    Attributes
    ----------
    left, right : (N, 2) float64, pixels of the rectified left / right image
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)

    def __len__(self) -> int:
        return len(self.left)

    @property
    def vertical_px(self) -> np.ndarray:
        """(N,) float64: vertical disparity ``y_left - y_right``, pixels (0 when rectified)."""
        return self.left[:, 1] - self.right[:, 1]


def match_features(pair: RectifiedPair, config: DriftConfig | None = None) -> FeatureMatches:
    """ORB matches between the rectified images, refined to sub-pixel by Lucas-Kanade.

    A match must lie within ``search_rows_px`` rows, have a disparity between
    ``-search_rows_px`` and half the image width, pass Lowe's ratio test among the
    candidates there, and survive a forward-backward Lucas-Kanade check.
    """
    cfg = config or DriftConfig()
    left, right = pair.left, pair.right
    orb = cv2.ORB_create(nfeatures=cfg.max_features)  # type: ignore[attr-defined]
    rect = pair.rectification
    kl, dl = orb.detectAndCompute(left, _feature_mask(rect.valid_left))
    kr, dr = orb.detectAndCompute(right, _feature_mask(rect.valid_right))
    empty = FeatureMatches(np.zeros((0, 2)), np.zeros((0, 2)))
    if dl is None or dr is None or len(kl) < 2 or len(kr) < 2:
        return empty
    # Candidates only where a rectified match can be: within the band of rows and a
    # plausible disparity. The ratio test then compares candidates of that region (3x
    # faster than matching everything with everything, and a repeated pattern elsewhere
    # in the image cannot veto a good match).
    w = left.shape[1]
    xyl = np.array([k.pt for k in kl], dtype=np.float32)
    xyr = np.array([k.pt for k in kr], dtype=np.float32)
    disp = xyl[:, None, 0] - xyr[None, :, 0]
    band = (
        (np.abs(xyl[:, None, 1] - xyr[None, :, 1]) <= cfg.search_rows_px)
        & (disp >= -cfg.search_rows_px)
        & (disp <= w / 2)
    )
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
    knn = matcher.knnMatch(dl, dr, k=2, mask=band.astype(np.uint8))
    # Mutual best within the region too: a repeated pattern (a checkerboard's corners)
    # offers many look-alikes in the same rows.
    back = {
        m[0].queryIdx: m[0].trainIdx for m in matcher.knnMatch(dr, dl, k=1, mask=band.T.astype(np.uint8)) if m
    }
    pairs = [
        m[0]
        for m in knn
        if len(m) == 2
        and m[0].distance < cfg.ratio * m[1].distance
        and back.get(m[0].trainIdx) == m[0].queryIdx
    ]
    if not pairs:
        return empty
    pl = xyl[[m.queryIdx for m in pairs]]
    pr = xyr[[m.trainIdx for m in pairs]]
    pr_fine, st_f = _lucas_kanade(left, right, pl, pr, cfg.lk_window_px)
    pl_back, st_b = _lucas_kanade(right, left, pr_fine, pl, cfg.lk_window_px)
    ok = (
        (st_f == 1)
        & (st_b == 1)
        & (np.linalg.norm(pl_back - pl, axis=1) <= cfg.fb_tolerance_px)
        & (np.linalg.norm(pr_fine - pr, axis=1) <= 3.0)  # LK may not wander off the ORB match
    )
    h = left.shape[0]
    inside = (pr_fine[:, 0] >= 0) & (pr_fine[:, 0] <= w - 1) & (pr_fine[:, 1] >= 0) & (pr_fine[:, 1] <= h - 1)
    ok &= inside
    return FeatureMatches(pl[ok].astype(np.float64), pr_fine[ok].astype(np.float64))


def _feature_mask(valid: np.ndarray | None) -> np.ndarray | None:
    """Where ORB may put a feature: pixels whose 31-px descriptor patch and LK window stay
    off the sourceless border of the rectified image (None: anywhere)."""
    if valid is None:
        return None
    k = np.ones((33, 33), np.uint8)
    return cv2.erode(valid.astype(np.uint8), k, borderType=cv2.BORDER_REPLICATE) * np.uint8(255)


def _lucas_kanade(
    a: np.ndarray, b: np.ndarray, pa: np.ndarray, pb_guess: np.ndarray, window_px: int
) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel positions in ``b`` of the points ``pa`` of ``a`` from the guesses ``pb_guess``.

    Returns ``(pb (N, 2) float32, status (N,) uint8)``.
    """
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.005)
    pb, status, _ = cv2.calcOpticalFlowPyrLK(
        a,
        b,
        pa,
        pb_guess.copy(),
        winSize=(window_px, window_px),
        maxLevel=1,
        criteria=criteria,
        flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
    )
    return np.asarray(pb, dtype=np.float32).reshape(-1, 2), np.asarray(status).ravel()


# --------------------------------------------------------------------------- rotation model


def _rect_intrinsics(rect: Rectification) -> tuple[float, float, float, float]:
    """``f, cx_left, cx_right, cy`` of the rectified pair, pixels."""
    return rect.focal_px, rect.cx, rect.cx + rect.doffs_px, rect.cy


def rays_from_matches(matches: FeatureMatches, rect: Rectification) -> tuple[np.ndarray, np.ndarray]:
    """Matches of ``rect``'s images -> rays of the *calibration's* rectified cameras.

    Returns
    -------
    left, right : (N, 3) float64
        ``(x, y, 1)`` rays of the rectified left camera and of the uncorrected rectified
        right camera (``rect.right_correction`` taken out), so that matches gathered under
        different corrections can be pooled.
    """
    f, cxl, cxr, cy = _rect_intrinsics(rect)
    n = len(matches)
    left = np.column_stack([(matches.left[:, 0] - cxl) / f, (matches.left[:, 1] - cy) / f, np.ones(n)])
    right = np.column_stack([(matches.right[:, 0] - cxr) / f, (matches.right[:, 1] - cy) / f, np.ones(n)])
    if rect.right_correction is not None:
        right = right @ rect.right_correction  # C^T r for each row r
        right /= right[:, 2:3]
    return left, right


def _rotate(rotvec: np.ndarray, rays: np.ndarray) -> np.ndarray:
    R, _ = cv2.Rodrigues(np.asarray(rotvec, dtype=np.float64).reshape(3, 1))
    return rays @ R.T


def vertical_residuals_px(
    rotvec: np.ndarray, left: np.ndarray, right: np.ndarray, focal_px: float
) -> np.ndarray:
    """(N,) float64: ``y_right - y_left`` in pixels after rotating the right rays by ``rotvec``."""
    q = _rotate(rotvec, right)
    return focal_px * (q[:, 1] / q[:, 2] - left[:, 1] / left[:, 2])


@dataclass(frozen=True)
class RightRotation:
    """The rotation of the rectified right camera that best removes vertical disparity.

    Attributes
    ----------
    rotvec_rad : (3,) float64
        Rodrigues vector of the correction, rectified right camera frame (x along the
        baseline, y down, z forward): ``right_correction = Rodrigues(rotvec_rad)``.
        Zero where a component was not significant.
    stderr_rad : (3,) float64
        Standard errors of the components (inf where not estimated).
    n_matches, n_inliers : int
    sigma_px : float
        Robust noise of the vertical disparity after the correction, pixels.
    rms_before_px, rms_after_px : float
        RMS vertical disparity of the inliers without and with the correction, pixels.
    significance : float
        Chi-square of the improvement, ``(SS_before - SS_after) / sigma^2``.
    """

    rotvec_rad: np.ndarray = field(repr=False)
    stderr_rad: np.ndarray = field(repr=False)
    n_matches: int
    n_inliers: int
    sigma_px: float
    rms_before_px: float
    rms_after_px: float
    significance: float

    @property
    def angle_deg(self) -> float:
        return math.degrees(float(np.linalg.norm(self.rotvec_rad)))


def estimate_right_rotation(
    left: np.ndarray,
    right: np.ndarray,
    focal_px: float,
    *,
    component_sigma: float = 3.0,
    estimate: tuple[bool, bool, bool] = (True, True, True),
) -> RightRotation | None:
    """Fit the rotation of the right rays that zeroes the vertical disparity.

    Parameters
    ----------
    left, right : (N, 3) float64
        Matched rays of the rectified left and (uncorrected) right cameras, see
        :func:`rays_from_matches`.
    focal_px : float
        Rectified focal length; residuals are measured in pixels.
    component_sigma : float
        Components smaller than this many standard errors are fixed at zero and the rest
        refitted (a weakly observed yaw must not add noise to depth).
    estimate : (3,) bool
        Which components (x, y, z) to estimate; the others are held at zero.

    Returns
    -------
    RightRotation, or None with fewer than 10 matches.

    Notes
    -----
    Robust: a Cauchy-weighted Gauss-Newton fit (scale 0.5 px) finds the inliers (within 4
    sigma and 1 px of the fit), then a plain least-squares fit on them gives the estimate
    and its covariance. Three parameters and an analytic Jacobian: about a millisecond for
    a few thousand matches.
    """
    n = len(left)
    if n < 10:
        return None
    free = np.array(estimate, dtype=bool)

    def fit(mask: np.ndarray, rows: np.ndarray, cauchy_px: float | None) -> np.ndarray:
        return _gauss_newton(left[rows], right[rows], focal_px, mask, cauchy_px)

    everyone = np.ones(n, dtype=bool)
    w = fit(free, everyone, 0.5) if free.any() else np.zeros(3)
    r = vertical_residuals_px(w, left, right, focal_px)
    sigma = max(MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r)))), 0.02)
    inl = np.abs(r) <= max(4.0 * sigma, 1.0)
    if inl.sum() < 10:
        return None
    stderr = np.full(3, np.inf)
    for _ in range(3):  # drop insignificant components, refit
        if not free.any():
            w = np.zeros(3)
            break
        w = fit(free, inl, None)
        r_in = vertical_residuals_px(w, left[inl], right[inl], focal_px)
        sigma = max(float(np.sqrt(np.mean(r_in**2))), 0.02)
        J = _jacobian(w, left[inl], right[inl], focal_px)[:, free]
        try:
            cov = sigma**2 * np.linalg.inv(J.T @ J)
        except np.linalg.LinAlgError:
            cov = np.full((int(free.sum()),) * 2, np.inf)
        stderr = np.full(3, np.inf)
        stderr[free] = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        weak = free & ~(np.abs(w) > component_sigma * stderr)
        if not weak.any():
            break
        free &= ~weak
        w[weak] = 0.0
    if not free.any():
        w = np.zeros(3)
    r0 = vertical_residuals_px(np.zeros(3), left[inl], right[inl], focal_px)
    r1 = vertical_residuals_px(w, left[inl], right[inl], focal_px)
    ss0, ss1 = float(np.sum(r0**2)), float(np.sum(r1**2))
    sigma = max(float(np.sqrt(ss1 / max(int(inl.sum()) - int(free.sum()), 1))), 0.02)
    return RightRotation(
        w,
        stderr,
        n,
        int(inl.sum()),
        sigma,
        float(np.sqrt(ss0 / inl.sum())),
        float(np.sqrt(ss1 / inl.sum())),
        (ss0 - ss1) / sigma**2,
    )


def _jacobian(w: np.ndarray, left: np.ndarray, right: np.ndarray, focal_px: float) -> np.ndarray:
    """(N, 3) Jacobian of :func:`vertical_residuals_px` w.r.t. a small extra rotation.

    With ``q = R(w) r`` and an extra rotation ``d``, ``q' = q + d x q``, so
    ``d(q_y / q_z) / dd = (-(1 + y^2), x y, x)`` with ``x, y = q_x / q_z, q_y / q_z`` (the
    tilt, yaw and roll signatures of the module docstring).
    """
    del left  # the residual's left term does not depend on the rotation
    q = _rotate(w, right)
    x, y = q[:, 0] / q[:, 2], q[:, 1] / q[:, 2]
    return focal_px * np.column_stack([-(1.0 + y * y), x * y, x])


def _gauss_newton(
    left: np.ndarray,
    right: np.ndarray,
    focal_px: float,
    free: np.ndarray,
    cauchy_px: float | None,
    iterations: int = 30,
) -> np.ndarray:
    """(3,) rotation vector minimising the (Cauchy-weighted) vertical residuals; components
    not in ``free`` stay zero."""
    w = np.zeros(3)
    for _ in range(iterations):
        r = vertical_residuals_px(w, left, right, focal_px)
        J = _jacobian(w, left, right, focal_px)[:, free]
        wt = np.ones_like(r) if cauchy_px is None else 1.0 / (1.0 + (r / cauchy_px) ** 2)
        A = J.T @ (J * wt[:, None])
        try:
            step = np.linalg.solve(A, -(J.T @ (wt * r)))
        except np.linalg.LinAlgError:
            break
        w[free] += step
        if np.max(np.abs(step)) < 1e-10:
            break
    return w


def rotation_effect_px(rotvec: np.ndarray, rect: Rectification, *, grid: int = 9) -> tuple[float, float]:
    """Worst vertical and horizontal displacement a right-camera rotation causes, pixels.

    The rotation moves every rectified right pixel; its vertical part is epipolar error,
    its horizontal part a disparity error (depth bias). Evaluated on a ``grid x grid``
    lattice over the image for points far away.
    """
    f, _, cxr, cy = _rect_intrinsics(rect)
    w, h = rect.image_size
    u, v = np.meshgrid(np.linspace(0, w - 1, grid), np.linspace(0, h - 1, grid))
    rays = np.column_stack([(u.ravel() - cxr) / f, (v.ravel() - cy) / f, np.ones(u.size)])
    q = _rotate(np.asarray(rotvec, dtype=np.float64), rays)
    dx = f * (q[:, 0] / q[:, 2] - rays[:, 0])
    dy = f * (q[:, 1] / q[:, 2] - rays[:, 1])
    return float(np.max(np.abs(dy))), float(np.max(np.abs(dx)))


# --------------------------------------------------------------------------- check


@dataclass(frozen=True)
class CalibrationCheck:
    """How well a pair fits its calibration (``stereo-terrain check-calib``).

    Attributes
    ----------
    n_matches : int
    median_px : float
        Median vertical disparity ``y_left - y_right`` of the matches, pixels.
    spread_px : float
        Robust spread (1.4826 x median absolute deviation) of it, pixels.
    p90_abs_px : float
        90th percentile of ``|y_left - y_right|``, pixels.
    rotation : RightRotation or None
        The fitted drift of the right camera (the correction that undoes it).
    vertical_error_px, disparity_error_px : float
        Worst vertical / horizontal (disparity) displacement over the image that the
        fitted drift causes, pixels.
    drift_px : float
        What the verdict is taken on: the largest of ``|median_px|``,
        ``vertical_error_px`` and ``disparity_error_px``.
    verdict : str
        ``ok`` (drift < ``ok_px``), ``degraded`` (< ``recalibrate_px``), ``recalibrate``,
        or ``unknown`` (fewer than ``min_matches`` matches).
    n_pairs : int
        Pairs the matches came from.
    yaw_confirmed : bool
        True when ``yaw_frames`` pairs agreed on a yaw, which was then estimated; else the
        yaw is held at zero. The yaw (turn about the image's vertical axis) biases every
        disparity by ``f * angle`` but shows in vertical disparity only as a second-order
        ``f * yaw * x * y`` term, which a lens-distortion residual can imitate in one view
        (0.2-0.9 deg on real scenes whose rectification is good): one pair cannot tell.
    """

    n_matches: int
    median_px: float
    spread_px: float
    p90_abs_px: float
    rotation: RightRotation | None
    vertical_error_px: float
    disparity_error_px: float
    drift_px: float
    verdict: str
    n_pairs: int = 1
    yaw_confirmed: bool = False


def check_calibration(
    pairs: RectifiedPair | Sequence[RectifiedPair], config: DriftConfig | None = None
) -> CalibrationCheck:
    """Match features in one or more rectified pairs and judge how far the rig has drifted.

    Several pairs (different views from the same rig) pool their matches and can confirm
    a yaw (see :class:`DriftConfig` ``yaw_frames``); one pair cannot.
    """
    cfg = config or DriftConfig()
    group = [pairs] if isinstance(pairs, RectifiedPair) else list(pairs)
    if not group:
        raise InputError("check_calibration needs at least one rectified pair")
    return check_matches([match_features(p, cfg) for p in group], group[0].rectification, cfg)


def check_matches(
    matches: FeatureMatches | Sequence[FeatureMatches], rect: Rectification, config: DriftConfig | None = None
) -> CalibrationCheck:
    """:func:`check_calibration` from matches already found (one group per pair)."""
    cfg = config or DriftConfig()
    groups = [matches] if isinstance(matches, FeatureMatches) else list(matches)
    nan = float("nan")
    n = sum(len(g) for g in groups)
    if n == 0:
        return CalibrationCheck(0, nan, nan, nan, None, nan, nan, nan, "unknown", len(groups), False)
    rays = [rays_from_matches(g, rect) for g in groups]
    left = np.concatenate([a for a, _ in rays])
    right = np.concatenate([b for _, b in rays])
    dy = np.concatenate([g.vertical_px for g in groups])
    med = float(np.median(dy))
    spread = MAD_TO_SIGMA * float(np.median(np.abs(dy - med)))
    p90 = float(np.percentile(np.abs(dy), 90))
    views = [_view_yaw(a, b, rect.focal_px) for a, b in rays if len(a) >= cfg.min_matches]
    yaw_ok = yaws_agree([v for v in views if v is not None], cfg)
    rot = None
    if n >= cfg.min_matches:
        rot = estimate_right_rotation(
            left, right, rect.focal_px, component_sigma=cfg.component_sigma, estimate=(True, yaw_ok, True)
        )
    if rot is None:
        return CalibrationCheck(n, med, spread, p90, None, nan, nan, nan, "unknown", len(groups), False)
    vert, horiz = rotation_effect_px(rot.rotvec_rad, rect)
    drift = max(abs(med), vert, horiz)
    verdict = "ok" if drift < cfg.ok_px else "degraded" if drift < cfg.recalibrate_px else "recalibrate"
    return CalibrationCheck(n, med, spread, p90, rot, vert, horiz, drift, verdict, len(groups), yaw_ok)


def _view_yaw(left: np.ndarray, right: np.ndarray, focal_px: float) -> tuple[float, float] | None:
    """One view's own yaw estimate and its standard error (radians), all components free."""
    own = estimate_right_rotation(left, right, focal_px, component_sigma=0.0)
    if own is None or not np.isfinite(own.stderr_rad[1]):
        return None
    return float(own.rotvec_rad[1]), float(own.stderr_rad[1])


def yaws_agree(views: Sequence[tuple[float, float]], config: DriftConfig) -> bool:
    """Do several views agree on a significant yaw of the right camera?

    Parameters
    ----------
    views : sequence of (yaw, standard error), radians
        Each view's own estimate (:func:`estimate_right_rotation` with every component
        free).
    config : DriftConfig
        ``yaw_frames``, ``component_sigma``, ``yaw_agreement``.

    Returns
    -------
    bool
        True when at least ``yaw_frames`` views are each sure of a yaw (beyond
        ``component_sigma`` standard errors) and those all have one sign, the weighted mean
        of all views is larger than ``min_yaw_deg`` and than ``component_sigma`` of its
        standard errors, and their chi-square about it is within ``yaw_agreement`` times
        its 99.9 % quantile.
        A camera that turned has the same yaw in every view; a lens-distortion residual
        that imitates one gives views that disagree far beyond their errors (on the three
        OAK-D Lite scenes: +0.55, +0.54 and -0.26 deg, each +-0.05 deg or better).
    """
    if len(views) < config.yaw_frames:
        return False
    y = np.array([v for v, _ in views])
    se = np.maximum(np.array([e for _, e in views]), 1e-9)
    sure = np.abs(y) > config.component_sigma * se
    if sure.sum() < config.yaw_frames or not (np.all(y[sure] > 0) or np.all(y[sure] < 0)):
        return False
    w = 1.0 / se**2
    mean = float(np.sum(w * y) / np.sum(w))
    if abs(mean) * math.sqrt(float(np.sum(w))) <= config.component_sigma:
        return False
    if math.degrees(abs(mean)) < config.min_yaw_deg:
        return False
    q = float(np.sum(w * (y - mean) ** 2))
    from scipy.stats import chi2  # here: scipy.stats costs ~0.9 s and ~40 MB at import (issue 13)

    return q <= config.yaw_agreement * float(chi2.ppf(0.999, len(views) - 1))


# --------------------------------------------------------------------------- online correction


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
