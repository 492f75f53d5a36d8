"""A staircase from its risers' ends alone, where the chain the planes made counts fewer
steps (issue 11).

A painted staircase gives the matcher nothing on its faces: the fills put its riser
planes in fronto-parallel bands centimetres off, and the chain built on them often starts
at the wrong riser or stops early. Each riser still ends in a vertical edge against the
wall beside the stairs or the room behind, and both images place such an edge best of all
(:attr:`~.nosings.view.ImageLines.vertical_edges`: on a realistic render the ends of five
risers within a centimetre of their truth along the axis, their tops within a centimetre
in height). :mod:`.nosings.riser_ends` uses them to carry a chain on from its first
riser; here they make the staircase on their own, from the floor up.

:func:`ends_profile` looks for the side's saw-tooth: every end a step up from another on
the same side of the staircase (its foot at that one's top, a run of
``min_run_m``-``continue_max_run_m`` on) proposes a pitch, whose rise puts every end's top
``k`` rises above the floor for a whole ``k``, and whose run puts it ``k - 1`` runs beyond
the first riser; the pitch that most steps' ends fit is refined on them by least squares
(the rise through the floor, the run and first riser along the axis) and kept where one
side of the staircase shows ``MIN_SIDE_STEPS`` steps or more, at most one step in between
and ``_MAX_BELOW`` below the lowest missing. The other side's ends, where they show, fit
the same pitch and give the width.

Ends stand everywhere in a room: a plant pot's side, a chair's leg, a shelf's corner. On
the real OAK-D living room four of them fit a three-step pitch, scattered across 0.8 m;
those on one line along the axis never did. The pipeline asks the profile last, of a
frame whose result already has a staircase or a step (:func:`staircase_from_ends`). Where
it holds a riser the planes measured, it is kept where it has more steps
(docs/benchmarks.md, "Forty-third session"), or as many from the same first riser where
the result's rises are off and its own treads do not agree on them ("Forty-fourth
session"). Where it holds none, the two disagree, and the ends are the surer: a
staircase of the planes (never a box) gives way to a profile that shows its own first
step's ends or has more steps ("Forty-fifth session").
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..msac import Plane
from ..planes.orientation import PlaneSet
from .chain import Chain, finish_chain, horizontal_info
from .model import NONE, STAIRS, StairModel, Step, TerrainConfig, stair_axes
from .nosings import ImageLines
from .nosings.view import VerticalEdges
from .risers import face_riser, riser_distance

#: The rises searched (metres): ordinary stairs' (building codes allow 10-22 cm; older
#: stairs reach 25).
RISE_RANGE_M = (0.08, 0.25)

#: An end fits a pitch where its top is within this of its step's height (metres) and its
#: position along the axis within ``_ALONG_M`` of the pitch line's.
_TOP_M = 0.035
_ALONG_M = 0.05

#: How far (metres) an end's foot may lie below the top of the step before it, or above
#: it (the segments' ends are not the corners): the end that proposes a pitch with
#: another.
_FOOT_BELOW_M = 0.05
_FOOT_ABOVE_M = 0.07

#: An end may span this much (metres) more than a rise.
_TALLER_M = 0.06

#: Ends on one side of a straight staircase lie on one line along its axis, within this
#: (metres) of it.
_SIDE_M = 0.06

#: Fewest steps whose ends one side shows.
MIN_SIDE_STEPS = 3

#: Most steps inferred below the lowest end (its foot hidden by the view's edge or the
#: steps in front), and most missing between two ends.
_MAX_BELOW = 1
_MAX_GAPS = 1

#: The stair axis within this of the camera's (deg): stairs are met yawed up to +-60 deg.
_MAX_YAW_DEG = 60.0

#: The first riser at least this far ahead along the axis (metres).
_MIN_FIRST_M = 0.3

#: A riser the planes measured lies on the profile where it is within this along the axis
#: (metres) and its top within ``_KEPT_TOP_M`` of its step's height, the two axes within
#: ``_KEPT_YAW_DEG``; a riser whose top no tread measured (its riser plane's top edge,
#: found low: realistic 57 scene 27's third riser, 5.6 cm under its nosing) by its
#: place alone.
_KEPT_ALONG_M = 0.10
_KEPT_TOP_M = 0.05
_KEPT_YAW_DEG = 10.0

#: A profile of as many steps as the result, from its first riser (``_KEPT_ALONG_M``),
#: mends its rises where one of them is this far (metres) or more off the profile's
#: (:func:`_mends_rises`) ...
_RISE_OFF_M = 0.02

#: ... and either every top a tread measured lies within this (metres) of its step's
#: height on the profile, or the result's own measured rises spread more than
#: ``TerrainConfig.common_rise_tolerance_m``.
_MENDED_TOP_M = 0.025

#: How the note says where the steps come from (``finish_chain``'s "from N riser plane(s)").
ORIGIN = "from the risers' ends both images place (the staircase's side, step by step from the floor)"


@dataclass(frozen=True)
class EndsProfile:
    """A staircase's pitch as its risers' ends show it (:func:`ends_profile`).

    Attributes
    ----------
    yaw_rad : float
        The stair axis in the terrain frame.
    rise_m, run_m : float
    first_m : float
        The first riser's position along the axis (metres).
    steps : int
        How many steps, the highest end's.
    seen : tuple of int
        The steps (1 the first) whose ends both images place.
    lateral : (float, float)
        The ends' extent across the axis (metres along its lateral direction): the
        staircase's width where both sides show.
    """

    yaw_rad: float
    rise_m: float
    run_m: float
    first_m: float
    steps: int
    seen: tuple[int, ...]
    lateral: tuple[float, float]


def ends_profile(edges: VerticalEdges, ground_z: float, config: TerrainConfig) -> EndsProfile | None:
    """The pitch that most steps' risers' ends fit (the module docstring), or None where
    no side of a staircase shows ``MIN_SIDE_STEPS`` steps. ``edges``: the image's vertical
    edges, terrain frame (z up); ``ground_z``: the floor's height; ``config``: the runs'
    range (``min_run_m``, ``continue_max_run_m``)."""
    foot = np.asarray(edges.foot, dtype=np.float64).reshape(-1, 3)
    top = np.asarray(edges.top, dtype=np.float64).reshape(-1, 3)
    tall = top[:, 2] - foot[:, 2]
    keep = (tall >= 0.5 * RISE_RANGE_M[0]) & (tall <= RISE_RANGE_M[1] + _TALLER_M)
    keep &= top[:, 2] - ground_z >= RISE_RANGE_M[0] - _TOP_M
    foot, top = foot[keep], top[keep]
    if len(foot) < MIN_SIDE_STEPS:
        return None
    xy = 0.5 * (foot[:, :2] + top[:, :2])
    h = top[:, 2] - ground_z
    # Each ordered pair (i below, j a step up on the same side): a proposed pitch.
    d = xy[None, :, :] - xy[:, None, :]
    run = np.hypot(d[..., 0], d[..., 1])
    rise = h[None, :] - h[:, None]
    step_on = foot[None, :, 2] - top[:, None, 2]
    pairs = (rise >= RISE_RANGE_M[0]) & (rise <= RISE_RANGE_M[1])
    pairs &= (run >= config.min_run_m) & (run <= config.continue_max_run_m)
    pairs &= (step_on >= -_FOOT_BELOW_M) & (step_on <= _FOOT_ABOVE_M)
    best: tuple[tuple[int, int], EndsProfile] | None = None
    for i, j in zip(*np.nonzero(pairs), strict=True):
        found = _fit(xy, foot[:, 2] - ground_z, h, int(i), int(j), config)
        if found is not None and (best is None or found[0] > best[0]):
            best = found
    return None if best is None else best[1]


def _fit(
    xy: np.ndarray, foot_h: np.ndarray, h: np.ndarray, i: int, j: int, config: TerrainConfig
) -> tuple[tuple[int, int], EndsProfile] | None:
    """The pitch that ends ``i`` and ``j`` (a step up from ``i``) propose, refined on the
    ends that fit it; with its score (steps seen, ends that fit), or None where it is no
    staircase's (the module docstring). ``foot_h``, ``h``: the ends' feet and tops above
    the floor."""
    run = float(np.hypot(*(xy[j] - xy[i])))
    u = (xy[j] - xy[i]) / run
    k_i = round(h[i] / (h[j] - h[i]))
    if k_i < 1 or abs(math.degrees(math.atan2(u[1], u[0]))) > _MAX_YAW_DEG + 10.0:
        return None
    rise = 0.5 * (h[i] / k_i + h[j] / (k_i + 1))
    fits = np.zeros(len(h), dtype=bool)
    fits[[i, j]] = True
    k = np.round(h / rise).astype(int)
    for _ in range(3):
        # the axis the side's ends line up along, then the pitch line along it
        u = _side_direction(xy, fits, i, u)
        v = np.array([-u[1], u[0]])
        along, across = xy @ u, xy @ v
        A = np.column_stack([np.ones(np.count_nonzero(fits)), k[fits] - k_i])
        a_i, run = (float(x) for x in np.linalg.lstsq(A, along[fits], rcond=None)[0])
        k = np.round(h / rise).astype(int)
        fits = (k >= 1) & (np.abs(h - k * rise) <= _TOP_M)
        fits &= np.abs(along - (a_i + (k - k_i) * run)) <= _ALONG_M
        fits &= (foot_h >= (k - 1) * rise - _FOOT_BELOW_M) & (h - foot_h <= rise + _TALLER_M)
        fits &= _on_sides(across, fits, i)
        kf = k[fits]
        if len(set(kf.tolist())) < 2:
            return None
        rise = float(np.sum(kf * h[fits]) / np.sum(kf * kf))  # tops k rises above the floor
        ok_rise = RISE_RANGE_M[0] <= rise <= RISE_RANGE_M[1]
        if not (ok_rise and config.min_run_m <= run <= config.continue_max_run_m):
            return None
    if abs(math.degrees(math.atan2(u[1], u[0]))) > _MAX_YAW_DEG:
        return None
    side = fits & (np.abs(across - across[i]) <= _SIDE_M)
    seen = sorted(set(kf.tolist()))
    first = a_i - (k_i - 1) * run
    gaps = seen[-1] - seen[0] + 1 - len(seen)
    if len(set(k[side].tolist())) < MIN_SIDE_STEPS or seen[0] - 1 > _MAX_BELOW or gaps > _MAX_GAPS:
        return None
    if first < _MIN_FIRST_M:
        return None
    lateral = (float(across[fits].min()), float(across[fits].max()))
    profile = EndsProfile(math.atan2(u[1], u[0]), rise, run, first, seen[-1], tuple(seen), lateral)
    return (len(seen), int(np.count_nonzero(fits))), profile


def _on_sides(across: np.ndarray, fits: np.ndarray, i: int) -> np.ndarray:
    """Which of the ends ``fits`` stand on one of the staircase's two sides: end ``i``'s
    line along the axis, or the line across from it (``across``: the ends' lateral
    positions) that holds most of the others, two or more of them, within ``_SIDE_M``."""
    own = np.abs(across - across[i]) <= _SIDE_M
    others = np.flatnonzero(fits & ~own)
    if len(others) < 2:
        return own
    near = np.abs(across[others][:, None] - across[others][None, :]) <= _SIDE_M
    count = near.sum(axis=1)
    if count.max() < 2:
        return own
    line = across[others[int(np.argmax(count))]]
    return own | (np.abs(across - line) <= _SIDE_M)


def _side_direction(xy: np.ndarray, fits: np.ndarray, i: int, u: np.ndarray) -> np.ndarray:
    """The stair axis (unit, horizontal, the way ``u`` points) that the ends ``fits`` on
    end ``i``'s side of the staircase line up along (their principal direction; ``u``
    where fewer than two): a pair of ends a run apart gives it to a few degrees, which
    their lateral offset turns into centimetres along the axis."""
    v = np.array([-u[1], u[0]])
    side = fits & (np.abs((xy - xy[i]) @ v) <= _SIDE_M)
    if np.count_nonzero(side) < 2:
        return u
    q = xy[side] - xy[side].mean(axis=0)
    w = np.linalg.eigh(q.T @ q)[1][:, -1]
    return w if w @ u >= 0 else -w


def staircase_from_ends(
    kept: StairModel, planes: PlaneSet, config: TerrainConfig, lines: ImageLines
) -> StairModel | None:
    """The staircase of the risers' ends (:func:`ends_profile`), finished as a chain is
    (the nosings beyond, the common rise, the polytope, the note), where it holds a riser
    of ``kept`` that the planes measured and has more steps than ``kept``, or as many and
    better rises (:func:`_mends_rises`); where it holds none, in place of a ``kept``
    staircase it outweighs (:func:`_outweighs`, ``config.ends_over_planes``) with as many
    steps or more; else None. The
    frame's origin is on the floor (``floor_known``); ``planes``: ``kept``'s (their
    samples, in the same frame).

    Where the ends show one side only, the staircase's width is ``kept``'s polytope's."""
    if kept.obstacle == NONE or not kept.steps:
        return None
    ground_z = 0.0
    profile = ends_profile(lines.vertical_edges, ground_z, config)
    if profile is None or profile.steps < len(kept.steps):
        return None
    held = _holds(profile, kept, ground_z)
    if not held and not (config.ends_over_planes and _outweighs(profile, kept)):
        return None
    as_many = profile.steps == len(kept.steps)
    if held and as_many and not _mends_rises(profile, kept, ground_z, config):
        return None
    u, v = stair_axes(profile.yaw_rad)
    lo, hi = profile.lateral
    if kept.polytope.vertices.size:
        across = kept.polytope.vertices @ v
        lo, hi = min(lo, float(across.min())), max(hi, float(across.max()))
    lateral = (lo, hi)
    P = planes.samples.points.astype(np.float64)
    s_all, v_all = P @ u, P @ v
    steps, ordered = [], []
    for k in range(1, profile.steps + 1):
        a = profile.first_m + (k - 1) * profile.run_m
        top = ground_z + k * profile.rise_m
        plane = Plane(-u, a)  # vertical, facing the robot, u . x = a
        inferred = k not in profile.seen
        run = profile.run_m if k < profile.steps else None
        steps.append(
            Step(
                profile.rise_m,
                run,
                riser_distance(plane, a, u),
                hi - lo,
                top,
                a,
                plane,
                rise_inferred=inferred,
                position_inferred=inferred,
            )
        )
        if not inferred:
            foot = top - profile.rise_m
            ordered.append(face_riser(P, s_all, v_all, plane, a, foot, top, lateral, config.merge_distance_m))
    below = profile.seen[0] - 1
    chain = Chain(
        planes,
        P,
        tuple(steps),
        tuple(ordered),
        profile.yaw_rad,
        ground_z,
        horizontal_info(planes, P, u, v),
        lateral,
        False,
        below,
        0,
    )
    # Not the photometric risers (a painted riser's two images have nothing to agree on),
    # nor the ends again.
    finishing = dataclasses.replace(config, photometric_risers=False, riser_end_steps=False)
    model = finish_chain(chain, finishing, lines, origin=ORIGIN)
    if model.obstacle != STAIRS or len(model.steps) < len(kept.steps):
        return None
    if len(model.steps) == len(kept.steps) and not as_many:
        return None
    if not held:
        replaced = f"the planes' staircase of {len(kept.steps)} step(s), which held none of the ends"
        note = f"{model.note}; in place of {replaced}"
        model = dataclasses.replace(model, note=note)
    return model


def _outweighs(profile: EndsProfile, kept: StairModel) -> bool:
    """Whether ``profile``, which holds none of ``kept``'s measured risers, is the better
    staircase: ``kept`` is a staircase (not a box: a piano's bench and its keys' ends
    made a three-step profile on a real room at webcam quality), and the profile shows
    its own first step's ends or has more steps than ``kept``.

    On rendered stairs (realistic, lab-like, landings) 18 of the 20 such profiles lay
    within 2 deg of the true stair axis (the others 2.8 and 5.1), while the planes'
    staircases they disagreed with were 13-42 deg off, or a step late, or a rise short
    (docs/benchmarks.md, "Forty-fifth session"). A profile
    whose first step is inferred, of as many steps, stays out: its first riser is the
    less sure (realistic 11 scene 54: 17 cm off where the planes' was within 1)."""
    return kept.obstacle == STAIRS and (profile.seen[0] == 1 or profile.steps > len(kept.steps))


def _holds(profile: EndsProfile, kept: StairModel, ground_z: float) -> bool:
    """Whether one of ``kept``'s risers that the planes measured lies on ``profile`` (the
    floor at ``ground_z``; ``_KEPT_ALONG_M``)."""
    turn = abs(math.remainder(profile.yaw_rad - kept.yaw_rad, 2.0 * math.pi))
    if math.degrees(turn) > _KEPT_YAW_DEG:
        return False
    for s in kept.steps:
        if s.rise_inferred or s.position_inferred:
            continue
        if s.tread is None:  # its top is its riser's top edge, found low: its place alone
            k = round((s.axis_position_m - profile.first_m) / profile.run_m) + 1
            on_height = True
        else:
            k = round((s.top_z_m - ground_z) / profile.rise_m)
            on_height = abs(s.top_z_m - ground_z - k * profile.rise_m) <= _KEPT_TOP_M
        a_k = profile.first_m + (k - 1) * profile.run_m
        if 1 <= k <= profile.steps and on_height and abs(s.axis_position_m - a_k) <= _KEPT_ALONG_M:
            return True
    return False


def _mends_rises(profile: EndsProfile, kept: StairModel, ground_z: float, config: TerrainConfig) -> bool:
    """Whether ``profile``, of as many steps as ``kept``, gives ``kept`` better rises: it
    starts at ``kept``'s first riser (within ``_KEPT_ALONG_M``), one of ``kept``'s
    rises is ``_RISE_OFF_M`` or more off its rise, and ``kept``'s own measure is the weaker:
    its measured rises disagree among themselves (by more than
    ``config.common_rise_tolerance_m``), or every top a tread measured lies on the
    profile (within ``_MENDED_TOP_M``), so that only the rise ``kept`` reports is off.

    Where ``kept``'s treads agree with each other and not with the profile, they are the
    better measure: a staircase along a side wall, whose risers' ends against the wall
    gave a rise of 15.3 cm for 17 (tests/test_terrain.py), where the treads measured it
    within 1.5."""
    if abs(kept.steps[0].axis_position_m - profile.first_m) > _KEPT_ALONG_M:
        return False
    if max(abs(s.rise_m - profile.rise_m) for s in kept.steps) < _RISE_OFF_M:
        return False
    own = [s.own_rise_m for s in kept.steps if not s.rise_inferred]
    if len(own) >= 2 and max(own) - min(own) > config.common_rise_tolerance_m:
        return True
    return all(
        abs(s.top_z_m - ground_z - k * profile.rise_m) <= _MENDED_TOP_M
        for k, s in enumerate(kept.steps, start=1)
        if not s.rise_inferred and s.tread is not None
    )
