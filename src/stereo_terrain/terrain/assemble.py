"""The chain assembly: stair-axis families of riser candidates, the ground, the steps
chained from it (the first-step rules), and what they make (stairs, a box or nothing:
each family's chain is finished by :func:`~.chain.finish_chain`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._numeric import median, percentile  # NumPy's bits, a fraction of its time (issue 13)
from ..msac import Plane
from ..planes.orientation import HORIZONTAL, VERTICAL, PlaneSet
from .below import Link as _Link
from .below import steps_below
from .chain import Chain, finish_chain, samples_along, tread_between
from .continuation import continue_steps
from .model import NONE, Polytope, StairModel, Step, TerrainConfig, stair_axes
from .nosings import ImageLines, axis_from_nosings
from .risers import (
    _LOW_INLIER_PCT,
    _axis_from_normal,
    _Riser,
    _riser_candidates,
    _riser_edges,
    _tread_front,
    edge_bias,
    riser_distance,
)

#: A merged riser whose refit normal has a larger vertical component (sin of ~6 deg, the
#: orientation method's tolerance) was two different faces.
_MAX_MERGED_RISER_TILT = 0.1


def _no_obstacle(planes: PlaneSet, note: str, ground_z: float = 0.0) -> StairModel:
    return StairModel(NONE, (), 0.0, ground_z, Polytope(np.zeros((0, 3))), planes.frame, note)


def _assemble(
    planes: PlaneSet,
    config: TerrainConfig,
    *,
    tread_first: bool = True,
    floor_known: bool = True,
    lines: ImageLines | None = None,
) -> StairModel:
    """:func:`build_terrain` for one set of limits (``tread_first``, ``lines``: see
    :func:`_assemble_along`)."""
    samples = planes.samples
    P = samples.points.astype(np.float64)
    cam = planes.camera_position
    verticals = [s for s in planes.segments if s.kind == VERTICAL]
    horizontals = [s for s in planes.segments if s.kind == HORIZONTAL]
    # Height of a horizontal plane where its points are (not its offset at the origin: a
    # plane tilted by a degree or two would be off by centimetres there).
    h_z = [float(median(P[h.indices, 2])) for h in horizontals]
    lowest_z = min(h_z) if h_z else 0.0
    if not verticals:
        return _no_obstacle(planes, "no vertical plane found", lowest_z)

    cands = _riser_candidates(samples, P, cam, verticals, config, floor_z=0.0 if floor_known else None)
    if not cands:
        return _no_obstacle(
            planes, "no vertical plane looks like a riser (all too tall, small or facing away)", lowest_z
        )

    # Stair axis: the riser directions are grouped into families (within
    # ``axis_spread_deg`` of the one with most support), largest first. A rail, the
    # balusters' plane or a wall's low strip beside the stairs is vertical, short and
    # facing the camera like a riser, and may hold more points than the real risers (seen
    # from the side, the railing is nearer the camera than the stairs behind it); what
    # it never does is chain into steps. So every family is assembled, and the one whose
    # risers chain into most steps is the staircase (ties: the larger family).
    yaws = np.array([math.atan2(*_axis_from_normal(c.plane.normal)[[1, 0]]) for c in cands])
    weights = np.array([len(c.idx) for c in cands], dtype=float)
    spread = math.radians(config.axis_spread_deg)
    diff = np.abs((yaws[:, None] - yaws[None, :] + np.pi) % (2 * np.pi) - np.pi)
    free = np.ones(len(cands), dtype=bool)
    best: StairModel | None = None
    while free.any():
        support = (diff <= spread) @ (weights * free)
        ref = int(np.argmax(np.where(free, support, -1.0)))
        near = free & (diff[ref] <= spread)
        # The risers of one staircase are parallel: within ``axis_spread_deg`` of each
        # other, not only of ``ref`` (two risers on either side of it may be twice that
        # apart: a cloth's folds, not a staircase; issue 11). From ``ref``, largest first,
        # a riser joins when it is within the spread of every riser already in; one left
        # out stays free for a later family (a staircase beside two clutter faces).
        keep = np.zeros(len(cands), dtype=bool)
        keep[ref] = True
        for i in sorted(np.flatnonzero(near & ~keep), key=lambda i: -weights[i]):
            if np.all(diff[i, keep] <= spread):
                keep[i] = True
        yaw = float(
            np.arctan2(np.sum(weights[keep] * np.sin(yaws[keep])), np.sum(weights[keep] * np.cos(yaws[keep])))
        )
        free &= ~keep
        family = [c for c, k in zip(cands, keep, strict=True) if k]
        found = _assemble_along(
            planes, config, family, yaw, horizontals, h_z, tread_first=tread_first, floor_known=floor_known
        )
        model = found if isinstance(found, StairModel) else finish_chain(found, config)
        if best is None or _chained(model) > _chained(best):
            best, best_found, best_family = model, found, family
    assert best is not None
    images_help = (
        config.nosing_steps
        or config.nosing_rise
        or (config.photometric_risers and lines is not None and lines.stereo is not None)
    )
    if lines is not None and images_help and isinstance(best_found, Chain):
        # The steps the image's lines show beyond the chain and the rise their nosings show,
        # and the risers where the images put them, for the family that won only (they do
        # not count in the choice: the one is inferred, the other moves centimetres).
        best = finish_chain(best_found, config, lines)
    if lines is not None and config.nosing_axis and isinstance(best_found, Chain):
        # The axis the image's nosings show: the chain is assembled again along it and
        # finished so, and kept where it has as many steps (:mod:`.nosings.axis`).
        turned = axis_from_nosings(lines, best_found.yaw, best_found.steps, best_found.lateral)
        if turned is not None:
            again = _assemble_along(
                planes,
                config,
                best_family,
                turned,
                horizontals,
                h_z,
                tread_first=tread_first,
                floor_known=floor_known,
            )
            if isinstance(again, Chain):
                model = finish_chain(again, config, lines if images_help else None)
                if len(model.steps) >= len(best.steps):
                    best = model
    return best


def _chained(model: StairModel) -> int:
    """The steps a model chained from riser planes and treads: not those continued beyond
    the last riser plane (:mod:`.continuation`; inferred, never first)."""
    return len(model.steps) - sum(1 for s in model.steps[1:] if s.rise_inferred)


def _chain_above_ground(
    cands_all: list[tuple[float, float, _Riser | None, Plane, Plane | None]],
    chain_from,
    ground_z: float,
    u: np.ndarray,
    config: TerrainConfig,
) -> tuple[list[_Link], set[int]]:
    """Where nothing chains from the ground: a chain of two or more riser planes that
    starts above it, a whole number of its rises up (at most ``max_steps_below_chain``),
    with the steps below it inferred at its rise and run (issue 11).

    On realistic stairs the first riser often forms no plane while the upper ones do, in
    part; the chain from the ground then refuses them all ("floats above the current
    level"). A bookshelf's shelf fronts stand at regular heights too, but at one depth: the
    chain needs them a run apart. Returns the chain and the indices of its inferred steps
    (both empty when there is none); the longest such chain wins.
    """
    best: tuple[list[_Link], int, float, float, float] | None = None
    for s_pos, _top, cand, _riser, _tread in cands_all:
        if cand is None or cand.z_lo < ground_z + config.min_rise_m:
            continue
        sub = [link for link in chain_from(False, start_z=cand.z_lo) if link[4] >= s_pos - 1e-9]
        if len(sub) < 2 or sub[0][0] is not cand or sub[1][0] is None:
            continue
        rise = float(median(np.diff([cand.z_lo] + [link[1] for link in sub])))
        below = int(round((cand.z_lo - ground_z) / rise)) if rise > 0 else 0
        if not 1 <= below <= config.max_steps_below_chain:
            continue
        if abs(cand.z_lo - ground_z - below * rise) > config.chain_tolerance_m:
            continue  # not a whole number of steps above the ground
        run = float(median(np.diff([link[4] for link in sub])))
        if not config.min_run_m <= run <= config.continue_max_run_m:
            continue
        if best is None or len(sub) > len(best[0]):
            best = (sub, below, rise, run, s_pos)
    if best is None:
        return [], set()
    sub, below, rise, run, s0 = best
    chain: list[_Link] = []
    for j in range(1, below + 1):
        s_j = s0 - (below - j + 1) * run
        chain.append((None, ground_z + j * rise, Plane(-u, s_j), None, s_j))
    return chain + sub, set(range(below))


def _assemble_along(
    planes: PlaneSet,
    config: TerrainConfig,
    family: list[_Riser],
    yaw: float,
    horizontals: list,
    h_z: list[float],
    *,
    tread_first: bool = True,
    floor_known: bool = True,
) -> StairModel | Chain:
    """The chain of steps (continued beyond the last riser plane from the samples) whose
    risers are ``family`` along the stair axis at ``yaw``, for :func:`finish_chain`, or the
    model of no obstacle (the rest of :func:`_assemble`). ``tread_first``: the first step
    may stand at a tread's front edge when its riser is no plane and a riser plane chains
    behind it. ``floor_known``: as in :func:`build_terrain`."""
    samples = planes.samples
    P = samples.points.astype(np.float64)
    cam = planes.camera_position
    u, v = stair_axes(yaw)
    risers = [dataclasses.replace(r, s=float(median(P[r.idx] @ u))) for r in family]
    risers.sort(key=lambda r: r.s)

    # Merge duplicates (one riser split in two planes).
    merged: list[_Riser] = []
    for r in risers:
        if merged and abs(r.s - merged[-1].s) < config.merge_distance_m:
            a = merged[-1]
            idx = np.concatenate([a.idx, r.idx])
            plane = (Plane.estimate(P[idx]) or a.plane).oriented_toward(cam)
            lat = P[idx] @ v
            v_lo, v_hi = percentile(lat, [2, 98])
            edges = _riser_edges(
                P, plane, v, v_lo, v_hi, thr=config.edge_band_m, seed_z=float(median(P[idx, 2]))
            )
            if edges is None or abs(plane.normal[2]) > _MAX_MERGED_RISER_TILT:
                # Parallel planes a few cm apart, or two faces whose union is no vertical
                # plane, not one riser split in two: keep the larger.
                if len(r.idx) > len(a.idx):
                    merged[-1] = r
                continue
            z_lo, z_hi = edges
            merged[-1] = _Riser(
                plane,
                idx,
                float(median(P[idx] @ u)),
                z_lo,
                z_hi,
                float(v_lo),
                float(v_hi),
                a.touches_border or r.touches_border,
                a.foot_hidden or r.foot_hidden,
                a.in_wall or r.in_wall,
            )
        else:
            merged.append(r)

    # Ground: the lowest of the large horizontal planes (small spurious planes ignored)
    # below the cameras: a surface above them is seen from below, so it is no floor (a
    # ceiling, a shelf's underside, or the frame's up is wrong; issue 11).
    s_h = [P[h.indices] @ u for h in horizontals]
    v_h = [P[h.indices] @ v for h in horizontals]
    floors = [(z, h.count) for z, h in zip(h_z, horizontals, strict=True) if z < cam[2] - config.min_rise_m]
    if floors:
        big = max(c for _, c in floors)
        ground_z = min(z for z, c in floors if c >= 0.25 * big)
    elif horizontals and not floor_known:
        # Every horizontal surface is above the cameras and the frame has no floor of its
        # own either (no rig, none found: its origin is at the cameras): nothing to measure
        # a first rise from. (With a rig the origin is on the floor however low the
        # cameras are mounted, and the first riser's foot is the ground, as below.)
        return _no_obstacle(planes, "no horizontal surface below the cameras (no floor in view)", min(h_z))
    else:
        ground_z = merged[0].z_lo
    if (
        floor_known
        and ground_z > config.min_rise_m
        and any(abs(r.z_lo) <= config.chain_tolerance_m for r in merged)
    ):
        # The frame's origin is on the floor (a rig, or the floor plane found), the lowest
        # horizontal plane stands a step above it, and a riser's foot is on the floor: the
        # floor before the stairs formed no plane (a texture-poor or edge-on floor) and
        # that plane is a tread. The ground is the floor (issue 11).
        ground_z = 0.0

    def tread_above(r: _Riser, s_next: float, level: float) -> int | None:
        """Index of the active horizontal plane above riser ``r``: most inliers between it
        and the next riser, at the height of the riser's top edge."""
        best_h, best_count = None, 0
        for k in range(len(horizontals)):
            z = h_z[k]
            if abs(z - r.z_hi) > config.tread_height_tolerance_m or z < level + config.min_rise_m / 2:
                continue
            between = (s_h[k] > r.s) & (s_h[k] < s_next) & (v_h[k] > r.v_lo - 0.1) & (v_h[k] < r.v_hi + 0.1)
            count = int(between.sum())
            if count >= config.min_tread_points and count > best_count:
                best_h, best_count = k, count
        return best_h

    # Step candidates: every riser (top from the tread above it, else its top edge), and
    # every tread no riser claimed (its riser too small or too poorly matched to be a plane;
    # the riser is then put at the tread's front edge).
    cands_all: list[tuple[float, float, _Riser | None, Plane, Plane | None]] = []
    claimed: set[int] = set()
    for i, r in enumerate(merged):
        later = [q.s for q in merged[i + 1 :] if q.z_hi > r.z_hi + config.min_rise_m / 2]
        k = tread_above(r, later[0] if later else np.inf, ground_z)
        if k is not None:
            claimed.add(k)
        tread_plane, top = (horizontals[k].plane, h_z[k]) if k is not None else (None, r.z_hi)
        cands_all.append((r.s, top, r, r.plane, tread_plane))
    v_lo_all = min(r.v_lo for r in merged) - 0.1
    v_hi_all = max(r.v_hi for r in merged) + 0.1
    for k, h in enumerate(horizontals):
        if k in claimed or h.count < config.min_tread_points or h_z[k] < ground_z + config.min_rise_m:
            continue
        front = _tread_front(P, samples.normals, h.plane, u, v, v_lo_all, v_hi_all, thr=config.edge_band_m)
        if front is None:
            continue
        virtual = Plane(-u, front)  # vertical, facing the robot, through the front edge
        cands_all.append((front, h_z[k], None, virtual, h.plane))
    cands_all.sort(key=lambda c: c[0])

    # Chain the candidates from the ground up: each starts where the step before it ended.
    # A riser's bottom edge may be hidden behind the nosing when that level is above the
    # cameras. The first step must be a real riser plane, unless its riser was not matched
    # (a texture-poor face) and a real riser plane chains on the tread behind it: then the
    # first riser stands at that tread's front edge.
    def chain_from(virtual_first: bool, start_z: float | None = None) -> list[_Link]:
        """The chain from the ground (or from ``start_z``: see :func:`_chain_above_ground`)."""
        chain: list[_Link] = []
        level, last_s = (ground_z if start_z is None else start_z), -np.inf
        for s_pos, top, cand, riser_plane, tread_plane in cands_all:
            if top < level + config.min_rise_m or top - level > config.max_rise_m + config.edge_margin_m:
                continue
            if s_pos < last_s + config.min_run_m:
                continue  # too near the step before it for a run of a staircase
            if cand is None:
                if not chain and not virtual_first:
                    continue
            else:
                if cand.z_lo < level - config.edge_margin_m:
                    continue  # reaches below the current level: a wall or a side face
                if float(percentile(P[cand.idx, 2], _LOW_INLIER_PCT)) < level - config.edge_margin_m:
                    # Its band of edges sits on this level, but the plane's own points go on
                    # below it: a wall or a junk plane through several objects, not a riser.
                    continue
                # Its foot may be out of sight: behind the nosing when that level is above the
                # cameras, or below the image's bottom edge (then its bottom is the image's).
                hidden = level > cam[2] - config.edge_margin_m or cand.foot_hidden
                if cand.z_lo > level + config.chain_tolerance_m and not hidden:
                    continue  # floats above the current level: not the next step
            chain.append((cand, top, riser_plane, tread_plane, s_pos))
            level, last_s = top, s_pos
        return chain

    chain = chain_from(False)
    loose = chain_from(True) if tread_first else []
    if len(loose) > max(1, len(chain)) and loose[0][0] is None and loose[1][0] is not None:
        chain = loose
    below: set[int] = set()  # steps inferred below a chain that starts above the ground
    if not chain and config.max_steps_below_chain > 0:
        chain, below = _chain_above_ground(cands_all, chain_from, ground_z, u, config)
    if len(chain) == 1 and chain[0][0] is not None and chain[0][0].in_wall and chain[0][3] is None:
        # A riser found in line with a wall (risers._riser_beside_wall) is a staircase's
        # first step; alone, its top not seen, it is as likely a wall's low band (issue 11).
        chain = []

    # Stairs filling the view: the first riser's foot (and the floor before it) is below
    # the image, so the first tread was taken for the ground. A riser in front of the
    # chain, cut by the image's bottom edge, whose top is that "ground", is the first step;
    # its rise is not seen and is taken as the median of the others (a staircase's rises
    # are equal), and said so.
    # Which steps' tops are their riser's own top edge (for the edge bias below).
    own_edge = [c is not None and tread is None and top == c.z_hi for c, top, _, tread, _ in chain]
    inferred_first = first_cut_off = False
    if chain and chain[0][0] is not None:
        first_s = chain[0][4]
        # The same when the first riser's foot is in view but the floor in front of it formed
        # no plane (a texture-poor floor, issue 11): then its bottom edge is the floor.
        cut_off = [
            r
            for r in merged
            if (r.foot_hidden or _stands_below(P, r, ground_z, config))
            and r.s < first_s - config.merge_distance_m
            and abs(r.z_hi - ground_z) <= config.tread_height_tolerance_m
            and not _ground_before(s_h, v_h, h_z, ground_z, r, config)
        ]
        if cut_off:
            first_cut_off = True
            r0 = max(cut_off, key=lambda r: r.s)  # the one just before the chain
            ground_tread = tread_between(horizontals, h_z, s_h, ground_z, r0.s, first_s)
            chain.insert(0, (r0, ground_z, r0.plane, ground_tread, r0.s))
            own_edge.insert(0, False)
            if r0.foot_hidden:
                inferred_first = True
            else:
                ground_z = r0.z_lo
    if chain and not below and all(own_edge):
        # Every top is its riser's edge, each found low by about the same amount: the
        # rises between them cancel it and only the first, from the floor plane, keeps it.
        # (Where some tops are treads, moving the edge tops alone would move the rises
        # beside them; on the real Staircase that made one worse, 17.0 -> 17.5 cm against
        # 16.7: left alone. Steps inferred below a chain took their rise from its edges.)
        bias = edge_bias([(c[0], c[1]) for c in chain], cam[2], config)
        chain = [(c, top + bias, rp, tp, sp) for c, top, rp, tp, sp in chain]
    if floor_known and chain and not below and not first_cut_off and ground_z >= config.min_rise_m:
        # The frame's origin is on the floor, yet the chain starts above it: from the tread
        # of a step whose riser formed no plane, or the foot of the riser above that step,
        # the floor before it no plane either (a level camera sees a strip of it; issue 11).
        ground_k = [k for k, z in enumerate(h_z) if abs(z - ground_z) < 1e-9]
        ground_tread = horizontals[ground_k[0]].plane if ground_k else None
        lower = steps_below(chain, ground_z, ground_tread, planes, P, u, v, (v_lo_all, v_hi_all), config)
        if lower:
            chain = lower + chain
            below = set(range(len(lower))) if len(lower) > 1 else set()
            ground_z = 0.0
    rises_seen = [chain[i][1] - chain[i - 1][1] for i in range(1, len(chain))]
    if inferred_first:
        ground_z = ground_z - float(median(rises_seen)) if rises_seen else ground_z - config.min_rise_m

    steps: list[Step] = []
    prev_top = ground_z
    for i, (cand, top, riser_plane, tread_plane, s_pos) in enumerate(chain):
        rise = top - prev_top
        run = chain[i + 1][4] - s_pos if i + 1 < len(chain) else None
        distance = riser_distance(riser_plane, s_pos, u)
        width = None if cand is None or cand.touches_border else cand.v_hi - cand.v_lo
        steps.append(
            Step(
                float(rise),
                None if run is None else float(run),
                float(distance),
                None if width is None else float(width),
                float(top),
                s_pos,
                riser_plane,
                tread_plane,
                rise_inferred=(inferred_first and i == 0) or i in below,
            )
        )
        prev_top = top
    ordered = [c[0] for c in chain if c[0] is not None]

    if not steps:
        return _no_obstacle(planes, "risers found but no step rises above the ground", ground_z)
    h_info = list(zip(horizontals, h_z, s_h, v_h, strict=True))
    # (``ordered`` holds a riser plane once there are steps: the first step is one.)
    lateral = (min(r.v_lo for r in ordered), max(r.v_hi for r in ordered))
    # Before a single step is classified: a riser found beyond it makes it a staircase,
    # though the ground may be seen beyond its top elsewhere (which would make it a box).
    steps, continued = continue_steps(steps, planes, P, u, v, lateral, config)
    return Chain(
        planes,
        P,
        tuple(steps),
        tuple(ordered),
        yaw,
        ground_z,
        h_info,
        lateral,
        inferred_first,
        len(below),
        continued,
    )


def _stands_below(P: np.ndarray, r: _Riser, ground_z: float, config: TerrainConfig) -> bool:
    """Whether riser ``r`` (its foot in view) stands a step below ``ground_z``: its bottom
    edge is ``min_rise_m`` or more below it and its own points (not only its edge band,
    which takes in the surface at its foot) span ``min_rise_m`` of height."""
    z = P[r.idx, 2]
    lo, hi = percentile(z, [_LOW_INLIER_PCT, 100.0 - _LOW_INLIER_PCT])
    return r.z_lo < ground_z - config.min_rise_m and float(hi - lo) >= config.min_rise_m


def _ground_before(s_h, v_h, h_z, ground_z: float, r: _Riser, config: TerrainConfig) -> bool:
    """Whether the surface at ``ground_z`` is seen in front of riser ``r`` (before it along
    the stair axis, within its lateral extent): then it is the floor the riser stands on or
    beside, not a tread on top of it (issue 11)."""
    tol = config.tread_height_tolerance_m / 2
    lateral = (r.v_lo, r.v_hi)
    count = len(
        samples_along(h_z, s_h, v_h, ground_z, tol, (-np.inf, r.s - config.merge_distance_m), lateral)
    )
    return count >= config.min_tread_points
