"""A staircase's chain of steps between its assembly and its model
(:func:`finish_chain`): the steps the image's lines show beyond it, the staircase's common
rise and run, a lone step classified, the polytope and the note; and the horizontal
planes' inliers a chain is measured against (:func:`horizontal_info`,
:func:`samples_along`). The chain comes from the planes (:mod:`.assemble`), the image's
lines (:mod:`.from_lines`) or the risers' ends (:mod:`.from_ends`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._numeric import median, percentile  # NumPy's bits, a fraction of its time (issue 13)
from ..msac import Plane
from ..planes.orientation import HORIZONTAL, PlaneSet
from .model import STAIRS, StairModel, Step, TerrainConfig, stair_axes
from .nosings import ImageLines, end_steps, nosing_heights, nosing_steps, pitched_steps
from .photometric import refine_risers
from .polytope import _classify_single_step, _polytope
from .risers import _Riser
from .uniform import common_steps, rise_from_nosings, takers_of_rise


@dataclass(frozen=True)
class Chain:
    """A family's steps before they are finished (:func:`finish_chain`): the chain, its risers,
    and what the note and the classification need."""

    planes: PlaneSet
    P: np.ndarray
    steps: tuple[Step, ...]
    ordered: tuple[_Riser, ...]
    yaw: float
    ground_z: float
    h_info: list
    lateral: tuple[float, float]
    inferred_first: bool
    below: int
    continued: int


def horizontal_info(planes: PlaneSet, P: np.ndarray, u: np.ndarray, v: np.ndarray) -> list:
    """Each horizontal plane of ``planes`` with its height (its inliers' median) and its
    inliers' positions along the stair axis ``u`` and across it ``v`` (``P``: the samples'
    points), as a chain carries them (``Chain.h_info``)."""
    out = []
    for h in planes.segments:
        if h.kind == HORIZONTAL:
            Q = P[h.indices]
            out.append((h, float(median(Q[:, 2])), Q @ u, Q @ v))
    return out


def finish_chain(
    chain: Chain, config: TerrainConfig, lines: ImageLines | None = None, *, origin: str | None = None
) -> StairModel:
    """The model of a family's chain: the steps the image's lines show beyond it
    (``lines``, :mod:`.nosings`), the staircase's common rise and run, a single step
    classified, the polytope and the note (whose steps are "from N riser plane(s)", or
    from ``origin`` where given)."""
    u, v = stair_axes(chain.yaw)
    steps = list(chain.steps)
    from_lines = split = pitched = refined = 0
    if lines is not None and lines.stereo is not None and config.photometric_risers:
        steps, refined = refine_risers(steps, u, v, _faces_lateral(chain, steps, v), lines.stereo, config)
    # The nosings' pitch (its first riser's foot seen): a chain of one riser plane is
    # rebuilt on it before the nosings beyond are looked for one by one; a chain of
    # several, whose measured rises and runs place those, is carried on by it after.
    on_ground = not (chain.inferred_first or chain.below)
    pitch_on = config.nosing_steps and config.nosing_pitch and on_ground
    if pitch_on and lines is not None and len(chain.ordered) == 1:
        steps, pitched = pitched_steps(
            steps, chain.planes, chain.P, u, v, chain.lateral, chain.ground_z, lines, config
        )
    if lines is not None and config.nosing_steps:
        # The nosings are looked for across the chain's narrowest riser plane: a fill
        # can paint a riser's plane on over a plain wall in line with it (2-3.4 m for a
        # 1-1.4 m staircase), and the next nosing then covers too little of that width.
        narrow = min(((r.v_lo, r.v_hi) for r in chain.ordered), key=lambda e: e[1] - e[0])
        steps, from_lines, split = nosing_steps(steps, chain.planes, chain.P, u, v, narrow, lines, config)
    if pitch_on and lines is not None and len(chain.ordered) > 1:
        steps, pitched = pitched_steps(
            steps, chain.planes, chain.P, u, v, chain.lateral, chain.ground_z, lines, config
        )
    pitch = (steps[-1].rise_m, steps[-2].run_m or 0.0) if pitched else (0.0, 0.0)
    before_ends = len(steps)
    profile = None
    if lines is not None and config.riser_end_steps:
        steps, profile = end_steps(
            steps, chain.planes, chain.P, u, v, chain.lateral, chain.ground_z, lines, config
        )
    ends = len(steps) - before_ends
    fit = None
    if lines is not None and config.nosing_rise:
        heights = nosing_heights(steps, u, v, chain.lateral, lines)
        known = not (chain.inferred_first or chain.below)  # else the ground is a guess
        lone = len(steps) == 1 and steps[0].tread is None  # its top: the riser's top edge
        fit = rise_from_nosings(heights, chain.ground_z if known else None, config, lone=lone)
    nosing_rise, fits = fit if fit is not None else (None, [])
    # whether the steps report the nosings' rise (else the median's rule, or their own)
    nosings_taken = nosing_rise is not None and bool(takers_of_rise(steps, nosing_rise, config, fits=fits))
    # where no nosings fit a rise: the one both images measure at the risers' ends, for
    # every step they show
    rise_of_ends = profile if nosing_rise is None else None
    if rise_of_ends is not None:
        nosing_rise, fits = rise_of_ends.rise_m, list(range(min(rise_of_ends.ends, len(steps))))
    steps, pooled_rises, pooled_runs, across = common_steps(
        steps, chain.ground_z, config, rise_m=nosing_rise, fits=fits
    )

    obstacle = STAIRS
    note = f"{len(steps)} step(s) {origin or f'from {len(chain.ordered)} riser plane(s)'}"
    if chain.inferred_first:
        note += "; the first riser's foot is out of view: its rise is the median of the others"
    if chain.below:
        note += (
            f"; the {chain.below} step(s) below the lowest riser plane formed none: inferred at the"
            " staircase's rise and run"
        )
    if pitched:
        note += (
            f"; the image's nosings show the staircase's pitch from its first riser's foot"
            f" ({100.0 * pitch[0]:.1f} cm rise, {100.0 * pitch[1]:.1f} cm run): {pitched} more step(s) at it"
        )
    elif chain.continued:
        note += (
            f"; {chain.continued} more beyond the last riser plane, from their samples' positions"
            " (rise: the median of the others)"
        )
    if split:
        note += (
            f"; {split} double step(s) split where the image's line segments show the nosing"
            " between (each half at half its rise)"
        )
    if from_lines:
        note += (
            f"; {from_lines} more beyond, where the image's line segments show their nosings"
            " (at the median rise and run)"
        )
    if ends:
        note += (
            f"; {ends} more beyond, where the image shows their risers' ends (vertical edges"
            " both images place)"
        )
    if rise_of_ends is not None:
        note += (
            f"; the staircase's rise is the one its {rise_of_ends.ends} risers' ends show"
            f" ({100.0 * rise_of_ends.rise_m:.1f} cm)"
        )
    # the measured rises that agree (those of two neighbours across a misplaced top apart)
    agreeing = pooled_rises - (2 if across is not None else 0)
    if nosings_taken and len(steps) == 1:
        note += (
            "; its rise is its nosing's height above the ground as the image's line segments"
            " show it, not its riser's top edge"
        )
    elif nosings_taken:
        note += (
            f"; {agreeing} measured rise(s) agree with the rise that puts the nosings the"
            " image's line segments show at their heights: those steps report it"
        )
    elif pooled_rises:
        note += f"; {agreeing} measured rises agree: those steps report their median"
    if across is not None:
        a, b = steps[across], steps[across + 1]
        note += (
            f"; steps {across + 1} and {across + 2} measured {100.0 * (a.measured_rise_m or 0.0):.1f} and"
            f" {100.0 * (b.measured_rise_m or 0.0):.1f} cm, their mean the others': the top between"
            " them misplaced, they report the common rise too"
        )
    if pooled_runs:
        note += f"; {pooled_runs} measured runs agree: those steps report their median"
    if refined:
        note += f"; {refined} riser(s) moved to where both images of their faces agree best"
    if len(steps) == 1:
        obstacle, note, steps = _classify_single_step(
            steps[0], chain.h_info, chain.ground_z, config, note, chain.lateral
        )
    poly = _polytope(steps, list(chain.ordered), u, v, chain.ground_z)
    return StairModel(obstacle, tuple(steps), chain.yaw, chain.ground_z, poly, chain.planes.frame, note)


#: The percentiles of a riser plane's inliers, across the stair, that bound its face for
#: :func:`~.photometric.refine_risers`.
_FACE_LATERAL_PCT = [10.0, 90.0]


def _faces_lateral(chain: Chain, steps: list[Step], v: np.ndarray) -> list[tuple[float, float]]:
    """Each step's riser face across the stair (metres along ``v``): the middle
    :data:`_FACE_LATERAL_PCT` of its riser plane's inliers, inside the staircase's extent
    (a riser plane may run on along a wall's foot in line with it); the staircase's extent
    for a step whose riser formed no plane."""
    lo_all, hi_all = chain.lateral
    out = []
    for s in steps:
        own = next((r for r in chain.ordered if r.plane is s.riser), None)
        if own is None or not len(own.idx):
            out.append((lo_all, hi_all))
            continue
        lo, hi = percentile(chain.P[own.idx] @ v, _FACE_LATERAL_PCT)
        out.append((max(float(lo), lo_all), min(float(hi), hi_all)))
    return out


def samples_along(
    h_z: list[float],
    s_h: list[np.ndarray],
    v_h: list[np.ndarray],
    z: float,
    tol: float,
    along: tuple[float, float],
    lateral: tuple[float, float],
) -> np.ndarray:
    """The positions along the stair axis of the inliers of the horizontal planes within
    ``tol`` of height ``z`` that lie strictly between ``along`` (metres along the stair
    axis) and ``lateral`` (along the lateral direction); ``h_z``, ``s_h``, ``v_h``: each
    plane's height and its inliers' positions (their count: how much of a surface is seen
    there)."""
    parts = [
        sh[(sh > along[0]) & (sh < along[1]) & (vh > lateral[0]) & (vh < lateral[1])]
        for hz, sh, vh in zip(h_z, s_h, v_h, strict=True)
        if abs(hz - z) <= tol
    ]
    return np.concatenate(parts) if parts else np.zeros(0)


def tread_between(horizontals, h_z, s_h, z: float, s_lo: float, s_hi: float) -> Plane | None:
    """The horizontal plane at height ``z`` with most inliers between ``s_lo`` and ``s_hi``
    along the stair axis, or None."""
    best, best_count = None, 0
    for h, hz, sh in zip(horizontals, h_z, s_h, strict=True):
        count = int(np.sum((sh > s_lo) & (sh < s_hi)))
        if abs(hz - z) < 1e-9 and count > best_count:
            best, best_count = h.plane, count
    return best
