"""Gravity from all of the image's lines: the scene's Manhattan frame.

The vertical vanishing point (:func:`stereo_terrain.gravity.from_lines.up_from_vertical_lines`)
needs near-vertical segments, and a level camera a metre or two from a staircase often
sees fewer than four of them (no wall corner, no newel post in view). It sees many
horizontal ones: nosings and tread edges run along the steps, the treads' side edges and
a side wall's skirting across them. Horizontal 3D lines also fix up: in a built scene
they follow two horizontal directions ``h`` and ``up x h``, whose vanishing points lie on
the horizon, so up is perpendicular to both; with the vertical lines, the three
directions are the columns of one rotation ``R = [up, h, up x h]`` (the Manhattan frame;
Coughlan & Yuille 1999, Kosecka & Zhang 2002).

:func:`up_from_line_frame` fits up and the horizontal directions to all the segments at
once, with a prior on up (the planes' estimate, or the upright camera):

1. starts: the prior's up, and the few best ups of hypotheses from triples of segments
   (two meet at a vanishing point; if it is horizontal the third gives the other
   horizontal direction, if it is up the third gives a horizontal one), each scored as
   a Manhattan frame: the segments' truncated chi^2 to their nearest vanishing point
   (MSAC, each in its own sigma: its ends' ``endpoint_sigma_px`` over its length, plus
   the structure's lean), and the prior's chi^2;
2. from each start, Gauss-Newton on up and the horizontal directions' angles about it:
   the Manhattan pair (``h`` and ``up x h``, one angle), then up to two more horizontal
   directions of three segments or more each (Atlanta world: a floor's tiles or a wall
   need not share the staircase's yaw; they help the fit, the score counts the pair
   only). A segment belongs to the direction whose vanishing point it points at, within
   a tolerance narrowing to ``frame_inlier_deg``; one that points at two (a step edge
   through the horizon's other point) belongs to none; sloped lines (handrails, the
   staircase's slope, grain) point at none. Cauchy weights. The best start by its score;
3. the 1-sigma of up is the marginal of the Gauss-Newton covariance, widened by the
   residuals' chi^2 per degree of freedom; a tilt the lines do not fix (a frontal
   staircase's step edges fix the roll, not the pitch) keeps the prior's width.

:func:`up_from_lines_and_planes` is what the pipeline runs without a rig where the planes
do not fix up to ``vanishing.frame_above_deg``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..rectify import Rectification
from .config import GravityEstimate
from .from_lines import VerticalLinesConfig, normalised_ends, unit_rows
from .geometry import CAMERA_UP, _tangent_basis, angle_deg

#: Where the frame near the planes' up and the upright one disagree, the upright one
#: is taken when its up's vanishing point gathers at least this many times the vertical
#: lines' gain of the other's (a frame a few degrees off still catches a few short
#: near-vertical segments by chance; the frames a junk plane tilted catch next to none).
_VERTICAL_MARGIN = 2.0

#: Scale of the Cauchy weights on a segment's normalised residual (in sigmas).
_CAUCHY_SCALE = 2.5

#: Yaw steps of the start's search over 90 deg.
_YAW_STEPS = 90

#: Gauss-Newton steps from each start.
_STEPS = 8

#: Starts fitted besides the prior's up.
_STARTS = 4

#: Most horizontal directions (Atlanta world: a staircase, a floor's tiles and a wall
#: need not share their yaw).
_MAX_HORIZONTALS = 4

#: Fewest segments of a horizontal direction beyond the Manhattan pair (two segments
#: always meet somewhere near the horizon).
_MIN_MEMBERS = 3


def _row_norms(v: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(v, axis=-1, keepdims=True)`` of 2-vectors: the same sum of squares
    and root (the same bits), without the wrapper's cost (the fit calls it thousands of
    times a frame)."""
    return np.sqrt(v[..., :1] * v[..., :1] + v[..., 1:] * v[..., 1:])


class _Segments:
    """The segments in normalised image coordinates: midpoints, unit directions, lengths."""

    def __init__(self, segments: np.ndarray, rectification: Rectification, endpoint_sigma_px: float):
        p1, p2 = normalised_ends(segments, rectification)
        self.lines = np.cross(p1, p2)  # homogeneous image lines
        self.mid = ((p1 + p2) / 2.0)[:, :2]
        d = (p2 - p1)[:, :2]
        self.direction = unit_rows(d)
        self.length = np.hypot(segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1])
        self.noise = 2.0 * endpoint_sigma_px / self.length  # radians, before the structure's floor

    def angles(self, directions: np.ndarray) -> np.ndarray:
        """``(K, N)``: signed angle (radians) between each segment and the line from its
        midpoint to the vanishing point of each of the ``(K, 3)`` directions."""
        return _angles_to(directions[:, None, :], self.mid[None], self.direction[None])

    def pair_angles(self, directions: np.ndarray, which: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """``angles(directions)[which, idx]``, computed for those pairs only (the same
        operations on each pair, so the same values: the fit's residuals need one
        direction per segment, not all of them); ``directions`` may have leading axes
        (``(..., K, 3)`` gives ``(..., len(idx))``)."""
        return _angles_to(directions[..., which, :], self.mid[idx], self.direction[idx])


def _angles_to(directions: np.ndarray, mid: np.ndarray, own: np.ndarray) -> np.ndarray:
    """Signed angle (radians) between segments (midpoints ``mid``, unit directions
    ``own``, ``(..., 2)``) and the lines from their midpoints to the vanishing points of
    ``directions`` (``(..., 3)``), all three broadcast together."""
    to = directions[..., :2] - mid * directions[..., 2:3]
    to /= _row_norms(to) + 1e-15
    along = own[..., 0] * to[..., 0] + own[..., 1] * to[..., 1]
    cross = own[..., 0] * to[..., 1] - own[..., 1] * to[..., 0]
    # The line from the midpoint has no orientation: fold it onto the segment's.
    return np.arcsin(np.clip(np.where(along < 0, -cross, cross), -1.0, 1.0))


def up_from_line_frame(
    segments: np.ndarray,
    rectification: Rectification,
    prior_up: np.ndarray,
    prior_sigma_deg: float,
    config: VerticalLinesConfig | None = None,
    *,
    prior_cone_deg: float = 45.0,
    max_sigma_deg: float | None = None,
) -> GravityEstimate:
    """Up in the rectified left camera from the Manhattan frame of all the line segments.

    Parameters
    ----------
    segments : (N, 4) array
        LSD segments of the rectified left image (:func:`stereo_terrain.gravity.from_lines.line_segments`).
    rectification : Rectification
    prior_up : (3,) array
        Up before the lines (the planes' estimate, or the camera's up), rectified camera.
    prior_sigma_deg : float
        Its 1-sigma (isotropic).
    config : VerticalLinesConfig
        ``frame_*`` fields, ``endpoint_sigma_px``, ``structure_sigma_deg``, ``seed``,
        ``hypotheses``, ``min_inliers`` and ``max_sigma_deg``.
    prior_cone_deg : float
        Up lies within this angle of the camera's up.
    max_sigma_deg : float, optional
        An estimate less certain than this does not count (default
        ``config.max_sigma_deg``).

    Returns
    -------
    GravityEstimate in ``camera_rect``; ``vertical_fraction`` is the share of the segments
    that fit the frame. ``ok=False`` (with a reason) when fewer than ``min_inliers``
    segments fit it or up is not fixed to ``max_sigma_deg``.
    """
    config = config or VerticalLinesConfig()
    if not 0 < prior_sigma_deg < math.inf:
        raise ValueError(f"prior_sigma_deg must be positive and finite, got {prior_sigma_deg}")
    frame = "camera_rect"
    u0 = np.asarray(prior_up, dtype=np.float64)
    u0 = u0 / np.linalg.norm(u0)

    def failed(reason: str, fraction: float = 0.0) -> GravityEstimate:
        return GravityEstimate(np.full(3, np.nan), frame, math.inf, False, 0.0, fraction, reason)

    if len(segments) < config.min_inliers:
        return failed(f"{len(segments)} line segment(s) in the image (need {config.min_inliers})")
    seg, sigma = _segments_and_sigma(segments, rectification, config)
    s0 = math.radians(prior_sigma_deg)
    # 1. Starts: the prior's up, and ups from triples of segments (the minimal case):
    # the first two meet at a vanishing point v; if v is horizontal, the third's
    # direction is perpendicular to it (its interpretation plane's normal crossed with v)
    # and up is perpendicular to both; if v is up, the third is horizontal. Those within
    # three prior sigmas are scored as Manhattan frames (up, the horizontal pair): the
    # few best, and the prior's up, are fitted.
    t0 = math.radians(config.frame_start_deg)
    gain = (t0 / sigma) ** 2  # what a segment on its vanishing point saves (chi^2)
    starts = _starts(seg, gain, u0, s0, config, math.radians(prior_cone_deg))
    # 2. Each start fitted; the best by its MAP score.
    fits = [_fit(seg, sigma, u, u0, s0, config) for u in starts]
    best = max(fits, key=lambda f: f.score)
    count = int(best.inliers.sum())
    fraction = count / len(seg.length)
    if best.normal is None or count < config.min_inliers:
        return failed(f"{count} line segment(s) fit a Manhattan frame (need {config.min_inliers})", fraction)
    up = best.up
    # 3. Marginal covariance of up (the first two parameters, tangent to up).
    try:
        cov = np.linalg.inv(best.normal)[:2, :2]
    except np.linalg.LinAlgError:
        return failed("the line segments do not fix a Manhattan frame", fraction)
    dof = count + 2 - len(best.normal)
    scale = max(1.0, best.chi2 / dof) if dof > 0 else 1.0
    var = float(np.linalg.eigvalsh(cov)[-1]) * scale
    sigma_deg = max(math.degrees(math.sqrt(max(var, 0.0))), config.structure_sigma_deg)
    tilt = angle_deg(up, CAMERA_UP)
    if tilt > prior_cone_deg:
        return failed(f"the lines' frame puts up {tilt:.0f} deg from the camera's up", fraction)
    if sigma_deg > (config.max_sigma_deg if max_sigma_deg is None else max_sigma_deg):
        return failed(f"{count} line segments fix the frame's up only to {sigma_deg:.1f} deg", fraction)
    horizontal = 0 if len(best.thetas) == 0 else len(best.thetas) + 1
    reason = f"the Manhattan frame of {count} line segments ({horizontal} horizontal directions)"
    return GravityEstimate(up, frame, sigma_deg, True, 0.0, fraction, reason)


def _starts(
    seg: _Segments, gain: np.ndarray, u0: np.ndarray, s0: float, config: VerticalLinesConfig, cone: float
) -> list[np.ndarray]:
    """Ups to fit from: ``u0`` and the best-scored distinct ups of the hypotheses (step 1
    of :func:`up_from_line_frame`)."""
    basis = _tangent_basis(u0)
    yaw = np.arange(_YAW_STEPS) * (0.5 * math.pi / _YAW_STEPS)
    h1 = np.cos(yaw)[:, None] * basis[0] + np.sin(yaw)[:, None] * basis[1]
    rng = np.random.default_rng(config.seed)
    i, j, k = rng.integers(0, len(seg.length), size=(3, config.hypotheses))
    v = unit_rows(np.cross(seg.lines[i], seg.lines[j]))
    across = unit_rows(np.cross(v, seg.lines[k]))  # v horizontal: the other horizontal
    along = unit_rows(np.cross(seg.lines[k], v))  # v up: the third's horizontal direction
    ups = np.vstack([np.repeat(u0[None], _YAW_STEPS, axis=0), np.cross(v, across), v])
    h1 = np.vstack([h1, v, along])
    ups *= np.where(ups @ u0 < 0, -1.0, 1.0)[:, None]
    keep = np.isfinite(ups).all(axis=1) & np.isfinite(h1).all(axis=1)
    keep &= ups @ u0 >= math.cos(min(3.0 * s0, cone))
    ups, h1 = ups[keep], h1[keep]
    h2 = np.cross(ups, h1)
    t0 = math.radians(config.frame_start_deg)
    fit = np.maximum.reduce([np.maximum(0.0, 1.0 - (seg.angles(d) / t0) ** 2) for d in (ups, h1, h2)])
    score = fit @ gain - (np.arccos(np.clip(ups @ u0, -1.0, 1.0)) / s0) ** 2
    starts = [u0]
    for k in np.argsort(-score):
        if len(starts) > _STARTS:
            break
        if all(ups[k] @ u < math.cos(math.radians(1.0)) for u in starts):  # 1 deg apart
            starts.append(ups[k])
    return starts


@dataclasses.dataclass
class _Fit:
    up: np.ndarray
    thetas: np.ndarray
    inliers: np.ndarray
    normal: np.ndarray | None
    chi2: float
    score: float


def _directions(u: np.ndarray, thetas: np.ndarray) -> np.ndarray:
    """``(K, 3)``: up, then the horizontal directions at angles ``thetas`` about it, the
    first one's perpendicular second (the Manhattan pair), the others (Atlanta) after."""
    if len(thetas) == 0:
        return u[None]
    angles = np.concatenate([thetas[:1], thetas[:1] + 0.5 * math.pi, thetas[1:]])
    e = _tangent_basis(u)
    out = np.empty((len(angles) + 1, 3))
    out[0] = u
    out[1:] = np.cos(angles)[:, None] * e[0] + np.sin(angles)[:, None] * e[1]
    return out


def _peaks(seg: _Segments, gain: np.ndarray, u: np.ndarray, free: np.ndarray, tol: float) -> np.ndarray:
    """Angles about ``u`` of the horizontal directions the ``free`` segments follow: the
    Manhattan pair that gathers the most gain (two segments or more), then other
    directions greedily (``_MIN_MEMBERS`` each: two segments always meet near the horizon)."""
    grid = np.arange(180) * (math.pi / 180)
    e = _tangent_basis(u)
    a = np.abs(seg.angles(np.cos(grid)[:, None] * e[0] + np.sin(grid)[:, None] * e[1]))  # (180, N)
    fit = _fit_weight(a, tol) * free
    pair = fit[:90] + fit[90:]
    first = int(np.argmax(pair @ gain))
    members = free & ((a[first] < tol) | (a[first + 90] < tol))
    if members.sum() < 2:
        return np.empty(0)
    found = [grid[first]]
    free = free & ~members
    while len(found) < _MAX_HORIZONTALS - 1:
        k = int(np.argmax((fit * free) @ gain))
        members = free & (a[k] < tol)
        if members.sum() < _MIN_MEMBERS:
            break
        found.append(grid[k])
        free &= ~members
    return np.array(found)


def _assign(
    seg: _Segments, u: np.ndarray, thetas: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each segment's direction (index into :func:`_directions`), whether it counts, and
    its angle to that direction's vanishing point."""
    angles = np.abs(seg.angles(_directions(u, thetas)))
    within = angles < tol
    family = np.argmax(within, axis=0)
    # A segment through two vanishing points (a step edge through the horizon's other
    # point) does not say which it follows; an Atlanta direction needs _MIN_MEMBERS.
    inliers = within.sum(axis=0) == 1
    need = np.where(np.arange(len(within)) < 3, 1, _MIN_MEMBERS)
    inliers &= (np.bincount(family[inliers], minlength=len(within)) >= need)[family]
    return family, inliers, angles[family, np.arange(len(family))]


def _residuals_and_jacobian(
    seg: _Segments,
    sigma: np.ndarray,
    u: np.ndarray,
    e: np.ndarray,
    thetas: np.ndarray,
    fam: np.ndarray,
    idx: np.ndarray,
    prior_basis: np.ndarray,
    s0: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The fit's residuals at its parameters (up turned by ``p[0] e[0] + p[1] e[1]``, the
    angles ``thetas + p[2:]``) equal to 0, and their numeric Jacobian (each parameter
    moved by 1e-6): each inlier ``idx`` segment's angle to its direction ``fam`` over its
    sigma, then the prior's two. All the residual vectors' angles in one pass (issue 13);
    the same values as evaluating them one parameter at a time."""
    params = np.vstack([np.zeros(2 + len(thetas)), 1e-6 * np.eye(2 + len(thetas))])
    dirs = np.empty((len(params), len(thetas) + 1 + (len(thetas) > 0), 3))
    prior = np.empty((len(params), 2))
    for m, p in enumerate(params):
        uu = u + p[0] * e[0] + p[1] * e[1]
        uu = uu / math.sqrt(uu.dot(uu))
        dirs[m] = _directions(uu, thetas + p[2:])
        prior[m] = prior_basis @ uu
    rows = np.concatenate([seg.pair_angles(dirs, fam, idx) / sigma[idx], prior / s0], axis=1)
    r = rows[0]
    return r, np.ascontiguousarray(((rows[1:] - r) / 1e-6).T)


def _fit(
    seg: _Segments, sigma: np.ndarray, u: np.ndarray, u0: np.ndarray, s0: float, config: VerticalLinesConfig
) -> _Fit:
    """Gauss-Newton from ``u`` on up and the horizontal directions' angles about it
    (Cauchy weights), the tolerance narrowing to ``frame_inlier_deg``; the directions found
    again at each of the first steps."""
    n = len(seg.length)
    prior_basis = _tangent_basis(u0)
    tolerances = np.linspace(config.frame_start_deg, config.frame_inlier_deg, 3).tolist()
    tolerances += [config.frame_inlier_deg] * (_STEPS - 3)
    thetas = np.empty(0)
    normal, chi2 = None, 0.0
    inliers = np.zeros(n, dtype=bool)
    family = np.zeros(n, dtype=int)
    for step_no, tol_deg in enumerate(tolerances):
        tol = math.radians(tol_deg)
        if step_no < 3:
            thetas = _peaks(seg, (tol / sigma) ** 2, u, np.abs(seg.angles(u[None]))[0] >= tol, tol)
        family, inliers, _ = _assign(seg, u, thetas, tol)
        if inliers.sum() < 2:
            break
        idx, fam = np.flatnonzero(inliers), family[inliers]
        e = _tangent_basis(u)

        r, J = _residuals_and_jacobian(seg, sigma, u, e, thetas, fam, idx, prior_basis, s0)
        weights = np.ones(len(r))
        weights[: len(idx)] = 1.0 / (1.0 + (r[: len(idx)] / _CAUCHY_SCALE) ** 2)
        normal = J.T @ (J * weights[:, None])
        # A direction left without members: its angle stays (and says nothing of up).
        normal[2:, 2:] += 1e-9 * np.eye(len(thetas))
        chi2 = float(np.sum(weights[: len(idx)] * r[: len(idx)] ** 2))
        try:
            step = -np.linalg.solve(normal, J.T @ (weights * r))
        except np.linalg.LinAlgError:  # pragma: no cover - the prior keeps up's block regular
            normal = None
            break
        u = u + step[0] * e[0] + step[1] * e[1]
        u = u / math.sqrt(u.dot(u))
        thetas = thetas + step[2:]
        if math.sqrt(step.dot(step)) < 1e-8:
            break
    tol = math.radians(config.frame_inlier_deg)
    family, inliers, angle = _assign(seg, u, thetas, tol)
    # The score counts up and the Manhattan pair only: each Atlanta direction has a free
    # angle of its own, and any three segments of a scene that meet near the horizon
    # would make one (they help the fit, they do not choose it).
    fit = np.where(inliers & (family < 3), _fit_weight(angle, tol), 0.0)
    score = float(fit @ (tol / sigma) ** 2) - (math.acos(min(1.0, max(-1.0, float(u @ u0)))) / s0) ** 2
    return _Fit(u if u @ u0 >= 0 else -u, thetas, inliers, normal, chi2, score)


def up_from_lines_and_planes(
    segments: np.ndarray,
    rectification: Rectification,
    planes_up: np.ndarray | None,
    planes_sigma_deg: float,
    config: VerticalLinesConfig,
    *,
    prior_cone_deg: float = 45.0,
    unsure_max_sigma_deg: float = 4.0,
    conflict_sigmas: float = 3.0,
    overrule: bool = True,
) -> GravityEstimate:
    """Up from the Manhattan frame of the line segments, given the planes' up (rectified
    camera; None, or an infinite sigma, where the planes do not fix it).

    With the planes' up, two frames: one with it as the prior (at least
    ``frame_prior_floor_deg`` wide), and one with the upright camera as the prior
    (``upright_sigma_deg``), which counts where its sigma is at most the larger of
    ``max_sigma_deg`` and the planes' sigma (and never above ``unsure_max_sigma_deg``).
    The planes' sigma comes from their own scatter and cannot see a plane family tilted
    as a whole (a fill's planes across a tread and a riser):
    realistic renders had them 5-17 deg off at a sigma of 1-1.3 deg, and the frame near
    them followed, its step edges fixing only the roll.

    - Both frames fit and are within ``conflict_sigmas`` combined sigmas of each other:
      their inverse-variance mean (the upright frame's prior leaves it free to follow the
      lines' own tilt where the planes' prior held the near one; on realistic renders
      the mean was within 2 deg where the two were 1-4 deg apart in 11 scenes of 12, the
      near frame in 6).
    - They contradict each other: the one whose up gathers clearly more vertical lines
      (``_VERTICAL_MARGIN`` times their gain, the near one on a tie). The vertical lines
      are the direct witness of up; the upright frame's own failure (a handrail's edges
      or the staircase's slope taken for a horizontal direction, up turned 10-30 deg
      about the step edges) loses them. (Not the frame that fits more segments: that
      overruled good planes by 14 and 22 deg on 60 realistic scenes.)
    - No frame near the planes' up (a junk plane tilted them further than their sigma
      says): the upright frame overrules the planes where it is further than
      ``conflict_sigmas`` combined sigmas from them, else the two are averaged.

    With ``overrule=False`` (``vanishing.overrule_planes``) the upright frame never
    overrules: where it contradicts, the frame near the planes' up (or nothing) is returned.

    Without the planes' up, the frame with the upright prior, which only has to do better
    than a level camera assumed: it counts up to ``unsure_max_sigma_deg``. ``ok=False``
    where the lines add nothing.
    """
    if planes_up is None or not math.isfinite(planes_sigma_deg):
        return up_from_line_frame(
            segments,
            rectification,
            CAMERA_UP,
            config.upright_sigma_deg,
            config,
            prior_cone_deg=prior_cone_deg,
            max_sigma_deg=unsure_max_sigma_deg,
        )
    width = max(planes_sigma_deg, config.frame_prior_floor_deg)
    cone = prior_cone_deg
    near = up_from_line_frame(segments, rectification, planes_up, width, config, prior_cone_deg=cone)
    # The upright frame counts up to the larger of max_sigma_deg and the planes' sigma.
    sharp = min(max(config.max_sigma_deg, planes_sigma_deg), unsure_max_sigma_deg)
    upright = config.upright_sigma_deg
    alone = up_from_line_frame(
        segments, rectification, CAMERA_UP, upright, config, prior_cone_deg=cone, max_sigma_deg=sharp
    )
    if not alone.ok:
        return near
    if near.ok:
        apart = angle_deg(alone.up, near.up)
        if apart <= conflict_sigmas * math.hypot(near.sigma_deg, alone.sigma_deg):
            return _both(near.up, near.sigma_deg, alone, f"{near.reason}, with the upright frame's up")
        # Two frames that contradict each other: the vertical lines, the direct witness of
        # up, choose (a sloped family, handrails or the staircase's slope, taken for a
        # horizontal direction turns up about the steps' edges and loses the verticals).
        seg, sigma = _segments_and_sigma(segments, rectification, config)
        tol = math.radians(config.frame_inlier_deg)
        v_near, v_alone = (_support(seg, sigma, u, tol) for u in (near.up, alone.up))
        if not overrule or v_alone <= _VERTICAL_MARGIN * v_near:
            return near
        why = f"{alone.reason} ({apart:.1f} deg from the planes' frame; more vertical lines point at its up)"
        return dataclasses.replace(alone, reason=why)
    apart = angle_deg(alone.up, planes_up)
    if apart > conflict_sigmas * math.hypot(planes_sigma_deg, alone.sigma_deg):
        if not overrule:
            return near
        why = f"{alone.reason} ({apart:.1f} deg from the planes' up, which it overrules)"
        return dataclasses.replace(alone, reason=why)
    # No frame near the planes' up, and the upright one does not contradict it: both.
    return _both(planes_up, planes_sigma_deg, alone, f"{alone.reason}, with the planes' up")


def _fit_weight(angle: np.ndarray, tol: float) -> np.ndarray:
    """A segment's share of its gain at ``angle`` (radians) from a direction: 1 on it,
    falling quadratically to 0 at ``tol`` (the frame's truncated quadratic)."""
    return np.maximum(0.0, 1.0 - (angle / tol) ** 2)


def _segments_and_sigma(
    segments: np.ndarray, rectification: Rectification, config: VerticalLinesConfig
) -> tuple[_Segments, np.ndarray]:
    """The segments in the camera's rays, and each one's direction sigma (radians): its
    ends' noise and the structure's own (real edges are not exactly plumb or level)."""
    seg = _Segments(np.asarray(segments, dtype=np.float64), rectification, config.endpoint_sigma_px)
    return seg, np.sqrt(seg.noise**2 + math.radians(config.structure_sigma_deg) ** 2)


def _both(up: np.ndarray, sigma_deg: float, other: GravityEstimate, reason: str) -> GravityEstimate:
    """The inverse-variance mean of ``up`` (1-sigma ``sigma_deg``) and ``other``'s up, as
    ``other`` otherwise. Its sigma is the sharper one's (two frames share their segments),
    widened by half the angle between the two (what their gap says of the error)."""
    wa, wb = sigma_deg**-2, other.sigma_deg**-2
    mean = wa * up + wb * other.up
    mean /= np.linalg.norm(mean)
    sigma = math.hypot(min(sigma_deg, other.sigma_deg), 0.5 * angle_deg(up, other.up))
    return dataclasses.replace(other, up=mean, sigma_deg=sigma, reason=reason)


def _support(seg: _Segments, sigma: np.ndarray, up: np.ndarray, tol: float) -> float:
    """What the segments pointing at ``up``'s vanishing point (within ``tol``) gain
    (chi^2, as in the frame's score)."""
    a = np.abs(seg.angles(up[None]))[0]
    return float(_fit_weight(a, tol) @ (tol / sigma) ** 2)
