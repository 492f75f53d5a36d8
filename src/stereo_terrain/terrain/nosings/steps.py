"""The steps the image's nosings add beyond the chain (:func:`nosing_steps`), and each
step's nosing height as its segments show it (:func:`nosing_heights`)."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import numpy as np

from ...planes.orientation import PlaneSet
from ..continuation import INLIERS, walls_across
from ..model import AGREEING_RISE_RATIO, Step, TerrainConfig
from .edges import edge_nosing, smoothed_image
from .next_nosing import LAM_GROUP, inferred_step, next_nosing
from .pitch import lines_beyond, pitch_from_nosings
from .splits import split_double_steps, split_too_tall
from .view import (
    EDGE_ON_PX,
    ImageLines,
    Segments,
    StairView,
    covered_share,
    inner_lateral,
    lateral_on_height,
    on_height,
    on_riser_plane,
    parallel_segments,
    tread_height_px,
    visible_span,
)

#: A refined top is taken from segments within this (metres) of each other.
_TOP_GROUP_M = 0.01


#: ... and cover this share of the step's visible width.
_TOP_MIN_COVER = 0.3


#: Samples on the tread's height beyond a would-be riser that make it a landing.
_MIN_FLOOR_SAMPLES = 5


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
    the image shows the nosing between (:func:`split_too_tall`,
    :func:`split_double_steps`), and the steps beyond the last one whose nosings the
    image's segments show (the package docstring); how many were added beyond, and how many
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
    segs = parallel_segments(lines, v)
    if segs is None:
        if not (edges and runs):
            return steps, 0, 0
        segs = Segments(np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)))
    view = StairView(lines, segs, u, v, inner_lateral(lateral))
    # The image smoothed for the edges, once and only when a nosing is looked for there.
    smoothed = functools.cache(lambda: smoothed_image(lines)) if edges else None
    out, tall = split_too_tall(list(steps), view, config)
    out, split = split_double_steps(out, view, config)
    split += tall
    if split:
        rise = float(np.median([s.rise_m for s in out]))
        runs = [s.run_m for s in out if s.run_m is not None]
    a, top = out[-1].axis_position_m, out[-1].top_z_m
    anchor = _refined_top(view, a, top, rise)
    if runs:
        run = float(np.median(runs))
    else:
        # A lone step: the run that puts two nosings beyond it (the package docstring).
        found = _run_from_two_nosings(view, a, anchor, rise, config)
        if found is None:
            return out, 0, split
        run = found
    walls = np.asarray(walls_across(planes, P, u, config), dtype=np.float64)
    skip_config = dataclasses.replace(config, nosing_run_tolerance=0.5 * config.nosing_run_tolerance)
    added = 0
    while added < config.max_nosing_steps:
        found = _next_nosing_or_edge(view, a, anchor, rise, run, config, smoothed)
        n_new = 1
        if not found and added + 2 <= config.max_nosing_steps and _tread_edge_on(view, a, anchor, rise, run):
            # The next nosing is at the cameras' height: its tread is seen edge-on and the
            # riser above meets it in one line, which tells nothing. The nosing after it,
            # a step further along the same pitch line, is asked instead: of the segments
            # alone and within half the tolerance, as nothing corroborates the nosing
            # skipped (beyond a landing at the cameras' height, the grey levels' test and
            # the whole tolerance took a far wall's tile joints on a default-profile render).
            found = next_nosing(view, a + run, anchor + rise, rise, run, skip_config) is not None
            n_new = 2
        if not found:
            break
        stop = False
        for _ in range(n_new):
            last = out[-1]
            a_new = a + run
            if no_riser_at(planes, P, view, walls, a_new, last.top_z_m, rise, config):
                stop = True
                break
            out[-1] = dataclasses.replace(last, run_m=run)
            out.append(inferred_step(u, a_new, last.top_z_m + rise, rise, None))
            added += 1
            a, anchor = a_new, _refined_top(view, a_new, anchor + rise, rise)
        if stop:
            break
    return out, added, split


def pitched_steps(
    steps: list[Step],
    planes: PlaneSet,
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    ground_z: float,
    lines: ImageLines,
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """``steps`` (a chain whose first riser stands on the ground) on the pitch that the
    image's nosings show (:func:`~.pitch.pitch_from_nosings`), and how many steps it added
    (0: ``steps`` unchanged).

    - A chain of one riser plane is rebuilt on it: the first riser where it was, with the
      pitch's rise, and a step at each further nosing shown (rise and position inferred).
      Taken where the pitch's rise agrees with the riser's measured one (its top edge,
      where the matcher is worst) within ``AGREEING_RISE_RATIO``.
    - A chain of several keeps its steps and gains one at each further nosing shown,
      where each of its steps stands within a third of a run and its top within a third
      of a rise of where the pitch puts them. Its pitch is looked for within a third of
      its own median rise and run, and only where a segment lies beyond its last nosing
      at its own pitch (:func:`~.pitch.lines_beyond`; on most frames none does).

    Either way the pitch shows three nosings or more, at least as many as the chain has
    steps (more, for a chain of several), and no step it adds stands at a wall across the
    stairs or where the samples see the tread before it go on (:func:`nosing_steps` asks
    the same of each step it adds)."""
    segs = parallel_segments(lines, v) if steps and not steps[0].rise_inferred else None
    if segs is None:
        return steps, 0
    view = StairView(lines, segs, u, v, inner_lateral(lateral))
    first = steps[0]
    a0 = first.axis_position_m
    near = None
    if len(steps) > 1:
        # the chain's own rise and run place its steps: the pitch is looked for near them
        rises = [s.rise_m for s in steps if not s.rise_inferred]
        runs = [s.run_m for s in steps if s.run_m is not None]
        if not rises or not runs:
            return steps, 0
        near = (float(np.median(rises)), float(np.median(runs)))
        if not lines_beyond(view, a0, ground_z, near[0], near[1], len(steps)):
            return steps, 0  # nothing beyond it to carry it on (most frames)
    pitch = pitch_from_nosings(view, a0, ground_z, config, near=near)
    if pitch is None or pitch.nosings < len(steps):
        return steps, 0
    rise, run = pitch.rise_m, pitch.run_m
    if len(steps) == 1:
        if max(rise, first.rise_m) > AGREEING_RISE_RATIO * min(rise, first.rise_m):
            return steps, 0
    elif pitch.nosings == len(steps) or not all(
        abs(s.axis_position_m - (a0 + i * run)) <= run / 3
        and abs(s.top_z_m - (ground_z + (i + 1) * rise)) <= rise / 3
        for i, s in enumerate(steps)
    ):
        return steps, 0
    walls = np.asarray(walls_across(planes, P, u, config), dtype=np.float64)
    for k in range(len(steps), pitch.nosings):  # as nosing_steps asks of a step it adds
        if no_riser_at(planes, P, view, walls, a0 + k * run, ground_z + k * rise, rise, config):
            return steps, 0
    if len(steps) == 1:
        out = [dataclasses.replace(first, rise_m=rise, top_z_m=ground_z + rise, measured_rise_m=first.rise_m)]
    else:
        out = list(steps)
    out[-1] = dataclasses.replace(out[-1], run_m=run)
    for k in range(len(out) + 1, pitch.nosings + 1):
        last_run = run if k < pitch.nosings else None
        out.append(inferred_step(u, a0 + (k - 1) * run, ground_z + k * rise, rise, last_run))
    return out, len(out) - len(steps)


def _next_nosing_or_edge(
    view: StairView,
    a: float,
    top: float,
    rise: float,
    run: float,
    config: TerrainConfig,
    smoothed: Callable[[], np.ndarray] | None,
) -> bool:
    """Whether the next nosing after the step at ``(a, top)`` shows, in the segments
    (:func:`next_nosing`) or else in the grey levels (:func:`edge_nosing`)."""
    if next_nosing(view, a, top, rise, run, config, smoothed) is not None:
        return True
    return smoothed is not None and edge_nosing(view, smoothed(), a, top, rise, run, config) is not None


def _tread_edge_on(view: StairView, a: float, top: float, rise: float, run: float) -> bool:
    """Whether the next step's tread (from its nosing at ``(a + run, top + rise)`` to the
    foot of the riser after it, ``run`` further) is seen edge-on: its nosing within half a
    rise of the cameras' height and the tread under ``EDGE_ON_PX`` tall in the image at
    the staircase's lateral middle."""
    if abs(top + rise - float(view.lines.centre[2])) > 0.5 * rise:
        return False
    return tread_height_px(view, a + run, a + 2.0 * run, top + rise) < EDGE_ON_PX


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
    noise (:mod:`~stereo_terrain.terrain.uniform` fits the staircase's rise to them).

    Parameters
    ----------
    steps : the staircase's steps, nearest first (``axis_position_m``, ``top_z_m``)
    u, v : (3,) float, the stair axis and the lateral direction (terrain frame)
    lateral : the staircase's lateral extent along ``v``, metres
    lines : ImageLines
    """
    rises = [s.rise_m for s in steps if not s.rise_inferred]
    segs = parallel_segments(lines, v) if rises else None
    if segs is None:
        return [None] * len(steps)
    view = StairView(lines, segs, u, v, inner_lateral(lateral))
    rise = float(np.median(rises))
    return [_nosing_top(view, s.axis_position_m, s.top_z_m, rise) for s in steps]


def nosing_under_first(
    steps: list[Step] | tuple[Step, ...],
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    lines: ImageLines,
    config: TerrainConfig,
) -> bool:
    """Whether the image's segments show the nosing of a step below the first of
    ``steps``: a run in front of its riser (within ``nosing_run_tolerance``), on the
    floor's height (0 in the terrain frame), across ``nosing_min_cover`` of the
    staircase's width, its foot in view where it must be (:func:`next_nosing` from two
    steps before the first, on the staircase's median measured rise and run), and the
    line met with the floor within that tolerance of its place too. Without a
    rig the floor is the lowest large horizontal plane; where the cameras see no floor
    before the stairs, that is the first tread, and its nosing lies there (the frame's
    floor is a step too high). Needs a measured rise and a run."""
    rises = [s.rise_m for s in steps if not s.rise_inferred]
    runs = [s.run_m for s in steps if s.run_m is not None]
    if not steps or not rises or not runs:
        return False
    segs = parallel_segments(lines, v)
    if segs is None:
        return False
    view = StairView(lines, segs, u, v, inner_lateral(lateral))
    rise, run = float(np.median(rises)), float(np.median(runs))
    a = steps[0].axis_position_m - 2.0 * run
    lam = next_nosing(view, a, -rise, rise, run, config)
    if lam is None:
        return False
    # Where the line lies on the floor itself: the pitch line's intersection is what
    # keeps a nosing's place well posed, but a low camera close to the stairs sees the
    # first riser's own foot on a true floor (a run further) meet the pitch line within
    # the tolerance too. The height is known here: the floor's.
    c = lines.centre
    mid = 0.5 * (view.lat[0] + view.lat[1])
    on_pitch = (a + lam * run) * u + mid * v + np.array([0.0, 0.0, (lam - 1.0) * rise])
    if not c[2] > on_pitch[2]:
        return False
    on_floor = on_height(lines, (on_pitch - c)[None, :], 0.0)[0]
    expected = steps[0].axis_position_m - run
    return abs(float(on_floor @ u) - expected) <= config.nosing_run_tolerance * run


def no_riser_at(
    planes: PlaneSet,
    P: np.ndarray,
    view: StairView,
    walls: np.ndarray,
    s_new: float,
    top: float,
    rise: float,
    config: TerrainConfig,
) -> bool:
    """Whether no riser may be added at ``s_new`` on the tread at ``top``: a wall across the
    stairs there (``walls``: :func:`walls_across`; its joints and edges are no nosings), or
    the samples see that tread go on beyond it (:func:`_floor_where_the_riser_would_be`: a
    landing's tiles, a platform, a box's top)."""
    if walls.size and float(np.min(np.abs(walls - s_new))) < config.merge_distance_m:
        return True
    return _floor_where_the_riser_would_be(planes, P, view, s_new, top, rise)


def _floor_where_the_riser_would_be(
    planes: PlaneSet,
    P: np.ndarray,
    view: StairView,
    s_new: float,
    top: float,
    rise: float,
) -> bool:
    """Whether the samples in the image of the riser that would stand at ``s_new`` on the
    tread at ``top`` lie on that tread's height beyond it (at least ``_MIN_FLOOR_SAMPLES``,
    more than lie at ``s_new`` and more than stand above the tread, up to a rise over it):
    the tread goes on, as a landing does. Where the matcher holds the faces (textured
    stairs) this tells a landing's tile joints from a step; where it holds nothing there
    (the far faces this module is for) it says nothing.

    Samples standing above the tread in that image are a riser wherever the matcher put
    them: a landing seen there has next to none (the rays through the riser's image meet
    its floor, unless a wall stands just beyond). On realistic renders the matcher placed
    a far riser's samples 10-40 cm off along their rays, some of them down to the tread's
    height: counted as floor alone, they stopped staircases whose next nosings showed, 1-4
    steps short (docs/benchmarks.md, "Thirty-eighth session")."""
    lines, u, v = view.lines, view.u, view.v
    span = visible_span(view, s_new, top + 0.5 * rise)
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
    standing = (q[:, 2] > top + thr) & (q[:, 2] < top + rise + thr)
    n_floor = int(np.count_nonzero(on_floor))
    return n_floor >= _MIN_FLOOR_SAMPLES and n_floor > max(
        int(np.count_nonzero(at_riser)), int(np.count_nonzero(standing))
    )


def _in_convex(quad: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Which points ``(x, y)`` lie inside the convex polygon ``quad`` ``(K, 2)`` (either
    winding)."""
    signs = []
    for k in range(len(quad)):
        (x0, y0), (x1, y1) = quad[k], quad[(k + 1) % len(quad)]
        signs.append((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0))
    cross = np.array(signs)
    return np.asarray(np.all(cross >= 0, axis=0) | np.all(cross <= 0, axis=0))


def _run_from_two_nosings(
    view: StairView,
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
    near = [np.abs(lam - k) < k * LAM_GROUP for k in (1, 2)]
    best, best_err = None, math.inf
    for i in np.flatnonzero(near[0].any(axis=1) & near[1].any(axis=1)):
        run = float(runs[i])
        err = 0.0
        for k in (1, 2):
            span = visible_span(view, a_k + k * run, top_k + k * rise)
            if span is None:
                err = math.inf
                break
            lo, hi = lateral_on_height(view, top_k + lam[i] * rise)
            at = near[k - 1][i] & np.isfinite(lo) & np.isfinite(hi)
            if covered_share(lo[at], hi[at], span) < config.nosing_min_cover:
                err = math.inf
                break
            err += abs(float(np.median(lam[i][at])) - k) / k
        if err < best_err:
            best, best_err = run, err
    return best


def _refined_top(view: StairView, a_k: float, top_k: float, rise: float) -> float:
    """:func:`_nosing_top`, else ``top_k``."""
    top = _nosing_top(view, a_k, top_k, rise)
    return top_k if top is None else top


def _nosing_top(
    view: StairView,
    a_k: float,
    top_k: float,
    rise: float,
) -> float | None:
    """The height of the step's nosing as its segments show it on its riser plane
    ``u . x = a_k`` (of the groups of segments within a third of a rise of ``top_k`` that
    cover ``_TOP_MIN_COVER`` of its width, the nearest; the top found from the samples is
    biased low, docs/benchmarks.md "Tenth session"); None where none does, or the step is
    not in view."""
    span = visible_span(view, a_k, top_k)
    if span is None:
        return None
    # The segments' lines on the riser plane, and their ends there for their lateral extent.
    z, lo, hi, _ = on_riser_plane(view.lines, view.segs, view.u, view.v, a_k, 0.5 * (span[0] + span[1]))
    near = np.isfinite(z) & (np.abs(z - top_k) < rise / 3.0)
    if not near.any():
        return None
    near &= np.isfinite(lo) & np.isfinite(hi)
    best: float | None = None
    best_dz = math.inf
    for x in z[near]:
        group = near & (np.abs(z - x) < _TOP_GROUP_M)
        if covered_share(lo[group], hi[group], span) >= _TOP_MIN_COVER and abs(x - top_k) < best_dz:
            best, best_dz = float(np.median(z[group])), abs(x - top_k)
    return best
