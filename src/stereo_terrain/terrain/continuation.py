"""Steps beyond the last riser plane: the next riser of a staircase found from its samples'
positions where it formed no plane (issue 11).

A far riser is a few centimetres of disparity noise tall: its samples lie on it (within
their depth noise) but their normals, differences of box means a few pixels apart, are
tens of degrees off, so the orientation method's normal test refuses them and the chain
stops early (docs/benchmarks.md, "Sixth session"). A staircase's steps are regular, so
the next riser is looked for where its spacing puts it: within ``continue_run_tolerance``
of the steps' median run, or, where no run is known yet (a single step whose tread's far
edge is not seen, but its tread is: a lone riser without one is too weak a witness),
between ``continue_min_run_m`` and ``continue_max_run_m`` beyond it (ordinary stairs;
once one riser is found so, its spacing is the run). It is sought among the samples that
no plane took, within the staircase's width and between the last tread's height and one
rise above it: a band of samples at one position along the stair axis (the most samples
within their inlier threshold), connected in the image and spanning at least half a rise
and ``min_riser_width_m``. It must also stop where a riser does (not many samples at its
position below the last tread or above one rise over it: a cabinet, a door, the ground
beyond a box go on) and stand where the last tread plane ends (not on it: an object on a
box's top). Its position gives the last step's run and the new step's distance; its rise
is not measured (its top and foot are where the noise is worst) but taken as the median of
the measured ones, and said so (``rise_inferred``), as for a first step whose foot is out
of view.
"""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np

from .._numeric import median, percentile
from ..cloud import GridSample
from ..msac import Plane
from ..planes.orientation import VERTICAL, OrientationConfig, PlaneSet
from .model import Step, TerrainConfig
from .risers import riser_distance

#: A sample's inlier threshold is the orientation method's (its default settings: the
#: terrain stage is not given the plane stage's config).
INLIERS = OrientationConfig()
#: Offsets tried: the positions with most samples within the threshold, best first.
_OFFSETS_TRIED = 20


def continue_steps(
    steps: list[Step],
    planes: PlaneSet,
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """``steps`` with the risers found beyond the last one (module docstring), and how many.

    Not at the foot of a wall: a plane across the stairs too tall for a riser within
    ``merge_distance_m`` of the position (the last tread ending at a wall,
    :func:`walls_across`).

    Parameters
    ----------
    steps : the chain's steps, nearest first (one with a measured rise at least for
        anything to be added)
    planes : PlaneSet the steps were built from (gravity-aligned frame)
    P : (N, 3) float64, its samples' points
    u, v : (3,) float, the stair axis and the lateral direction
    lateral : the staircase's lateral extent along ``v``, metres
    config : TerrainConfig (``continue_steps``, ``continue_run_tolerance``,
        ``max_continued_steps``, ``min_riser_points``, ``min_riser_width_m``,
        ``edge_margin_m``, ``merge_distance_m``)
    """
    if not config.continue_steps or config.max_continued_steps < 1 or not steps:
        return steps, 0
    runs = [s.run_m for s in steps if s.run_m is not None]
    rises = [s.rise_m for s in steps if not s.rise_inferred]
    if not rises:
        return steps, 0
    # the spacing: the median run, or (none seen yet) the ordinary range until one is found
    run: float | None = float(median(np.asarray(runs))) if runs else None
    if run is None and steps[-1].tread is None:
        # A lone riser whose top formed no plane: any vertical face of about a step's
        # height (an object's front, a junk plane) is one, so it is no staircase to extend.
        return steps, 0
    rise = float(median(np.asarray(rises)))
    tol = config.continue_run_tolerance
    samples = planes.samples
    s_all, v_all, z_all = P @ u, P @ v, P[:, 2]
    free, thr = free_samples(planes, s_all)
    wall_s = np.asarray(walls_across(planes, P, u, config), dtype=np.float64)
    out = list(steps)
    added = 0
    while added < config.max_continued_steps:
        last = out[-1]
        s0, top = last.axis_position_m, last.top_z_m
        if run is None:
            lo, hi = s0 + config.continue_min_run_m, s0 + config.continue_max_run_m
        else:
            lo, hi = s0 + (1.0 - tol) * run, s0 + (1.0 + tol) * run
        heights = (top, top + rise)
        found = riser_band(free, s_all, v_all, z_all, thr, samples, (lo, hi), heights, rise, lateral, config)
        if found is None:
            break
        patch, a0, v_lo, v_hi = found
        if wall_s.size and float(np.min(np.abs(wall_s - a0))) < config.merge_distance_m:
            break
        if not _a_riser_there(a0, (v_lo, v_hi), top, rise, len(patch), s_all, v_all, z_all, thr, config):
            break
        if _tread_goes_on(last, a0, planes, s_all, v_all, lateral):
            break  # on the tread, not where it ends: an object on it (a box's top)
        plane = Plane(-u, a0)  # vertical, facing the robot, u . x = a0
        out[-1] = dataclasses.replace(last, run_m=a0 - s0)
        out.append(
            Step(
                rise,
                None,
                riser_distance(plane, a0, u),
                None,
                top + rise,
                a0,
                plane,
                None,
                rise_inferred=True,
            )
        )
        free[patch] = False
        added += 1
        if run is None:
            run = a0 - s0
    return out, added


def free_samples(planes: PlaneSet, s_all: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples no plane took (with a finite position ``s_all`` along the stair axis and
    a finite inlier threshold), and every sample's inlier threshold (:data:`INLIERS`)."""
    thr = INLIERS.inlier_threshold_m(planes.samples.sigma_m)
    used = np.zeros(len(s_all), dtype=bool)
    for seg in planes.segments:
        used[seg.indices] = True
    return ~used & np.isfinite(s_all) & np.isfinite(thr), thr


def riser_band(
    free: np.ndarray,
    s_all: np.ndarray,
    v_all: np.ndarray,
    z_all: np.ndarray,
    thr: np.ndarray,
    samples: GridSample,
    span: tuple[float, float],
    heights: tuple[float, float],
    rise: float,
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> tuple[np.ndarray, float, float, float] | None:
    """A riser from the samples' positions: of the ``free`` samples within ``lateral`` (10
    cm beside it too), between ``heights`` (``edge_margin_m`` beyond each) and about the
    positions ``span`` along the stair axis, the patch at one position (:func:`_riser_patch`)
    at least half of ``rise`` tall and ``min_riser_width_m`` wide, its median position
    within ``span``: ``(patch, that position, its lateral extent v_lo, v_hi)``; None where
    there is none.

    The patch is seeded at a position within ``span`` but holds the samples within their
    inlier threshold of it (up to ``INLIERS.max_threshold_m``), so its median can lie
    outside: on the realistic renders, the last riser's own samples that its plane left
    out, up to 3 cm short of the span, were taken for the next riser (a step too many beyond
    a short landing, or three risers where two stand)."""
    lo, hi = span
    band = (
        free
        & (s_all > lo - INLIERS.max_threshold_m)
        & (s_all < hi + INLIERS.max_threshold_m)
        & (v_all > lateral[0] - 0.1)
        & (v_all < lateral[1] + 0.1)
        & (z_all > heights[0] - config.edge_margin_m)
        & (z_all < heights[1] + config.edge_margin_m)
    )
    patch = _riser_patch(np.flatnonzero(band), s_all, thr, samples, lo, hi, config)
    if patch is None:
        return None
    z_lo, z_hi = percentile(z_all[patch], [5.0, 95.0])
    v_lo, v_hi = percentile(v_all[patch], [5.0, 95.0])
    if z_hi - z_lo < 0.5 * rise or v_hi - v_lo < config.min_riser_width_m:
        return None
    at = float(median(s_all[patch]))
    if not lo <= at <= hi:
        return None
    return patch, at, float(v_lo), float(v_hi)


def _a_riser_there(
    a0: float,
    lateral: tuple[float, float],
    top: float,
    rise: float,
    n_patch: int,
    s_all: np.ndarray,
    v_all: np.ndarray,
    z_all: np.ndarray,
    thr: np.ndarray,
    config: TerrainConfig,
) -> bool:
    """Whether the face at ``a0`` (across ``lateral``) stops where a riser does: at most half
    as many samples as its patch (any samples, in a plane or not) at that position below
    the last tread or above one rise over it. A riser's foot is the tread it stands on
    and the next tread starts at its top; a cabinet front, a door or the ground beyond a
    box go on below or above (as a riser plane that does so is no riser to the chain)."""
    at = (np.abs(s_all - a0) < thr) & (v_all > lateral[0]) & (v_all < lateral[1])
    outside = (z_all < top - config.edge_margin_m) | (z_all > top + rise + config.edge_margin_m)
    return int(np.count_nonzero(at & outside)) <= 0.5 * n_patch


def _tread_goes_on(
    step: Step,
    a0: float,
    planes: PlaneSet,
    s_all: np.ndarray,
    v_all: np.ndarray,
    lateral: tuple[float, float],
) -> bool:
    """Whether ``step``'s tread plane goes on past ``a0``: more than a quarter of its samples
    within the staircase's width lie beyond it by more than the largest inlier threshold
    (a tread ends at the next riser; the noise of a far tread's samples spills a few
    centimetres past it, a box's top with an object on it goes on). False without a tread
    plane."""
    if step.tread is None:
        return False
    for seg in planes.segments:
        if seg.plane is step.tread:
            s, v = s_all[seg.indices], v_all[seg.indices]
            s = s[(v > lateral[0]) & (v < lateral[1]) & np.isfinite(s)]
            return len(s) > 0 and float(np.mean(s > a0 + INLIERS.max_threshold_m)) > 0.25
    return False


def walls_across(planes: PlaneSet, P: np.ndarray, u: np.ndarray, config: TerrainConfig) -> list[float]:
    """Positions along the stair axis ``u`` of the vertical planes across it (facing the
    robot within ``axis_spread_deg``) whose samples span more height than a riser can."""
    cos_spread = math.cos(math.radians(config.axis_spread_deg))
    too_tall = config.max_rise_m + config.edge_margin_m
    walls = []
    for seg in planes.segments:
        if seg.kind != VERTICAL or abs(float(seg.plane.normal @ u)) < cos_spread:
            continue
        z_lo, z_hi = percentile(P[seg.indices, 2], [5.0, 95.0])
        if z_hi - z_lo > too_tall:
            walls.append(float(median(P[seg.indices] @ u)))
    return walls


def _riser_patch(
    idx: np.ndarray,
    s_all: np.ndarray,
    thr: np.ndarray,
    samples: GridSample,
    lo: float,
    hi: float,
    config: TerrainConfig,
) -> np.ndarray | None:
    """Of the samples ``idx``, the largest connected patch (8-neighbours in the sample grid,
    gaps of one cell bridged) at the position along the axis, within ``[lo, hi]``, that
    most of them lie within their threshold of; None when it has fewer than
    ``min_riser_points`` samples."""
    if len(idx) < config.min_riser_points:
        return None
    a = s_all[idx]
    order = np.sort(a)
    t = float(median(thr[idx]))
    counts = np.searchsorted(order, order + t, side="right") - np.searchsorted(order, order - t)
    best: np.ndarray | None = None
    inside = np.flatnonzero((order >= lo) & (order <= hi))  # positions within the spacing
    for j in inside[np.argsort(-counts[inside], kind="stable")][:_OFFSETS_TRIED]:
        a0 = order[j]
        if counts[j] < config.min_riser_points:
            break
        patch = largest_grid_patch(idx[np.abs(a - a0) < thr[idx]], samples)
        if patch is not None and (best is None or len(patch) > len(best)):
            best = patch
    if best is None or len(best) < config.min_riser_points:
        return None
    return best


def largest_grid_patch(indices: np.ndarray, samples: GridSample) -> np.ndarray | None:
    """Of the samples ``indices``, those of the largest patch of 8-connected cells in the
    sample grid (gaps of one cell bridged); None when there is none."""
    gh, gw = samples.grid_shape
    grid = np.zeros((gh, gw), np.uint8)
    cells = samples.grid_index[indices]
    grid.flat[cells] = 1
    n_lab, lab = cv2.connectedComponents(cv2.dilate(grid, np.ones((3, 3), np.uint8)), connectivity=8)
    if n_lab <= 1:
        return None
    labels = lab.flat[cells]
    sizes = np.bincount(labels, minlength=n_lab)
    sizes[0] = 0
    patch: np.ndarray = indices[labels == int(np.argmax(sizes))]
    return patch
