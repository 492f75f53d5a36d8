"""The verdict on a rig (``stereo-terrain check-calib``): :func:`check_calibration`, and
when views agree on a yaw (:func:`yaws_agree`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..rectify import Rectification, RectifiedPair
from .config import MAD_TO_SIGMA, DriftConfig
from .matches import FeatureMatches, match_features
from .rotation import RightRotation, estimate_right_rotation, rays_from_matches, rotation_effect_px


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
