"""Steps the image's line segments show: beyond the last one, and inside double steps
(issue 11).

Far up a staircase the risers are a few pixels of disparity noise tall: they form no plane
and their samples do not sit at one position (:mod:`.continuation` then finds nothing),
but their edges are still plain in the image. On realistic rendered stairs a step's nosing
is a long straight intensity edge (a dark strip, or the shading change between riser and
tread) where the matcher holds nothing (docs/benchmarks.md, "Twelfth session").

A nosing is a horizontal 3D line along the staircase's lateral direction ``v``. The line
segments of the rectified left image (LSD, found beside the matcher for gravity and the
Manhattan fill, :mod:`stereo_terrain.gravity.from_lines`) that are images of such lines are
those whose plane through the camera centre contains ``v``. Where the chain's last step is
``(a_k, top_k)`` and its steps' median rise and run are ``R`` and ``L``, the next nosing
lies on the staircase's pitch line ``(a_k + lam L, top_k + lam R)`` near ``lam = 1``: each
such segment's plane meets that line at one ``lam``. A height error of the last top, or a
nosing near the cameras' horizon, would make the segment's own depth (its plane met with
the tread's height) unreliable; the pitch line's slope keeps the intersection well posed.

The next step is accepted where:

- segments within ``_LAM_GROUP`` of one ``lam`` in ``[1 - tol, 1 + tol]`` (``tol`` =
  ``nosing_run_tolerance``) cover ``nosing_min_cover`` of the staircase's width as far as
  it is in view at that depth: texture, grout lines and plank joints are short or broken
  lines; a nosing spans the staircase. The group that covers most is the candidate; of
  groups that cover as much (each across the whole staircase), the one nearest ``lam =
  1`` (with a run measured a few centimetres long, the next nosing and a line beyond it
  both fall within the tolerance);
- where the cameras are above the last tread (so the foot of the next riser is in view)
  and see it steeply enough that the foot's line is not the last nosing's, segments on
  that tread's height at the same position cover ``nosing_min_foot_cover``: a riser has a
  foot; the grout lines of a landing's tiles or the far edge of a platform have a floor at
  that height beyond them instead.

and it is not added where the samples in the image of its riser lie on the last tread's
height beyond it (a landing the matcher holds: tile joints are long lines too) or a wall
stands across the stairs there.

A step so found gets the staircase's median run as its position and the median rise (a
step found beyond the last riser plane by :mod:`.continuation` does the same, and says so
with ``rise_inferred``): the segment gives where a nosing is, not precisely which of a
nosing strip's two edges it is. Measured on the same renders, its positions are closer to
the truth that way (docs/benchmarks.md).

Where the segments show no next nosing, the image itself is asked
(:func:`_edge_nosing`, ``nosing_edge_contrast``; the pipeline hands the rectified left
image over in :class:`ImageLines`): LSD keeps only the lines it is sure of, and a white
nosing between two white faces seen from below gives it a few short pieces. Along the
predicted line's image, a nosing is a step edge: the grey levels a few pixels either side
differ, with one sign, over ``nosing_min_cover`` of the width (texture differs either way,
a plank gap or a dark strip's middle not at all; :func:`_edge_cover`). The same foot test
follows, with the foot's image apart from the nosing's (a camera a little above the last
tread sees the tread's far end as one edge for both), and no line within ``_HORIZON_DEG``
of the cameras' height is taken (the horizon, the sky's edge).

The same test on other pitch lines serves three more cases: a lone step, whose run is the
one that puts two nosings beyond it (:func:`_run_from_two_nosings`); a double step, split
where the nosing halfway shows (:func:`_split_double_steps`); and steps taller than a
stair rise, a chain of every other riser, split the same way (:func:`_split_too_tall`).

Each step's nosing height as its segments show it on its riser plane
(:func:`nosing_heights`) is what the staircase's rise is fitted to where two or more show
(:func:`.uniform.rise_from_nosings`, ``TerrainConfig.nosing_rise``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..msac import Plane
from ..planes.orientation import PlaneSet
from .continuation import INLIERS, walls_across
from .model import Step, TerrainConfig
from .risers import riser_distance

#: Segments whose pitch-line positions are within this (in steps) are one nosing.
_LAM_GROUP = 0.08
#: A segment is parallel to the nosings when its plane through the camera is within this
#: of containing ``v``, plus the angle one pixel of end error makes over its length.
_PARALLEL_DEG = 2.0
#: Segments reaching the image's border whose plane through the camera is within this of
#: horizontal are not taken for nosings (:func:`_parallel_segments`).
_HORIZON_DEG = 1.0
#: A refined top is taken from segments within this (metres) of each other.
_TOP_GROUP_M = 0.01
#: ... and cover this share of the step's visible width.
_TOP_MIN_COVER = 0.3
#: The lateral step (metres) at which the visible part of a nosing is measured.
_LATERAL_STEP_M = 0.02
#: The least part of a nosing that must be in view (metres) to judge it.
_MIN_VISIBLE_M = 0.15
#: The cameras must be this much above a tread to see the foot of the riser behind it.
_FOOT_VISIBLE_M = 0.03
#: Samples on the tread's height beyond a would-be riser that make it a landing.
_MIN_FLOOR_SAMPLES = 5


@dataclass(frozen=True)
class ImageLines:
    """The rectified left image's line segments and the camera that saw them, for the
    terrain stage.

    Attributes
    ----------
    segments : (N, 4) float64
        ``x1, y1, x2, y2`` in pixels of the rectified left image.
    focal_px, cx, cy : float
        The rectified left camera.
    image_size : (width, height)
    T_frame_camera : (4, 4) float64
        Rectified left camera to the terrain's (gravity-aligned) frame.
    at_border : (M, 4) float64
        Segments that reach the border of the image's valid region, clipped there (a
        staircase wider than the view has all its nosings so); ``segments`` are whole.
    image : (H, W) array or None
        The rectified left image itself, where a nosing no segment shows is looked for
        as a step edge in its grey levels (``TerrainConfig.nosing_edge_contrast``).
    """

    segments: np.ndarray = field(repr=False)
    focal_px: float
    cx: float
    cy: float
    image_size: tuple[int, int]
    T_frame_camera: np.ndarray = field(repr=False)
    at_border: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 4)))
    image: np.ndarray | None = field(repr=False, default=None)

    @property
    def centre(self) -> np.ndarray:
        """The camera centre in the terrain's frame."""
        return np.asarray(self.T_frame_camera[:3, 3], dtype=np.float64)

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Directions (not unit) of the rays through ``pixels`` ``(N, 2)``, terrain frame."""
        d = np.column_stack(
            [
                (pixels[:, 0] - self.cx) / self.focal_px,
                (pixels[:, 1] - self.cy) / self.focal_px,
                np.ones(len(pixels)),
            ]
        )
        out: np.ndarray = d @ self.T_frame_camera[:3, :3].T
        return out

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(N, 2)`` and depths ``(N,)`` of terrain-frame ``points``."""
        R = self.T_frame_camera[:3, :3]
        X = (points - self.centre) @ R  # R^T (p - c), row-wise
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.column_stack(
                [self.focal_px * X[:, 0] / X[:, 2] + self.cx, self.focal_px * X[:, 1] / X[:, 2] + self.cy]
            )
        return uv, X[:, 2]


@dataclass(frozen=True)
class _Segments:
    """The segments parallel to the nosings, with their end rays and planes."""

    d0: np.ndarray
    d1: np.ndarray
    normal: np.ndarray


@dataclass(frozen=True)
class _View:
    """One staircase as the image's lines see it: the camera (``lines``), the segments
    parallel to its nosings, its axis ``u`` and lateral direction ``v``, and the part of
    its width looked at (``lat``, metres along ``v``)."""

    lines: ImageLines
    segs: _Segments
    u: np.ndarray
    v: np.ndarray
    lat: tuple[float, float]


def nosing_steps(
    steps: list[Step],
    planes: PlaneSet,
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    lines: ImageLines,
    config: TerrainConfig,
) -> tuple[list[Step], int, int]:
    """``steps`` with each step taller than a stair rise and each double step split where
    the image shows the nosing between (:func:`_split_too_tall`,
    :func:`_split_double_steps`), and the steps beyond the last one whose nosings the
    image's segments show (module docstring); how many were added beyond, and how many
    split.

    Parameters
    ----------
    steps : the chain's steps, nearest first; nothing is done without a measured rise, nor
        without a known run unless the chain is a lone step
    planes : PlaneSet the steps were built from (gravity-aligned frame)
    P : (N, 3) float64, its samples' points
    u, v : (3,) float, the stair axis and the lateral direction (terrain frame)
    lateral : the staircase's lateral extent along ``v``, metres
    lines : ImageLines
    config : TerrainConfig (``nosing_steps``, ``max_nosing_steps``,
        ``nosing_run_tolerance``, ``nosing_min_cover``, ``nosing_min_foot_cover``)
    """
    if not config.nosing_steps or not steps:
        return steps, 0, 0
    rises = [s.rise_m for s in steps if not s.rise_inferred]
    runs = [s.run_m for s in steps if s.run_m is not None]
    edges = config.nosing_edge_contrast > 0 and lines.image is not None
    if not rises or not (runs or len(steps) == 1):
        return steps, 0, 0
    if len(lines.segments) + len(lines.at_border) == 0 and not (edges and runs):
        return steps, 0, 0
    rise = float(np.median(rises))
    segs = _parallel_segments(lines, v)
    if segs is None:
        if not (edges and runs):
            return steps, 0, 0
        segs = _Segments(np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)))
    view = _View(lines, segs, u, v, _inner(lateral))
    # The image smoothed for the edges, once and only when a nosing is looked for there.
    smoothed = functools.cache(lambda: smoothed_image(lines)) if edges else None
    out, tall = _split_too_tall(list(steps), view, config)
    out, split = _split_double_steps(out, view, config)
    split += tall
    if split:
        rise = float(np.median([s.rise_m for s in out]))
        runs = [s.run_m for s in out if s.run_m is not None]
    a, top = out[-1].axis_position_m, out[-1].top_z_m
    anchor = _refined_top(view, a, top, rise)
    if runs:
        run = float(np.median(runs))
    else:
        # A lone step: the run that puts two nosings beyond it (module docstring).
        found = _run_from_two_nosings(view, a, anchor, rise, config)
        if found is None:
            return out, 0, split
        run = found
    walls = np.asarray(walls_across(planes, P, u, config), dtype=np.float64)
    added = 0
    while added < config.max_nosing_steps:
        lam = _next_nosing(view, a, anchor, rise, run, config, smoothed)
        if lam is None and smoothed is not None:
            lam = _edge_nosing(view, smoothed(), a, anchor, rise, run, config)
        if lam is None:
            break
        last = out[-1]
        a_new = a + run
        if walls.size and float(np.min(np.abs(walls - a_new))) < config.merge_distance_m:
            break  # a wall across the stairs there: its joints and edges are no nosings
        if _floor_where_the_riser_would_be(planes, P, view, a_new, last.top_z_m, rise):
            break  # the samples see the last tread go on (a landing's tiles, a platform)
        out[-1] = dataclasses.replace(last, run_m=run)
        out.append(_inferred_step(u, a_new, last.top_z_m + rise, rise, None))
        added += 1
        a, anchor = a_new, _refined_top(view, a_new, anchor + rise, rise)
    return out, added, split


def _inner(lateral: tuple[float, float]) -> tuple[float, float]:
    """The part of a staircase's lateral extent whose nosings are looked at: not its side
    edges (stringers, walls)."""
    margin = 0.1 * (lateral[1] - lateral[0])
    return (lateral[0] + margin, lateral[1] - margin)


def nosing_heights(
    steps: list[Step],
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    lines: ImageLines,
) -> list[float | None]:
    """Each step's nosing height as the image's segments show it on its riser plane
    (:func:`_nosing_top`: the segments within a third of the steps' median measured rise
    of its top that cover ``_TOP_MIN_COVER`` of its width); None where none do. The
    segments place a nosing to a fraction of a pixel of elevation, a few millimetres at
    stair distances, where a height from the samples carries centimetres of disparity
    noise (:mod:`.uniform` fits the staircase's rise to them).

    Parameters
    ----------
    steps : the staircase's steps, nearest first (``axis_position_m``, ``top_z_m``)
    u, v : (3,) float, the stair axis and the lateral direction (terrain frame)
    lateral : the staircase's lateral extent along ``v``, metres
    lines : ImageLines
    """
    rises = [s.rise_m for s in steps if not s.rise_inferred]
    segs = _parallel_segments(lines, v) if rises else None
    if segs is None:
        return [None] * len(steps)
    view = _View(lines, segs, u, v, _inner(lateral))
    rise = float(np.median(rises))
    return [_nosing_top(view, s.axis_position_m, s.top_z_m, rise) for s in steps]


def _split_too_tall(
    steps: list[Step],
    view: _View,
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """``steps`` with each step taller than a stair rise (``max_rise_m``) split where the
    image shows the nosing halfway, and how many were split.

    Where every other riser formed no plane (or the first did not), the chain is one of
    double steps: twice the rise, twice the run, self-consistent, so
    :func:`_split_double_steps` has no ordinary step to compare with. A rise above
    ``max_rise_m`` is no stair's (the samples' continuation carries it on at that rise).
    A later step is split as a double step is; the first one, the second riser chained
    from the ground, gets a step of half its rise in front of it, a run before it (half
    the staircase's median run where every step is too tall, else that run), where that
    step's nosing shows on the pitch line from the ground. Halves of less than
    ``min_rise_m`` or runs of less than ``min_run_m`` are not made."""
    u = view.u
    out = list(steps)
    if not any(s.rise_m > config.max_rise_m for s in out):
        return out, 0
    runs = [s.run_m for s in out if s.run_m is not None]
    all_tall = all(s.rise_m > config.max_rise_m for s in out)
    split = 0
    i = 0
    while i < len(out):
        step = out[i]
        half_rise = step.rise_m / 2
        if step.rise_m <= config.max_rise_m or half_rise < config.min_rise_m:
            i += 1
            continue
        if i == 0:
            if not runs:
                break
            run = float(np.median(runs)) / (2 if all_tall else 1)
            ground = step.top_z_m - step.rise_m
            a_before = step.axis_position_m - run
            if run < config.min_run_m or (
                _next_nosing(view, a_before - run, ground, half_rise, run, config) is None
            ):
                i += 1
                continue
            before = _inferred_step(u, a_before, ground + half_rise, half_rise, run)
            out[0] = dataclasses.replace(step, rise_m=half_rise, rise_inferred=True)
            out.insert(0, before)
        else:
            run_before = out[i - 1].run_m
            if (
                run_before is None
                or run_before / 2 < config.min_run_m
                or not _split_at_nosing(out, i, view, half_rise, run_before / 2, config)
            ):
                i += 1
                continue
        split += 1
        i += 2
    return out, split


def _split_at_nosing(
    out: list[Step], i: int, view: _View, half_rise: float, half_run: float, config: TerrainConfig
) -> bool:
    """Split ``out[i]`` in two, in place, where the nosing halfway along the pitch from
    ``out[i - 1]`` (``half_rise``, ``half_run``) shows (:func:`_next_nosing`): the run
    before it halved, a step of ``half_rise`` inserted, both rises inferred. Whether it
    was split."""
    prev, step = out[i - 1], out[i]
    if _next_nosing(view, prev.axis_position_m, prev.top_z_m, half_rise, half_run, config) is None:
        return False
    a_mid = prev.axis_position_m + half_run
    out[i - 1] = dataclasses.replace(prev, run_m=half_run)
    out[i] = dataclasses.replace(step, rise_m=half_rise, rise_inferred=True)
    out.insert(i, _inferred_step(view.u, a_mid, prev.top_z_m + half_rise, half_rise, half_run))
    return True


def _inferred_step(u: np.ndarray, a: float, top: float, rise: float, run: float | None) -> Step:
    """A step whose riser formed no plane, at ``a`` along the stair axis ``u`` (inferred rise)."""
    plane = Plane(-u, a)  # vertical, facing the robot, u . x = a
    distance = riser_distance(plane, a, u)
    return Step(rise, run, distance, None, top, a, plane, None, rise_inferred=True, position_inferred=True)


def _split_double_steps(
    steps: list[Step],
    view: _View,
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """``steps`` with each double step split where the image shows the nosing between, and
    how many were split.

    A riser that formed no plane between two that did makes one step of two: about twice
    the staircase's rise, after a run about twice its run (the others' medians; without
    another run, twice the ordinary range). Where a nosing lies halfway along the pitch
    from the step before (:func:`_next_nosing`, with half the double rise and run), the
    step becomes two of half its rise, the run before it halved; both rises are inferred.
    Not the first step: the ground before it has no nosing to start the pitch from."""
    out = list(steps)
    split = 0
    i = 1
    while i < len(out):
        step, prev = out[i], out[i - 1]
        rises = [s.rise_m for j, s in enumerate(out) if j != i and not s.rise_inferred]
        runs = [s.run_m for j, s in enumerate(out) if j != i - 1 and s.run_m is not None]
        run_before = prev.run_m
        if step.rise_inferred or not rises or run_before is None:
            i += 1
            continue
        rise = float(np.median(rises))
        if runs:
            run = float(np.median(runs))
            double_run = 1.5 * run <= run_before <= 2.5 * run
        else:
            double_run = 2 * config.continue_min_run_m <= run_before <= 2 * config.continue_max_run_m
        if not (double_run and 1.6 * rise <= step.rise_m <= 2.4 * rise):
            i += 1
            continue
        if not _split_at_nosing(out, i, view, step.rise_m / 2, run_before / 2, config):
            i += 1
            continue
        split += 1
        i += 2
    return out, split


def _floor_where_the_riser_would_be(
    planes: PlaneSet,
    P: np.ndarray,
    view: _View,
    s_new: float,
    top: float,
    rise: float,
) -> bool:
    """Whether the samples in the image of the riser that would stand at ``s_new`` on the
    tread at ``top`` lie on that tread's height beyond it (at least ``_MIN_FLOOR_SAMPLES``,
    and more than lie at ``s_new``): the tread goes on, as a landing does. Where the
    matcher holds the faces (textured stairs) this tells a landing's tile joints from a
    step; where it holds nothing there (the far faces this module is for) it says nothing."""
    lines, u, v = view.lines, view.u, view.v
    span = _visible(view, s_new, top + 0.5 * rise)
    if span is None:
        return False
    m = 0.1 * (span[1] - span[0])
    corners = [(span[0] + m, 0.15), (span[1] - m, 0.15), (span[1] - m, 0.85), (span[0] + m, 0.85)]
    ends = np.array([s_new * u + t * v + [0.0, 0.0, top + f * rise] for t, f in corners])
    quad, depth = lines.project(ends)
    if not (depth > 0).all():
        return False
    smp = planes.samples
    inside = _in_convex(quad, smp.cols.astype(np.float64), smp.rows.astype(np.float64))
    if not inside.any():
        return False
    q = P[inside]
    thr = INLIERS.inlier_threshold_m(smp.sigma_m[inside])
    s = q @ u
    at_riser = np.abs(s - s_new) < thr
    on_floor = (np.abs(q[:, 2] - top) < thr) & (s > s_new - thr) & ~at_riser
    n_floor = int(np.count_nonzero(on_floor))
    return n_floor >= _MIN_FLOOR_SAMPLES and n_floor > int(np.count_nonzero(at_riser))


def _in_convex(quad: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Which points ``(x, y)`` lie inside the convex polygon ``quad`` ``(K, 2)`` (either
    winding)."""
    signs = []
    for k in range(len(quad)):
        (x0, y0), (x1, y1) = quad[k], quad[(k + 1) % len(quad)]
        signs.append((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0))
    cross = np.array(signs)
    return np.asarray(np.all(cross >= 0, axis=0) | np.all(cross <= 0, axis=0))


def _parallel_segments(lines: ImageLines, v: np.ndarray) -> _Segments | None:
    """The segments that are images of lines along ``v``; None when there are none.

    Of those that reach the image's border, not the ones whose plane through the camera is
    within ``_HORIZON_DEG`` of horizontal: a line across the view at the cameras' height is
    as likely the horizon or a far wall's foot as a nosing (one made a step beyond a
    landing on a default-profile render). A whole one there is kept: the nosings of a
    staircase whose top is at the cameras' height are such segments."""
    whole = np.asarray(lines.segments, dtype=np.float64).reshape(-1, 4)
    border = np.asarray(lines.at_border, dtype=np.float64).reshape(-1, 4)
    s = np.concatenate([whole, border])
    d0, d1 = lines.rays(s[:, :2]), lines.rays(s[:, 2:])
    n = np.cross(d0, d1)
    norm = np.linalg.norm(n, axis=1)
    length = np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1])
    ok = (norm > 1e-12) & (length > 0)
    n[ok] /= norm[ok, None]
    tol = np.sin(np.radians(_PARALLEL_DEG) + 2.0 / np.maximum(length, 1.0))
    ok &= np.abs(n @ v) < tol
    ok[len(whole) :] &= np.abs(n[len(whole) :, 2]) < math.cos(math.radians(_HORIZON_DEG))
    if not ok.any():
        return None
    return _Segments(d0[ok], d1[ok], n[ok])


def _on_height(lines: ImageLines, d: np.ndarray, z: np.ndarray | float) -> np.ndarray:
    """Where the rays ``d`` meet the horizontal plane at height ``z`` (NaN behind or along)."""
    c = lines.centre
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z - c[2]) / d[:, 2]
    p: np.ndarray = c + t[:, None] * d
    p[~(t > 0)] = np.nan
    return p


def _visible(view: _View, s: float, z: float) -> tuple[float, float] | None:
    """The part of ``lat`` in view (in the image, in front of the camera) of the line at
    position ``s`` along ``u`` and height ``z``; None when less than ``_MIN_VISIBLE_M``."""
    lines, u, v, lat = view.lines, view.u, view.v, view.lat
    t = np.arange(lat[0], lat[1] + 1e-9, _LATERAL_STEP_M)
    if len(t) < 2:
        return None
    uv, depth = lines.project(s * u + t[:, None] * v + np.array([0.0, 0.0, z]))
    w, h = lines.image_size
    with np.errstate(invalid="ignore"):
        ok = (depth > 0.2) & (uv[:, 0] > 3) & (uv[:, 0] < w - 4) & (uv[:, 1] > 3) & (uv[:, 1] < h - 4)
    if not ok.any():
        return None
    lo, hi = float(t[ok][0]), float(t[ok][-1])
    return (lo, hi) if hi - lo >= _MIN_VISIBLE_M else None


def _cover(lo: np.ndarray, hi: np.ndarray, span: tuple[float, float]) -> float:
    """The share of ``span`` that the union of the intervals ``[lo, hi]`` covers."""
    a, b = np.maximum(lo, span[0]), np.minimum(hi, span[1])
    keep = b > a
    total, reach = 0.0, -math.inf
    for x, y in sorted(zip(a[keep], b[keep], strict=True)):
        if y > reach:
            total += y - max(x, reach)
            reach = y
    return total / (span[1] - span[0])


def _lateral_on_height(view: _View, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's lateral extent ``(lo, hi)`` where its end rays meet height ``z`` (one
    per segment; NaN where a ray misses)."""
    lines, segs, v = view.lines, view.segs, view.v
    a = _on_height(lines, segs.d0, z) @ v
    b = _on_height(lines, segs.d1, z) @ v
    return np.minimum(a, b), np.maximum(a, b)


def _next_nosing(
    view: _View,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    config: TerrainConfig,
    smoothed: Callable[[], np.ndarray] | None = None,
) -> float | None:
    """The pitch-line position ``lam`` of the next nosing after the step at ``(a_k, top_k)``,
    or None when the segments show none (module docstring). ``smoothed`` gives the smoothed
    image (:func:`smoothed_image`) where a foot the segments do not show may be looked for
    in it."""
    lines, segs, u, v, lat = view.lines, view.segs, view.u, view.v, view.lat
    c = lines.centre
    span = _visible(view, a_k + run, top_k + rise)
    if span is None:
        return None
    anchor = a_k * u + 0.5 * (lat[0] + lat[1]) * v + np.array([0.0, 0.0, top_k])
    pitch = run * u + np.array([0.0, 0.0, rise])
    den = segs.normal @ pitch
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -(segs.normal @ (anchor - c)) / den
    tol = config.nosing_run_tolerance
    near = np.isfinite(lam) & (np.abs(den) > 1e-9) & (lam > 1.0 - tol) & (lam < 1.0 + tol)
    if not near.any():
        return None
    lo, hi = _lateral_on_height(view, top_k + lam * rise)
    near &= np.isfinite(lo) & np.isfinite(hi)
    # The group of segments that covers most of the staircase's width; of groups that
    # cover as much (lines across the whole staircase cover all of it), the nearest to
    # the expected position: with a run measured a few centimetres long, the next nosing
    # and a line beyond it (the tread's far edge, the nosing after) both fall within the
    # tolerance.
    found: dict[float, float] = {}
    for x in lam[near]:
        group = near & (np.abs(lam - x) < _LAM_GROUP)
        at = float(np.median(lam[group]))
        if at not in found:
            found[at] = _cover(lo[group], hi[group], span)
    widest = max(found.values(), default=0.0)
    if widest < config.nosing_min_cover:
        return None
    first = min((at for at, cover in found.items() if cover == widest), key=lambda at: abs(at - 1.0))
    # Where the widest group's riser foot does not show, it is no nosing (a tread's far
    # edge, a rail beyond it): the groups nearer the expected position are tried in turn.
    nearer = [
        at
        for at, cover in found.items()
        if cover >= config.nosing_min_cover and abs(at - 1.0) < abs(first - 1.0)
    ]
    ranked = [first, *sorted(nearer, key=lambda at: abs(at - 1.0))]
    for best in ranked:
        if _foot_shows(view, segs, anchor, pitch, den, a_k, top_k, rise, run, best, config):
            return best
        # No segments at the foot: with the image, its grey levels may still show it.
        if smoothed is not None and _foot_in_grey_levels(view, smoothed, a_k, top_k, rise, run, best, config):
            return best
    return None


def _foot_in_grey_levels(
    view: _View,
    smoothed: Callable[[], np.ndarray],
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    best: float,
    config: TerrainConfig,
) -> bool:
    """Whether the nosing at pitch position ``best`` shows as an edge in the smoothed image
    (``smoothed()``) and the foot of the riser below it too (:func:`_edge_foot_shows`)."""
    width = _visible(view, a_k + best * run, top_k + best * rise)
    if width is None:
        return False
    nosing = _line_pixels(view, a_k + best * run, top_k + best * rise, width)
    if nosing is None:
        return False
    image = smoothed()
    edge = _edge_cover(image, nosing, config.nosing_edge_contrast)
    if abs(edge) < config.nosing_min_cover:
        return False
    return _edge_foot_shows(view, image, a_k, top_k, rise, run, best, edge, width, config)


def _foot_shows(
    view: _View,
    segs: _Segments,
    anchor: np.ndarray,
    pitch: np.ndarray,
    den: np.ndarray,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    best: float,
    config: TerrainConfig,
) -> bool:
    """Whether the foot of the riser below a nosing found at pitch position ``best`` is
    in the image where it must be (:func:`_next_nosing`)."""
    c = view.lines.centre
    if not c[2] > top_k + _FOOT_VISIBLE_M:
        return True
    # The last tread is seen from above, so the next riser's foot is in view: it must
    # show too (a landing's tile joint or far edge has the floor beyond it instead).
    # The feet lie on the pitch line a rise lower: the same well-posed intersection.
    # Where the tread is seen so flat that the foot's line and the last nosing's are
    # one (their pitch positions within twice a group), the foot says nothing.
    foot_anchor = anchor - np.array([0.0, 0.0, rise])
    last_nosing = np.cross(anchor - c, view.v)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam_last = -(last_nosing @ (foot_anchor - c)) / (last_nosing @ pitch)
    foot_span = _visible(view, a_k + best * run, top_k + (best - 1.0) * rise)
    if foot_span is None or abs(lam_last - best) < 2 * _LAM_GROUP:
        return True
    with np.errstate(divide="ignore", invalid="ignore"):
        lam_f = -(segs.normal @ (foot_anchor - c)) / den
    at = np.isfinite(lam_f) & (np.abs(den) > 1e-9) & (np.abs(lam_f - best) < _LAM_GROUP)
    flo, fhi = _lateral_on_height(view, top_k + (lam_f - 1.0) * rise)
    at &= np.isfinite(flo) & np.isfinite(fhi)
    return _cover(flo[at], fhi[at], foot_span) >= config.nosing_min_foot_cover


def _run_from_two_nosings(
    view: _View,
    a_k: float,
    top_k: float,
    rise: float,
    config: TerrainConfig,
) -> float | None:
    """For a lone step at ``(a_k, top_k)``: of the runs between ``continue_min_run_m`` and
    ``continue_max_run_m`` (1 cm apart) for which segments cover ``nosing_min_cover`` of
    the width at both the next nosing and the one after, the one that puts them nearest
    one and two steps along the pitch line; None when no run has both."""
    lines, segs, u, v, lat = view.lines, view.segs, view.u, view.v, view.lat
    c = lines.centre
    anchor = a_k * u + 0.5 * (lat[0] + lat[1]) * v + np.array([0.0, 0.0, top_k])
    lift = segs.normal @ (anchor - c)
    runs = np.arange(config.continue_min_run_m, config.continue_max_run_m + 1e-9, 0.01)
    # Every run at once: each segment's pitch-line position (runs x segments); only the
    # runs with a segment near both nosings are looked at further.
    den = (segs.normal @ u)[None, :] * runs[:, None] + (segs.normal[:, 2] * rise)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.where(np.abs(den) > 1e-9, -lift[None, :] / den, np.nan)
    near = [np.abs(lam - k) < k * _LAM_GROUP for k in (1, 2)]
    best, best_err = None, math.inf
    for i in np.flatnonzero(near[0].any(axis=1) & near[1].any(axis=1)):
        run = float(runs[i])
        err = 0.0
        for k in (1, 2):
            span = _visible(view, a_k + k * run, top_k + k * rise)
            if span is None:
                err = math.inf
                break
            lo, hi = _lateral_on_height(view, top_k + lam[i] * rise)
            at = near[k - 1][i] & np.isfinite(lo) & np.isfinite(hi)
            if _cover(lo[at], hi[at], span) < config.nosing_min_cover:
                err = math.inf
                break
            err += abs(float(np.median(lam[i][at])) - k) / k
        if err < best_err:
            best, best_err = run, err
    return best


def _refined_top(view: _View, a_k: float, top_k: float, rise: float) -> float:
    """:func:`_nosing_top`, else ``top_k``."""
    top = _nosing_top(view, a_k, top_k, rise)
    return top_k if top is None else top


def _nosing_top(
    view: _View,
    a_k: float,
    top_k: float,
    rise: float,
) -> float | None:
    """The height of the step's nosing as its segments show it on its riser plane
    ``u . x = a_k`` (of the groups of segments within a third of a rise of ``top_k`` that
    cover ``_TOP_MIN_COVER`` of its width, the nearest; the top found from the samples is
    biased low, docs/benchmarks.md "Tenth session"); None where none does, or the step is
    not in view."""
    lines, segs, u, v = view.lines, view.segs, view.u, view.v
    span = _visible(view, a_k, top_k)
    if span is None:
        return None
    c = lines.centre
    n = segs.normal
    base = a_k * u + 0.5 * (span[0] + span[1]) * v
    with np.errstate(divide="ignore", invalid="ignore"):
        z = -(n @ (base - c)) / n[:, 2]
    near = np.isfinite(z) & (np.abs(z - top_k) < rise / 3.0)
    if not near.any():
        return None
    # The segments' ends on the riser plane, for their lateral extent.
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (a_k - c @ u) / (segs.d0 @ u)
        t1 = (a_k - c @ u) / (segs.d1 @ u)
    e0 = (c + t0[:, None] * segs.d0) @ v
    e1 = (c + t1[:, None] * segs.d1) @ v
    lo, hi = np.minimum(e0, e1), np.maximum(e0, e1)
    near &= np.isfinite(lo) & np.isfinite(hi)
    best: float | None = None
    best_dz = math.inf
    for x in z[near]:
        group = near & (np.abs(z - x) < _TOP_GROUP_M)
        if _cover(lo[group], hi[group], span) >= _TOP_MIN_COVER and abs(x - top_k) < best_dz:
            best, best_dz = float(np.median(z[group])), abs(x - top_k)
    return best


#: Grey levels are compared this far (pixels) either side of a predicted nosing's image
#: (:func:`_edge_cover`): past a dark strip or a plank gap's half width, so that a thin
#: line (the same face on both sides) shows no step edge.
_EDGE_OFFSET_PX = 2.5
#: The image is smoothed with this Gaussian sigma (pixels) before (JPEG blocks, noise).
_EDGE_SMOOTH_PX = 1.0
#: The grey levels either side of a nosing must differ by more than they vary along it:
#: by this many times the larger side's spread (its median absolute deviation, scaled to
#: a standard deviation). A face's texture, or its blotches, vary along the line as much
#: as across it.
_EDGE_ALONG_SCALE = 1.5
#: Positions along the pitch line tried for the next nosing, in steps.
_EDGE_LAM_STEP = 0.02
#: A predicted line's image must be at least this long (pixels) to be judged.
_EDGE_MIN_PX = 12
#: A riser's foot must lie at least this far (pixels) from the nosings above and below it
#: in the image to be told from them as an edge (twice the comparison's reach, with the
#: smoothing).
_FOOT_APART_PX = 8.0


def smoothed_image(lines: ImageLines) -> np.ndarray:
    """The rectified left image (``lines.image``, which must be there), float32 and
    smoothed, for :func:`_edge_cover`."""
    img = np.asarray(lines.image, dtype=np.float32)
    if img.ndim == 3:
        img = img.mean(axis=2, dtype=np.float32)
    return cv2.GaussianBlur(img, (0, 0), _EDGE_SMOOTH_PX)


def _lines_pixels(
    view: _View, s: np.ndarray, z: np.ndarray, span: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Pixels about one apart along the images of the lines at ``s`` along ``u`` and
    heights ``z`` (each ``(K,)``) over the lateral ``span``: ``(K, n, 2)``, one count
    ``n`` for all (the longest image's length), and which of them count (in front of the
    camera, at least ``_EDGE_MIN_PX`` long). A 3D line's image is straight: its pixels
    lie evenly between its ends' images."""
    lines, u, v = view.lines, view.u, view.v
    base = s[:, None] * u + z[:, None] * np.array([0.0, 0.0, 1.0])
    ends = np.stack([base + t * v for t in span], axis=1)  # (K, 2, 3)
    uv, depth = lines.project(ends.reshape(-1, 3))
    uv, depth = uv.reshape(-1, 2, 2), depth.reshape(-1, 2)
    length = np.hypot(*(uv[:, 1] - uv[:, 0]).T)
    ok = (depth > 0.2).all(axis=1) & np.isfinite(length) & (length >= _EDGE_MIN_PX)
    n = int(np.max(length[ok])) + 1 if ok.any() else 2
    f = np.linspace(0.0, 1.0, n)[None, :, None]
    px = uv[:, :1] + f * (uv[:, 1:] - uv[:, :1])
    return px, ok


def _line_pixels(view: _View, s: float, z: float, span: tuple[float, float]) -> np.ndarray | None:
    """:func:`_lines_pixels` of one line, ``(n, 2)``; None where it does not count."""
    px, ok = _lines_pixels(view, np.array([s]), np.array([z]), span)
    return px[0] if ok[0] else None


def _edge_covers(smoothed: np.ndarray, px: np.ndarray, contrast: float) -> np.ndarray:
    """How much of each straight image line through the pixels ``px`` (``(K, n, 2)``) is
    a step edge (a tread and a riser lit differently), signed: the share of its pixels
    where the grey levels ``_EDGE_OFFSET_PX`` to the left of the line (from its first
    pixel to its last) exceed those to the right by the threshold or more, less the share
    where they fall short of them so. The threshold is ``contrast``, or more where the
    grey levels vary along the line (``_EDGE_ALONG_SCALE``). Texture differs either way
    about as often (its net share is near 0); a thin line (a plank gap, a dark strip's
    middle) has the same face on both sides."""
    d = px[:, -1] - px[:, 0]
    d = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    normal = np.stack([d[:, 1], -d[:, 0]], axis=1)[:, None, :] * _EDGE_OFFSET_PX
    sides = []
    for off in (normal, -normal):
        p = (px + off).astype(np.float32)
        sides.append(
            cv2.remap(
                smoothed,
                np.ascontiguousarray(p[..., 0]),
                np.ascontiguousarray(p[..., 1]),
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=float("nan"),
            )
        )
    diff = sides[0] - sides[1]
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: lines out of the image
        # Each side's grey levels vary along the line too: on a textured face they do by
        # as much as across it, and a step edge must stand out of that.
        spread = [
            1.4826 * np.nanmedian(np.abs(side - np.nanmedian(side, axis=1, keepdims=True)), axis=1)
            for side in sides
        ]
        threshold = np.maximum(contrast, _EDGE_ALONG_SCALE * np.fmax(spread[0], spread[1]))[:, None]
        up = np.count_nonzero(diff >= threshold, axis=1)
        down = np.count_nonzero(diff <= -threshold, axis=1)
    out: np.ndarray = (up - down) / diff.shape[1]
    return out


def _edge_cover(smoothed: np.ndarray, px: np.ndarray, contrast: float) -> float:
    """:func:`_edge_covers` of one line's pixels ``(n, 2)``."""
    return float(_edge_covers(smoothed, px[None], contrast)[0])


def _edge_nosing(
    view: _View,
    smoothed: np.ndarray,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    config: TerrainConfig,
) -> float | None:
    """The pitch-line position of the next nosing after the step at ``(a_k, top_k)``
    where the image's grey levels show it as a step edge (:func:`_edge_cover`), for when
    its line segments show none; None where they do not either (module docstring).

    The position within ``nosing_run_tolerance`` where the edge covers most of the
    visible width, ``nosing_min_cover`` of it at least, with the sign of the last
    nosing's edge where that shows (the same faces, tread over riser, lit alike). Where
    the cameras see the last tread from above, the next riser's foot must show too, over
    ``nosing_min_foot_cover`` of the width, with the opposite sign (riser over tread),
    and apart from both nosings in the image (``_FOOT_APART_PX``: a tread seen so flat
    that its two ends are one edge does not tell a step from a landing's far end)."""
    span = _visible(view, a_k + run, top_k + rise)
    if span is None:
        return None
    contrast = config.nosing_edge_contrast
    tol = config.nosing_run_tolerance
    last = _line_pixels(view, a_k, top_k, span)
    last_cover = 0.0 if last is None else _edge_cover(smoothed, last, contrast)
    sign = math.copysign(1.0, last_cover) if abs(last_cover) >= config.nosing_min_cover else 0.0
    c = view.lines.centre
    lam = np.arange(1.0 - tol, 1.0 + tol + 1e-9, _EDGE_LAM_STEP)
    s_lam, z_lam = a_k + lam * run, top_k + lam * rise
    ahead = s_lam - float(c @ view.u)
    # Not at the cameras' height: the horizon, a far wall's foot, the sky's edge.
    keep = (ahead > 0) & (np.degrees(np.arctan2(np.abs(z_lam - c[2]), ahead)) >= _HORIZON_DEG)
    if not keep.any():
        return None
    px, ok = _lines_pixels(view, s_lam[keep], z_lam[keep], span)
    lam, cover = lam[keep][ok], _edge_covers(smoothed, px[ok], contrast) if ok.any() else np.empty(0)
    if sign != 0.0:
        lam, cover = lam[cover * sign > 0], cover[cover * sign > 0]
    if len(lam) == 0:
        return None
    widest = np.abs(cover) == np.max(np.abs(cover))
    pick = np.flatnonzero(widest)[np.argmin(np.abs(lam[widest] - 1.0))]
    best, best_cover = float(lam[pick]), float(cover[pick])
    if abs(best_cover) < config.nosing_min_cover:
        return None
    if c[2] > top_k + _FOOT_VISIBLE_M and not _edge_foot_shows(
        view, smoothed, a_k, top_k, rise, run, best, best_cover, span, config
    ):
        return None
    return best


def _edge_foot_shows(
    view: _View,
    smoothed: np.ndarray,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    best: float,
    nosing_cover: float,
    span: tuple[float, float],
    config: TerrainConfig,
) -> bool:
    """Whether the foot of the riser under the nosing found at pitch position ``best``
    (its edge's signed cover ``nosing_cover``) shows in the image's grey levels: the
    opposite edge (riser over tread) over ``nosing_min_foot_cover`` of the width, at least
    ``_FOOT_APART_PX`` from that nosing and from the last one in the image (a tread seen
    so flat that its two ends are one edge does not tell a step from a landing's far
    end)."""
    foot = _line_pixels(view, a_k + best * run, top_k, span)
    nosing = _line_pixels(view, a_k + best * run, top_k + best * rise, span)
    last = _line_pixels(view, a_k, top_k, span)
    if foot is None or nosing is None or last is None:
        return False
    if min(_apart_px(foot, nosing), _apart_px(foot, last)) < _FOOT_APART_PX:
        return False
    opposite = -math.copysign(1.0, nosing_cover) * _edge_cover(smoothed, foot, config.nosing_edge_contrast)
    return opposite >= config.nosing_min_foot_cover


def _apart_px(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between the middles of two image lines sampled over one lateral span."""
    return float(np.hypot(*(a[len(a) // 2] - b[len(b) // 2])))
