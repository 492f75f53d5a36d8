"""Gravity from the image: "up" as the vanishing point of the scene's vertical lines.

Gravity from the scene's plane families (:mod:`stereo_terrain.gravity`) needs planes, and
planes need disparities: on the texture-poor faces of real staircases (paint, wood grain
seen head-on) the matcher's errors can make a junk plane look like a floor or a wall, and
the estimate is then off by 5-30 deg with a sigma that does not say so. The image itself
holds an independent witness: built scenes are full of vertical edges (wall corners, the
ends of the steps, door frames, newel posts, balusters), and the images of vertical 3D
lines all pass through one point, the vertical vanishing point ``v``, whose direction
``K^-1 v`` in the camera is "up" (Hartley & Zisserman, *Multiple View Geometry*, 8.6).
Their positions are exact to a fraction of a pixel whatever the disparity.

:func:`up_from_vertical_lines`:

1. line segments of the rectified left image (OpenCV's LSD, von Gioi et al. 2012), kept
   when long enough, inside the valid image and within ``max_tilt_deg`` of the image's
   vertical (the weak prior: the camera is roughly upright);
2. MSAC over pairs of segments: the hypothesis is their intersection, a segment scores by
   the truncated squared angle between it and the line from its midpoint to the point;
3. the winner refined by length-weighted least squares on its inliers (the null vector of
   their stacked homogeneous lines), its 1-sigma from a bootstrap over the inliers, with
   a floor for the structure (real walls and door frames lean by a few tenths of a degree).

An estimate with fewer than ``min_inliers`` segments or a sigma above ``max_sigma_deg`` is
returned with ``ok=False``: two segments always meet somewhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..rectify import Rectification, valid_interior
from .config import GravityEstimate
from .geometry import CAMERA_UP, angle_deg


@dataclass(frozen=True)
class VerticalLinesConfig:
    """How the vertical vanishing point is found.

    Attributes
    ----------
    enabled : bool
        Use the image's vertical lines for gravity when no rig is given (the pipeline
        combines them with the planes' estimate, see :mod:`stereo_terrain.pipeline`).
    detect_scale : float
        The segments are detected on the image resized by this factor, their ends then
        scaled back. LSD costs 16-35 ms on a 640x480 image on one core of the project's
        machine and 6-13 ms at half size, but at half size gravity from the scene is
        within 2 deg in 63% of the realistic scenes instead of 73-75%
        (docs/benchmarks.md).
    min_length_px : float
        Shortest segment used, in pixels of a 640-pixel-wide raw image (scaled with the
        raw width).
    terrain_min_length_px : float
        Shortest segment the terrain stage's vertical edges take (the risers' ends,
        :func:`stereo_terrain.terrain.nosings.view.vertical_edges`), as ``min_length_px``:
        the segments between the two lengths go to them alone (:attr:`SceneLines.short`);
        gravity, the horizontal direction and the nosings keep to ``min_length_px``. The
        end of a riser at the top of a staircase 3 m away is 20-25 px tall; the shorter
        segments for the nosings too made as many counts wrong as right without a rig
        (docs/benchmarks.md, "Forty-fifth session").
    max_tilt_deg : float
        Segments within this angle of the image's vertical are candidates.
    inlier_deg : float
        A segment supports a vanishing point when the line from its midpoint to the point
        is within this angle of it.
    hypotheses : int
        MSAC hypotheses (pairs of segments).
    min_inliers : int
        Fewest supporting segments for an estimate that counts.
    max_sigma_deg : float
        An estimate less certain than this does not count.
    structure_sigma_deg : float
        Floor of the reported sigma: real vertical edges lean by a few tenths of a degree.
    bootstrap : int
        Resamples of the inliers behind the sigma.
    seed : int
    overrule_planes : bool
        Where the planes' estimate and the lines' disagree by more than three combined
        sigmas, take the lines' (True, the default) or keep the planes' (False; see
        :func:`combine_with_lines`; the Manhattan frame of all the lines,
        :func:`~stereo_terrain.gravity.line_frame.up_from_lines_and_planes`, follows it too). On
        60 realistic rendered scenes overruling puts 75% of
        them within 2 deg (73% without); on the real scenes the lines' up is the one that
        makes their door frames and wall slats vertical (docs/benchmarks.md).
    horizontal_scale : float
        With up known from a rig, the segments behind :func:`horizontal_direction` are
        found on the image resized by this (long lines are enough for a direction; LSD at
        half size costs a fifth). Without a rig the full-size segments of the vertical
        lines are used again.
    finer_scale : float
        Where a frame's lines were found at another scale (``horizontal_scale``, with a
        rig) and it found no obstacle, the terrain stage looks once more for a staircase
        in the lines found at this scale (``pipeline.second_opinions.staircase_of_finer_lines``;
        set it to ``horizontal_scale`` to turn that off). A staircase 2-4 m ahead loses its
        nosings and risers' ends at half size (docs/benchmarks.md, "Forty-seventh
        session"); nearer ones keep more of theirs there, where the full-size segments
        break a faint line into pieces and add the floor's, so the frame keeps its own
        lines wherever it finds anything.
    horizontal_window_deg : float
        Segments whose horizontal direction is within this angle of the histogram's peak
        (modulo 90 deg) support it.
    horizontal_max_slope_deg : float
        Where :func:`horizontal_direction` is given a disparity map, a segment whose 3D
        line (from the disparity along it) rises more steeply than this is left out: the
        histogram takes every segment for the image of a horizontal line, and a long
        sloped one (a handrail, a stair's skirting or string, parallel to its pitch) points
        it somewhere. 0 = off. On the webcam-degraded real ``Staircase`` three handrail
        lines outweighed its eleven nosings (docs/benchmarks.md, twenty-eighth session).
    frame : bool
        Without a rig, where the planes do not fix up to ``frame_above_deg`` (or at all),
        fit the scene's Manhattan frame to all the segments, vertical and horizontal, with
        the planes' up as its prior (:mod:`stereo_terrain.gravity.line_frame`): a level camera near
        a staircase sees few vertical lines but many step edges. On 60 realistic rendered
        scenes, gravity within 2 deg of the truth in 93% of them instead of 75% (median
        0.88 -> 0.50 deg; 78-80% instead of 62-68% on two fresh sets of 40); the default
        profile's planes fix up to about 0.45 deg and are left alone (docs/benchmarks.md).
    frame_at_border : bool
        The frame is also fitted to the segments that run out of the view (clipped at the
        border of the valid region, :attr:`SceneLines.at_border`), not only the whole ones
        (True, the default): a staircase wider than the view, or yawed so that its
        nosings leave the image, has few whole lines (realistic 41 scene 57: 3 whole of
        10). Gravity within 2 deg without a rig on eight sets went up on four and held on
        four, the planes' worst errors (10-37 deg) mostly mended; a wooden floor's plank
        lines cut by the border misled it in two scenes (docs/benchmarks.md, thirty-sixth
        session). The other estimates keep to whole segments.
    frame_start_deg, frame_inlier_deg : float
        A segment belongs to the frame's direction whose vanishing point it points at
        within this angle: ``frame_start_deg`` at the start, narrowing to
        ``frame_inlier_deg``.
    endpoint_sigma_px : float
        1-sigma of a segment's ends across it: its angle is known to ``2 *
        endpoint_sigma_px / length`` (plus ``structure_sigma_deg``).
    frame_above_deg : float
        The frame is fitted where the planes' up is less certain than this (the lines fix
        up to about 1 deg: where the planes do better, they are kept; fitted everywhere,
        the default profile's median error goes from 0.12 to 0.16 deg). 0.55 (0.7
        before): on realistic and lab-like renders the planes' reported sigma covers
        their error within 2 sigma in only 67-83% of the scenes, and planes reporting
        0.55-0.7 deg were 2-8 deg off in several; gravity within 2 deg on eight sets
        went up on three and down on one, the median down or level on all
        (docs/benchmarks.md, thirty-sixth session).
    frame_prior_floor_deg : float
        The planes' up enters the frame as a prior at least this wide (their sigma is
        over-confident where a junk plane tilted them).
    upright_sigma_deg : float
        The upright camera's prior, with this 1-sigma: the frame's only prior where the
        planes do not fix up, and a second frame's beside the one near the planes' up
        where they leave it unsure.
    """

    enabled: bool = True
    detect_scale: float = 1.0
    min_length_px: float = 20.0
    terrain_min_length_px: float = 14.0
    max_tilt_deg: float = 30.0
    inlier_deg: float = 1.0
    hypotheses: int = 300
    min_inliers: int = 4
    max_sigma_deg: float = 2.0
    structure_sigma_deg: float = 0.3
    bootstrap: int = 30
    seed: int = 0
    overrule_planes: bool = True
    horizontal_scale: float = 0.5
    finer_scale: float = 1.0
    horizontal_window_deg: float = 4.0
    horizontal_max_slope_deg: float = 20.0
    frame: bool = True
    frame_at_border: bool = True
    frame_start_deg: float = 3.0
    frame_inlier_deg: float = 1.5
    endpoint_sigma_px: float = 1.0
    frame_above_deg: float = 0.55
    frame_prior_floor_deg: float = 1.0
    upright_sigma_deg: float = 8.0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 2, "min_inliers")
        check_min(self, 1, "hypotheses", "bootstrap")
        check_min(self, 0, "structure_sigma_deg")
        if not 0 < self.max_tilt_deg < 90:
            raise ConfigError(f"max_tilt_deg must be in (0, 90), got {self.max_tilt_deg}")
        for name in ("detect_scale", "horizontal_scale", "finer_scale"):
            if not 0 < getattr(self, name) <= 1:
                raise ConfigError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        if not 0 <= self.horizontal_max_slope_deg < 90:
            raise ConfigError(
                f"horizontal_max_slope_deg must be in [0, 90), got {self.horizontal_max_slope_deg}"
            )
        if not 0 < self.horizontal_window_deg < 45:
            raise ConfigError(f"horizontal_window_deg must be in (0, 45), got {self.horizontal_window_deg}")
        if not 0 < self.frame_inlier_deg <= self.frame_start_deg < 45:
            raise ConfigError(
                "need 0 < frame_inlier_deg <= frame_start_deg < 45, got "
                f"{self.frame_inlier_deg} and {self.frame_start_deg}"
            )
        if not 0 < self.terrain_min_length_px <= self.min_length_px:
            raise ConfigError(
                "need 0 < terrain_min_length_px <= min_length_px, got "
                f"{self.terrain_min_length_px} and {self.min_length_px}"
            )
        for name in (
            "min_length_px",
            "inlier_deg",
            "max_sigma_deg",
            "endpoint_sigma_px",
            "frame_above_deg",
            "frame_prior_floor_deg",
            "upright_sigma_deg",
        ):
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)}")


def _segments(
    image: np.ndarray, valid: np.ndarray | None, min_length_px: float, scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """LSD segments ``(N, 4)`` (x1, y1, x2, y2, pixels of ``image``) found on ``image``
    resized by ``scale``, each clipped to its longest part on valid pixels away from the
    border of the valid region (whose outline is a straight edge of the rectified image,
    not of the scene) and at least ``min_length_px`` long after that; and which of them
    were whole (both ends and the middle there, not clipped).

    A segment along the valid region's outline lies wholly in the border band and is
    dropped. One that runs out of the view is a line of the scene up to the border: a
    staircase wider than the view has all its nosings so (issue 11, :func:`scene_lines`)."""
    small = image if scale == 1 else cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    found = cv2.createLineSegmentDetector().detect(small)[0]
    if found is None:
        return np.empty((0, 4)), np.zeros(0, dtype=bool)
    # Pixel centres: x_small = (x + 0.5) * scale - 0.5.
    s = (found.reshape(-1, 4).astype(np.float64) + 0.5) / scale - 0.5
    s = s[np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) >= min_length_px]
    h, w = image.shape
    inside = valid_interior(valid, (h, w))

    def on(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        xi = np.clip(np.round(x).astype(int), 0, w - 1)
        yi = np.clip(np.round(y).astype(int), 0, h - 1)
        ok: np.ndarray = inside[yi, xi]
        return ok

    whole = on(s[:, 0], s[:, 1]) & on(s[:, 2], s[:, 3]) & on((s[:, 0] + s[:, 2]) / 2, (s[:, 1] + s[:, 3]) / 2)
    keep = whole.copy()
    cut = np.flatnonzero(~whole)
    if len(cut):
        # Each cut segment's longest run of inside pixels, one pixel apart (all at once:
        # sample k of segment i at t = k / (n_i - 1), none past its own end).
        a, b = s[cut, :2], s[cut, 2:]
        length = np.hypot(*(b - a).T)
        n = np.ceil(length).astype(int) + 1
        k = np.arange(int(n.max()))
        t = k[None, :] / (n[:, None] - 1)
        along = t < 1.0 + 1e-9
        t = np.minimum(t, 1.0)
        flags = on(a[:, :1] + t * (b[:, :1] - a[:, :1]), a[:, 1:] + t * (b[:, 1:] - a[:, 1:])) & along
        last_out = np.maximum.accumulate(np.where(flags, -1, k[None, :]), axis=1)
        run = np.where(flags, k[None, :] - last_out, 0)  # length of the run ending here
        end = np.argmax(run, axis=1)
        longest = run[np.arange(len(cut)), end]
        t0 = (end - longest + 1) / (n - 1)
        t1 = end / (n - 1)
        ok = (longest > 0) & ((t1 - t0) * length >= min_length_px)
        lo, hi = a + t0[:, None] * (b - a), a + t1[:, None] * (b - a)
        s[cut[ok]] = np.column_stack([lo, hi])[ok]
        keep[cut[ok]] = True
    return s[keep], whole[keep]


def _tilt_deg(segments: np.ndarray) -> np.ndarray:
    """Each segment's angle to the image's vertical, degrees (0-90)."""
    d = segments[:, 2:] - segments[:, :2]
    return np.degrees(np.arctan2(np.abs(d[:, 0]), np.abs(d[:, 1])))


def normalised_ends(segments: np.ndarray, rectification: Rectification) -> tuple[np.ndarray, np.ndarray]:
    """The segments' two ends as rays ``K^-1 (x, y, 1)`` of the rectified camera, ``(N, 3)``
    each (normalised image coordinates)."""
    f, cx, cy = rectification.focal_px, rectification.cx, rectification.cy
    ones = np.ones(len(segments))
    p1 = np.column_stack([(segments[:, 0] - cx) / f, (segments[:, 1] - cy) / f, ones])
    p2 = np.column_stack([(segments[:, 2] - cx) / f, (segments[:, 3] - cy) / f, ones])
    return p1, p2


def unit_rows(a: np.ndarray) -> np.ndarray:
    """Rows of ``a`` normalised (NaN where a row is zero)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return a / np.linalg.norm(a, axis=1, keepdims=True)


def line_segments(
    image: np.ndarray, rectification: Rectification, config: VerticalLinesConfig, scale: float
) -> np.ndarray:
    """LSD segments ``(N, 4)`` (x1, y1, x2, y2 in pixels of ``image``, the rectified left
    image) found at ``scale``, at least ``config.min_length_px`` long (in pixels of a
    640-pixel-wide raw image), away from the border of the valid region (whole ones: not
    those that reach it)."""
    length = _in_raw_px(rectification, config.min_length_px)
    s, whole = _segments(image, rectification.valid_left, length, scale)
    return s[whole]


def _in_raw_px(rectification: Rectification, length_px: float) -> float:
    """A length given in pixels of a 640-pixel-wide raw image, in pixels of this one."""
    return length_px * rectification.raw_size[0] / 640.0


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


#: Points along a segment at which :func:`sloped_segments` reads the disparity.
_SLOPE_SAMPLES = 8

#: A segment's two halves must lie this far apart in 3D (metres) for its slope to count.
_SLOPE_MIN_SPAN_M = 0.05


def _nanmedian_rows(a: np.ndarray) -> np.ndarray:
    """``np.nanmedian(a, axis=-1)``, NaN where a row is all NaN, without the warning that
    NumPy gives there (the warning filters are process-wide; the lines' thread runs beside
    the matcher)."""
    empty = np.isnan(a).all(axis=-1)
    out: np.ndarray = np.nanmedian(np.where(empty[..., None], 0.0, a), axis=-1)
    out[empty] = np.nan
    return out


def sloped_segments(
    segments: np.ndarray,
    rectification: Rectification,
    disparity: np.ndarray,
    up: np.ndarray,
    max_slope_deg: float,
) -> np.ndarray:
    """Which of ``segments`` are images of 3D lines rising more steeply than
    ``max_slope_deg``, by the disparity along them.

    Parameters
    ----------
    segments : (N, 4) float, (x1, y1, x2, y2) in pixels of the rectified left image
    rectification : Rectification of the pair (focal length, principal point, baseline,
        ``doffs_px``)
    disparity : (H, W) float, the rectified pair's disparity in pixels; NaN or <= 0 where
        unmatched
    up : (3,) float, up in the rectified left camera
    max_slope_deg : float

    Returns
    -------
    (N,) bool. At :data:`_SLOPE_SAMPLES` points between 10% and 90% of each segment, the
    median of the positive disparities in a 3x3 window is back-projected; the line's
    direction joins the median point of the samples on the segment's first half to that
    of those on its second half (robust to a stray disparity or two). A segment with fewer
    than three points on either half (unmatched, or outside the image), or whose halves
    lie less than :data:`_SLOPE_MIN_SPAN_M` apart, is not called sloped.
    """
    n = len(segments)
    out = np.zeros(n, dtype=bool)
    if n == 0:
        return out
    h, w = disparity.shape
    t = np.linspace(0.1, 0.9, _SLOPE_SAMPLES)
    x = segments[:, None, 0] + t[None, :] * (segments[:, None, 2] - segments[:, None, 0])
    y = segments[:, None, 1] + t[None, :] * (segments[:, None, 3] - segments[:, None, 1])
    xi, yi = np.round(x).astype(int), np.round(y).astype(int)
    inside = (xi >= 1) & (xi <= w - 2) & (yi >= 1) & (yi <= h - 2)
    xi, yi = np.clip(xi, 1, w - 2), np.clip(yi, 1, h - 2)
    window = np.stack([disparity[yi + dy, xi + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=-1)
    window = np.where(window > 0, window, np.nan).astype(np.float64)  # NaN: unmatched
    d = _nanmedian_rows(window)
    d[~inside] = np.nan
    Z = rectification.depth_from_disparity(d)  # NaN where d + doffs <= 0
    f = rectification.focal_px
    half = _SLOPE_SAMPLES // 2
    seen = np.isfinite(Z)
    enough = (seen[:, :half].sum(axis=1) >= 3) & (seen[:, half:].sum(axis=1) >= 3)
    if not enough.any():
        return out
    P = np.stack([(x - rectification.cx) * Z / f, (y - rectification.cy) * Z / f, Z], axis=-1)[enough]
    first = np.stack([_nanmedian_rows(P[:, :half, k]) for k in range(3)], axis=-1)
    second = np.stack([_nanmedian_rows(P[:, half:, k]) for k in range(3)], axis=-1)
    direction = second - first
    span = np.linalg.norm(direction, axis=1)
    unit_up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    rising = np.abs(direction @ unit_up) > math.sin(math.radians(max_slope_deg)) * span
    out[np.flatnonzero(enough)] = rising & (span >= _SLOPE_MIN_SPAN_M)
    return out


def level_turn_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two horizontal directions ``a`` and ``b`` modulo 90 deg (a built
    scene's two horizontal families are one for :func:`horizontal_direction`), degrees in
    [0, 45]."""
    cos = abs(float(a @ b)) / float(np.linalg.norm(a) * np.linalg.norm(b))
    turn = math.degrees(math.acos(min(cos, 1.0)))
    return min(turn, 90.0 - turn)


def horizontal_direction(
    segments: np.ndarray,
    rectification: Rectification,
    up: np.ndarray,
    config: VerticalLinesConfig,
    disparity: np.ndarray | None = None,
) -> np.ndarray | None:
    """The scene's dominant horizontal direction in the rectified left camera, modulo 90
    deg, from its non-vertical line segments, given ``up`` (same frame); None when fewer
    than ``config.min_inliers`` segments agree on one.

    A segment and the camera centre span a plane with normal ``m``; if the segment is the
    image of a horizontal 3D line, the line's direction is ``m x up``. Nosings, tread edges,
    skirting boards and door tops are such lines, along the staircase or across it: in a
    built (Manhattan) scene their directions fall in two families 90 deg apart, so the
    length-weighted histogram of the directions' angles in the horizontal plane, modulo 90
    deg, has one peak; the direction is the weighted circular mean of the segments within
    ``horizontal_window_deg`` of it. Grain falls elsewhere and does not move the peak;
    sloped lines (handrails, the staircase's slope line) mostly fall elsewhere too, but a
    few long ones can outweigh the step edges: given the ``disparity`` map of the
    rectified pair, the segments it shows rising more steeply than
    ``config.horizontal_max_slope_deg`` are left out (:func:`sloped_segments`).
    """
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    if len(segments) == 0:
        return None
    s = segments[_tilt_deg(segments) > config.max_tilt_deg]
    if disparity is not None and config.horizontal_max_slope_deg > 0 and len(s):
        s = s[~sloped_segments(s, rectification, disparity, up, config.horizontal_max_slope_deg)]
    d = s[:, 2:] - s[:, :2]
    if len(s) < config.min_inliers:
        return None
    p1, p2 = normalised_ends(s, rectification)
    m = np.cross(p1, p2)
    t = np.cross(m, up)
    norm = np.linalg.norm(t, axis=1)
    # A segment whose plane nearly contains up (a near-vertical line) fixes no horizontal
    # direction.
    keep = norm > 0.2 * np.linalg.norm(m, axis=1)
    t, length = t[keep] / norm[keep, None], np.hypot(d[keep, 0], d[keep, 1])
    if len(t) < config.min_inliers:
        return None
    e1 = np.cross(up, [0.0, 0.0, 1.0])
    if np.linalg.norm(e1) < 1e-6:  # a camera looking straight up or down
        e1 = np.cross(up, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    # Angles modulo 90 deg, as points on a circle (x4): the peak and the mean wrap.
    quad = 4.0 * np.arctan2(t @ e2, t @ e1)
    bins = np.bincount(np.round(np.degrees(quad) / 4.0).astype(int) % 90, weights=length, minlength=90)
    k = np.exp(-0.5 * (np.arange(-6, 7) / 2.0) ** 2)
    smooth = np.array([bins[(i + np.arange(-6, 7)) % 90] @ k for i in range(90)])
    peak = math.radians(4.0 * float(np.argmax(smooth)))
    off = np.angle(np.exp(1j * (quad - peak)))  # in (-pi, pi]: 4x the angle to the peak
    near = np.abs(off) <= math.radians(4.0 * config.horizontal_window_deg)
    if near.sum() < config.min_inliers:
        return None
    mean = peak + float(np.angle(np.sum(length[near] * np.exp(1j * off[near]))))
    a = mean / 4.0
    return math.cos(a) * e1 + math.sin(a) * e2


@dataclass(frozen=True)
class SceneLines:
    """What the image's line segments say, found beside the matcher (:func:`scene_lines`).

    Attributes
    ----------
    up : GravityEstimate or None
        :func:`up_from_vertical_lines` (None when up was known and not asked for).
    horizontal : (3,) float64 or None
        :func:`horizontal_direction` in the rectified left camera (None when asked for and
        not found, or not asked for).
    segments : (N, 4) float64
        The LSD segments behind them (for :func:`horizontal_direction` with another up):
        whole ones, away from the border of the valid region.
    at_border : (M, 4) float64
        The same pass's segments that reach that border, clipped there (for the terrain's
        nosings, :mod:`stereo_terrain.terrain.nosings`: a staircase wider than the view has
        all its nosings so), and for gravity's Manhattan frame of the lines
        (``frame_at_border``). The estimates above keep to whole segments: with these too,
        the Manhattan fill and the rematches moved and lost as many staircases as the
        nosings gained (docs/benchmarks.md, "Sixteenth session").
    short : (K, 4) float64
        The same pass's segments shorter than ``min_length_px`` and at least
        ``terrain_min_length_px`` long, the whole ones then those at the border: for the
        terrain's vertical edges alone (``VerticalLinesConfig.terrain_min_length_px``).
    scale : float or None
        The scale the LSD pass ran at (``detect_scale`` or ``horizontal_scale``); None
        where no pass ran.
    """

    up: GravityEstimate | None
    horizontal: np.ndarray | None
    segments: np.ndarray
    at_border: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))
    short: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))
    scale: float | None = None

    @property
    def every_segment(self) -> np.ndarray:
        """``(N + M, 4)``: the whole segments, then those at the border (the band fill's,
        and with ``frame_at_border`` the Manhattan frame's)."""
        return np.concatenate([self.segments, self.at_border])


def scene_lines(
    image: np.ndarray,
    rectification: Rectification,
    config: VerticalLinesConfig,
    *,
    known_up: np.ndarray | None = None,
    want_up: bool = True,
    want_horizontal: bool = True,
    prior_cone_deg: float = 45.0,
) -> SceneLines:
    """Up from the vertical lines (unless ``known_up``, e.g. a rig's, is given or
    ``want_up`` is False) and the dominant horizontal direction (``want_horizontal``; with
    the given up, else with the lines' when they fix it), from one LSD pass."""
    up_est = None
    scale = None  # the pass's, where one ran
    length = _in_raw_px(rectification, config.min_length_px)
    shortest = _in_raw_px(rectification, config.terrain_min_length_px)
    found, whole = np.empty((0, 4)), np.zeros(0, dtype=bool)
    if known_up is None and want_up:
        scale = config.detect_scale
        found, whole, long = _long_and_short(image, rectification, shortest, length, scale)
        segments = found[whole & long]
        up_est = up_from_vertical_lines(
            image, rectification, config, prior_cone_deg=prior_cone_deg, segments=segments
        )
        up = up_est.up if up_est.ok else None
    else:
        up = known_up
        long = np.zeros(0, dtype=bool)
        if want_horizontal and up is not None:
            scale = config.horizontal_scale
            found, whole, long = _long_and_short(image, rectification, shortest, length, scale)
        segments = found[whole & long]
    horizontal = None
    if want_horizontal and up is not None:
        horizontal = horizontal_direction(segments, rectification, up, config)
    return _sorted(found, whole, long, scale, up_est, horizontal)


def scene_segments(
    image: np.ndarray, rectification: Rectification, config: VerticalLinesConfig, scale: float
) -> SceneLines:
    """One LSD pass at ``scale`` sorted as :func:`scene_lines` sorts its segments (whole,
    at the border, short), with neither up nor a horizontal direction: the terrain's lines
    at another scale than the frame's (``finer_scale``)."""
    length = _in_raw_px(rectification, config.min_length_px)
    shortest = _in_raw_px(rectification, config.terrain_min_length_px)
    return _sorted(*_long_and_short(image, rectification, shortest, length, scale), scale)


def _sorted(
    found: np.ndarray,
    whole: np.ndarray,
    long: np.ndarray,
    scale: float | None,
    up: GravityEstimate | None = None,
    horizontal: np.ndarray | None = None,
) -> SceneLines:
    """One pass's segments (:func:`_long_and_short`) as :class:`SceneLines` holds them."""
    short = np.concatenate([found[whole & ~long], found[~whole & ~long]])
    return SceneLines(up, horizontal, found[whole & long], found[~whole & long], short, scale)


def _long_and_short(
    image: np.ndarray, rectification: Rectification, shortest: float, length: float, scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One LSD pass's segments at least ``shortest`` long (:func:`_segments`), which of
    them are whole, and which are ``length`` long or more: the same segments that pass
    would give at ``length`` (a clipped segment's length is its clipped part's)."""
    found, whole = _segments(image, rectification.valid_left, shortest, scale)
    long = np.hypot(found[:, 2] - found[:, 0], found[:, 3] - found[:, 1]) >= length
    return found, whole, long
