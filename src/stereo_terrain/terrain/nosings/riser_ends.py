"""Steps and rise where the image shows a staircase's risers' ends (issue 11).

A staircase seen at an angle shows its side: each riser ends in a vertical edge, against
the wall beside the stairs or the room behind them, and the side's outline climbs in a
saw-tooth of those edges and the treads' sides. On a painted staircase the faces give the
matcher nothing and the nosings are barely darker than the risers, yet the ends stand out
and a horizontal baseline places them best of all (:attr:`~.view.ImageLines.vertical_edges`:
within 3 cm along the stair axis and 2 cm in height on a realistic render whose chain
ended two steps short).

:func:`end_steps` looks for the side's profile from the chain's first riser on
(:func:`_profile`): its end (within ``_FIRST_ALONG_M`` of the riser along the axis, its
foot on the ground), then end after end, each 0.15-0.45 m on (``min_run_m`` to
``continue_max_run_m``) within ``_ALONG_DEG`` of the axis, its foot about the top of the
one before, no taller than a rise; the longest such saw-tooth of ``MIN_ENDS`` ends or more
whose heights lie on one pitch and whose runs agree. The profile comes from the ends
alone, not from the chain's own rise and run: the chains it carries on are often a few
degrees and centimetres off (docs/benchmarks.md, "Forty-second session").

The chain gains a step for each end beyond its last, a run of the profile's apart, at its
median rise (inferred), and not where a wall stands across the stairs or the samples see
the last tread go on (as :func:`~.steps.nosing_steps` asks). The profile's rise, which
both images measure at the ends, is the staircase's where no nosings fit one
(:func:`~stereo_terrain.terrain.chain.finish_chain`).

A wall's corner or a door's frame is taller than a rise and is no riser's end; pieces of
balusters as tall as a rise, stacked a run apart, would be taken for a profile.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ...planes.orientation import PlaneSet
from ..continuation import walls_across
from ..model import AGREEING_RISE_RATIO, Step, TerrainConfig
from .next_nosing import inferred_step
from .steps import no_riser_at
from .view import ImageLines, Segments, StairView, inner_lateral

#: How far beside the staircase's lateral extent (metres) a riser's end may stand: the
#: extent comes from the riser planes' inliers, which stop short of the ends.
_BESIDE_M = 0.3

#: How far (metres) the first riser's end may stand from the chain's first riser along
#: the axis, and its foot above the ground.
_FIRST_ALONG_M = 0.15
_FIRST_FOOT_M = 0.06

#: How far (metres) an end's foot may lie below the top of the end before it, or above
#: it: the segments' ends are not the corners.
_BELOW_M = 0.04
_ABOVE_M = 0.06

#: Most angle (deg) between the stair axis and the step from one end to the next.
_ALONG_DEG = 30.0

#: Fewest ends (the first riser's included) that make a side's profile.
MIN_ENDS = 3

#: Most spread of the profile's runs (each from its median, a share of it) and of its
#: ends' heights from a straight pitch (a share of the rise).
_RUN_SPREAD = 0.25
_HEIGHT_SPREAD = 0.3


@dataclass(frozen=True)
class SideProfile:
    """The risers' ends a staircase's side shows (:func:`end_steps`): how many, from its
    first riser on, and the rise their heights' middles fit."""

    ends: int
    rise_m: float


def end_steps(
    steps: list[Step],
    planes: PlaneSet,
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    ground_z: float,
    lines: ImageLines,
    config: TerrainConfig,
) -> tuple[list[Step], SideProfile | None]:
    """``steps`` with the steps beyond the last one whose risers' ends the image shows (the
    module docstring), and the side's profile where it shows as many ends as ``steps``
    has steps or more (else None and ``steps`` unchanged): its rise is the staircase's
    that both images measure at the ends.

    Parameters
    ----------
    steps : the chain's steps, nearest first; its first riser must stand on the ground
        (``ground_z``) with a measured rise, which the profile's must agree with
        (``AGREEING_RISE_RATIO``)
    planes : PlaneSet the steps were built from, P its samples' points (for the walls and
        the treads that go on)
    u, v : (3,) float, the stair axis and the lateral direction (terrain frame)
    lateral : the staircase's lateral extent along ``v``, metres
    lines : ImageLines, with the rectified pair (``stereo``)
    config : TerrainConfig (``riser_end_steps``, ``max_nosing_steps``, ``min_run_m``,
        ``continue_max_run_m``, ``min_rise_m``, ``max_rise_m``)
    """
    if not config.riser_end_steps or not steps or steps[0].rise_inferred or lines.stereo is None:
        return steps, None
    ends = _profile(steps[0], u, v, lateral, ground_z, lines, config)
    if ends is None or len(ends) < len(steps):
        return steps, None
    rise, run, _ = profile_pitch(ends, u)
    first = steps[0]
    if max(rise, first.rise_m) > AGREEING_RISE_RATIO * min(rise, first.rise_m):
        return steps, None
    view = StairView(
        lines, Segments(np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3))), u, v, inner_lateral(lateral)
    )
    walls = np.asarray(walls_across(planes, P, u, config), dtype=np.float64)
    out = list(steps)
    added = 0
    while len(out) < len(ends) and added < config.max_nosing_steps:
        last = out[-1]
        a_new = last.axis_position_m + run
        if no_riser_at(planes, P, view, walls, a_new, last.top_z_m, rise, config):
            break
        out[-1] = dataclasses.replace(last, run_m=run)
        out.append(inferred_step(u, a_new, last.top_z_m + rise, rise, None))
        added += 1
    return out, SideProfile(len(ends), rise)


def profile_pitch(ends: list[tuple[np.ndarray, np.ndarray]], u: np.ndarray) -> tuple[float, float, float]:
    """The rise, run (along ``u``) and the worst spread (metres, heights) of a profile's
    ends ``[(foot, top), ...]``: least-squares lines of their heights' middles and their
    positions against the step's index."""
    k = np.arange(len(ends), dtype=np.float64)
    mid = np.array([0.5 * (f[2] + t[2]) for f, t in ends])
    along = np.array([f @ u for f, _ in ends])
    rise, z0 = np.polyfit(k, mid, 1)
    run, _ = np.polyfit(k, along, 1)
    return float(rise), float(run), float(np.max(np.abs(mid - (z0 + rise * k))))


def _profile(
    first: Step,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    ground_z: float,
    lines: ImageLines,
    config: TerrainConfig,
) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """The longest saw-tooth of risers' ends that starts at the first riser's end: each
    end a run on from the one before (about along ``u``), its foot about that one's top;
    the ends' heights on a straight pitch and their runs alike. None where there is none of
    ``MIN_ENDS`` ends or more."""
    edges = lines.vertical_edges
    if not len(edges.foot):
        return None
    foot, top = edges.foot, edges.top
    span = top[:, 2] - foot[:, 2]
    lat = 0.5 * (foot + top) @ v
    ok = (
        (lat > lateral[0] - _BESIDE_M)
        & (lat < lateral[1] + _BESIDE_M)
        & (span >= 0.5 * config.min_rise_m)
        & (span <= config.max_rise_m + _ABOVE_M)
        & (foot[:, 2] > ground_z - _BELOW_M)
    )
    starts = np.flatnonzero(
        ok
        & (np.abs(foot @ u - first.axis_position_m) < _FIRST_ALONG_M)
        & (foot[:, 2] < ground_z + _FIRST_FOOT_M)
        & (span >= 0.5 * first.rise_m)
    )
    cos_along = np.cos(np.radians(_ALONG_DEG))
    best: list[tuple[np.ndarray, np.ndarray]] | None = None
    for i in starts:
        chain = [int(i)]
        while True:
            cur = chain[-1]
            step = foot[:, :2] - foot[cur, :2]
            dist = np.hypot(step[:, 0], step[:, 1])
            with np.errstate(invalid="ignore", divide="ignore"):
                along = (step @ u[:2]) / dist
            nxt = (
                ok
                & (dist >= config.min_run_m)
                & (dist <= config.continue_max_run_m)
                & (along >= cos_along)
                & (foot[:, 2] > top[cur, 2] - _BELOW_M)
                & (foot[:, 2] < top[cur, 2] + _ABOVE_M)
            )
            if not nxt.any():
                break
            cand = np.flatnonzero(nxt)
            chain.append(int(cand[np.argmin(dist[cand])]))
        ends = [(foot[j], top[j]) for j in chain]
        if len(ends) < MIN_ENDS or (best is not None and len(ends) <= len(best)):
            continue
        rise, run, worst = profile_pitch(ends, u)
        runs = np.diff([f @ u for f, _ in ends])
        if not (config.min_rise_m <= rise <= config.max_rise_m) or run < config.min_run_m:
            continue
        if worst > _HEIGHT_SPREAD * rise or np.max(np.abs(runs - np.median(runs))) > _RUN_SPREAD * run:
            continue
        best = ends
    return best
