"""Up from the vertical vanishing point (:func:`up_from_vertical_lines`), and combined
with the planes' up (:func:`combine_with_lines`)."""

from __future__ import annotations

import math

import numpy as np

from ...errors import ConfigError
from ...rectify import Rectification
from ..config import GravityEstimate
from ..geometry import CAMERA_UP, angle_deg
from .config import VerticalLinesConfig
from .segments import _tilt_deg, line_segments, normalised_ends, unit_rows


def up_from_vertical_lines(
    image: np.ndarray,
    rectification: Rectification,
    config: VerticalLinesConfig | None = None,
    *,
    prior_cone_deg: float = 45.0,
    segments: np.ndarray | None = None,
) -> GravityEstimate:
    """Up in the rectified left camera from the vanishing point of the image's vertical lines.

    Parameters
    ----------
    image : (H, W) uint8
        The rectified left image.
    rectification : Rectification
        Its intrinsics (``focal_px``, ``cx``, ``cy``) and valid region (``valid_left``).
    config : VerticalLinesConfig
    prior_cone_deg : float
        The weak prior: up lies within this angle of the camera's up (-y).
    segments : (N, 4) array, optional
        :func:`line_segments` of ``image`` at ``config.detect_scale``, when already found.

    Returns
    -------
    GravityEstimate in ``camera_rect``; ``vertical_fraction`` is the share of the candidate
    segments that support the vanishing point. ``ok=False`` (with a reason) when the lines
    do not fix up.
    """
    config = config or VerticalLinesConfig()
    frame = "camera_rect"

    def failed(reason: str, fraction: float = 0.0) -> GravityEstimate:
        return GravityEstimate(np.full(3, np.nan), frame, math.inf, False, 0.0, fraction, reason)

    s = line_segments(image, rectification, config, config.detect_scale) if segments is None else segments
    s = s[_tilt_deg(s) <= config.max_tilt_deg]
    d = s[:, 2:] - s[:, :2]
    n = len(s)
    if n < config.min_inliers:
        return failed(f"{n} near-vertical line segment(s) in the image (need {config.min_inliers})")
    # Normalised image coordinates: the vanishing point is then up's direction itself.
    p1, p2 = normalised_ends(s, rectification)
    lines = np.cross(p1, p2)
    lines /= np.linalg.norm(lines[:, :2], axis=1, keepdims=True)
    mid = (p1 + p2) / 2.0
    direction = unit_rows((p2 - p1)[:, :2])
    length = np.hypot(d[:, 0], d[:, 1])
    thr = math.radians(config.inlier_deg)

    def residual(v: np.ndarray) -> np.ndarray:
        """Angle between each segment and the line from its midpoint to ``v`` (or to each
        row of ``v``, shape ``(H, 3)``: then ``(H, N)``), radians."""
        to = v[..., None, :2] - mid[:, :2] * v[..., None, 2:3]
        to /= np.linalg.norm(to, axis=-1, keepdims=True) + 1e-15
        cross = np.abs(direction[:, 0] * to[..., 1] - direction[:, 1] * to[..., 0])
        return np.arcsin(np.clip(cross, 0.0, 1.0))

    def fit(idx: np.ndarray) -> np.ndarray:
        """Length-weighted least squares: the null vector of the stacked lines."""
        a = lines[idx] * np.sqrt(length[idx])[:, None]
        v = np.linalg.svd(a)[2][-1]
        return v / np.linalg.norm(v)

    rng = np.random.default_rng(config.seed)
    pairs = rng.integers(0, n, size=(config.hypotheses, 2))
    # Every hypothesis at once: the intersection of each pair, scored by the truncated
    # squared angles of all segments (MSAC), length-weighted.
    hyp = np.cross(lines[pairs[:, 0]], lines[pairs[:, 1]])
    norm = np.linalg.norm(hyp, axis=1)
    usable = (pairs[:, 0] != pairs[:, 1]) & (norm >= 1e-12)
    hyp = hyp[usable] / norm[usable, None]
    if len(hyp) == 0:
        return failed("the near-vertical segments are all parallel to one another")
    scores = np.maximum(0.0, 1.0 - (residual(hyp) / thr) ** 2) @ length
    v = hyp[int(np.argmax(scores))]
    inliers = residual(v) < thr
    for _ in range(3):  # refit and re-select
        if inliers.sum() < 2:
            break
        v = fit(np.flatnonzero(inliers))
        inliers = residual(v) < thr
    count = int(inliers.sum())
    fraction = count / n
    if count < config.min_inliers:
        return failed(
            f"{count} vertical line segment(s) agree on a vanishing point (need {config.min_inliers})",
            fraction,
        )
    up = v if v @ CAMERA_UP >= 0 else -v
    idx = np.flatnonzero(inliers)
    spread = [math.radians(angle_deg(fit(rng.choice(idx, len(idx))), up)) for _ in range(config.bootstrap)]
    # A resample's null vector may come out with either sign: angle_deg is unsigned, fold it.
    spread = [min(a, math.pi - a) for a in spread]
    sigma = max(math.degrees(math.sqrt(float(np.mean(np.square(spread))))), config.structure_sigma_deg)
    tilt_from_upright = angle_deg(up, CAMERA_UP)
    if tilt_from_upright > prior_cone_deg:
        return failed(f"the lines' up is {tilt_from_upright:.0f} deg from the camera's up", fraction)
    if sigma > config.max_sigma_deg:
        return failed(f"{count} vertical line segments fix up only to {sigma:.1f} deg", fraction)
    reason = f"the vanishing point of {count} vertical line segments"
    return GravityEstimate(up, frame, sigma, True, 0.0, fraction, reason)


def combine_with_lines(
    planes: GravityEstimate, lines: GravityEstimate, *, conflict_sigmas: float = 3.0, overrule: bool = True
) -> GravityEstimate:
    """The planes' up and the lines' up (same frame) as one estimate.

    Where both count and agree within ``conflict_sigmas`` combined sigmas, their inverse-
    variance weighted mean (the sigma shrinks accordingly). Where they disagree, the
    lines' with ``overrule`` (a plane-based estimate goes wrong by whole planes, a junk
    plane of a bad disparity taken for a floor or a wall, and its sigma, from the planes'
    own scatter, cannot say so, while the lines' estimate is only used when many segments
    agree on it tightly: :func:`up_from_vertical_lines`), else the planes'. Where only one
    counts (the planes' without a finite sigma: a floor alone), that one.
    """
    if not lines.ok:
        return planes
    if not planes.ok or not math.isfinite(planes.sigma_deg):
        return lines
    if planes.frame != lines.frame:
        raise ConfigError(f"cannot combine estimates in frames {planes.frame!r} and {lines.frame!r}")
    combined = math.hypot(planes.sigma_deg, lines.sigma_deg)
    apart = angle_deg(planes.up, lines.up)
    if apart > conflict_sigmas * combined:
        if not overrule:
            return planes
        reason = f"{lines.reason} ({apart:.1f} deg from the planes' up, which it overrules)"
        return GravityEstimate(
            lines.up,
            lines.frame,
            lines.sigma_deg,
            True,
            planes.horizontal_fraction,
            lines.vertical_fraction,
            reason,
        )
    wp, wl = planes.sigma_deg**-2, lines.sigma_deg**-2
    up = wp * planes.up + wl * lines.up
    up /= np.linalg.norm(up)
    sigma = (wp + wl) ** -0.5
    reason = f"{planes.reason}, with {lines.reason}"
    return GravityEstimate(
        up, planes.frame, sigma, True, planes.horizontal_fraction, planes.vertical_fraction, reason
    )
