"""A staircase none of whose risers formed a plane, from the first riser the image's lines
show (issue 11; :mod:`.nosings.first_riser`), finished as a chain of one riser plane is
(:func:`~.assemble._finish`: the nosings' pitch, the nosings beyond, their rise).

The pipeline asks for it last, where every pass and second opinion found nothing and the
floor is known (``TerrainConfig.lines_first_riser``): it adds staircases to frames that had
none and changes no other.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._numeric import median
from ..msac import Plane
from ..planes.orientation import HORIZONTAL, PlaneSet
from .assemble import _Chain, _finish
from .model import STAIRS, StairModel, Step, TerrainConfig
from .nosings import FirstRiser, ImageLines, first_risers, line_axes
from .nosings.view import parallel_segments
from .risers import _Riser, riser_distance

#: The fewest steps a staircase from the lines must have: a lone pair of edges, or two, is
#: any box's or shelf's.
MIN_STEPS = 3


def staircase_from_lines(planes: PlaneSet, config: TerrainConfig, lines: ImageLines) -> StairModel | None:
    """The staircase of the first riser the image's lines show (:mod:`.nosings.first_riser`),
    finished as a one-riser chain, where it has ``MIN_STEPS`` or more; None where none does.
    The frame's origin is on the floor (``floor_known``).

    Along each stair axis the lines show, the feet are taken nearest first. A foot without
    the ground's plane a run's length in front of it is no first riser's; one with the
    ground's plane beyond it, where each staircase it makes would stand
    (:func:`_ground_plane_holds`), is a line on the floor (or a box's front), and the next
    is looked at. The first other foot
    is the first riser's: its staircase with most steps (of the nosings over it), or none
    where it makes none: a farther foot would skip the first riser and put the staircase
    a step or more too far (on a realistic render 0.7 m). Of the axes, the staircase with
    most steps."""
    samples = planes.samples
    P = samples.points.astype(np.float64)
    horizontals = [s for s in planes.segments if s.kind == HORIZONTAL]
    h_z = [float(median(P[h.indices, 2])) for h in horizontals]
    ground_z = 0.0
    # Not the photometric risers: a painted riser's two images have nothing to agree on.
    finishing = dataclasses.replace(config, photometric_risers=False)
    best: StairModel | None = None
    for yaw in line_axes(lines):
        u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        v = np.array([-u[1], u[0], 0.0])
        segs = parallel_segments(lines, v)
        if segs is None:
            continue
        s_h = [P[h.indices] @ u for h in horizontals]
        v_h = [P[h.indices] @ v for h in horizontals]
        h_info = list(zip(horizontals, h_z, s_h, v_h, strict=True))
        feet: dict[float, list[FirstRiser]] = {}
        for first in first_risers(lines, segs, u, v, ground_z, config):
            feet.setdefault(first.axis_position_m, []).append(first)
        for a0, over in feet.items():  # nearest first
            lateral = over[0].lateral
            if not _ground_plane_holds(h_info, ground_z, a0 - config.continue_max_run_m, a0, lateral, config):
                continue  # no floor seen just in front of it: no foot on the floor
            s_lo = a0 + config.merge_distance_m
            if _ground_plane_holds(h_info, ground_z, s_lo, a0 + config.continue_min_run_m, lateral, config):
                continue  # the floor goes on just beyond it: a line on the floor (no chain needed)
            plane = Plane(-u, a0)  # vertical, facing the robot, u . x = a0
            models = []
            for first in over:
                riser = _line_riser(P, plane, u, v, a0, first.top_z_m, lateral, ground_z, config)
                width = lateral[1] - lateral[0]
                step = Step(
                    first.top_z_m - ground_z,
                    None,
                    riser_distance(plane, a0, u),
                    width,
                    first.top_z_m,
                    a0,
                    plane,
                )
                chain = _Chain(planes, P, (step,), (riser,), yaw, ground_z, h_info, lateral, False, 0, 0)
                models.append(_finish(chain, finishing, lines))
            beyond = [
                _ground_plane_holds(h_info, ground_z, s_lo, _far_end(a0, m, config), lateral, config)
                for m in models
            ]
            if all(beyond):
                continue  # a line on the floor, or a box's front: the floor goes on beyond it
            found = [
                m
                for m, b in zip(models, beyond, strict=True)
                if m.obstacle == STAIRS and len(m.steps) >= MIN_STEPS and not b
            ]
            if found:
                along = max(found, key=lambda m: len(m.steps))
                if best is None or len(along.steps) > len(best.steps):
                    best = along
            break  # the first riser's foot: the staircase is its or none
    if best is None:
        return None
    note = best.note.replace(
        "from 1 riser plane(s)",
        "from the image's lines (no riser formed a plane: the first riser's foot and nosing are lines)",
        1,
    )
    return dataclasses.replace(best, note=note)


def _line_riser(
    P: np.ndarray,
    plane: Plane,
    u: np.ndarray,
    v: np.ndarray,
    a0: float,
    top: float,
    lateral: tuple[float, float],
    ground_z: float,
    config: TerrainConfig,
) -> _Riser:
    """The riser the lines show at ``a0``, ``top`` high across ``lateral``, with the samples
    on its face (within ``merge_distance_m`` of it; few or none on a painted riser)."""
    s, lat, z = P @ u, P @ v, P[:, 2]
    face = (np.abs(s - a0) < config.merge_distance_m) & (lat > lateral[0]) & (lat < lateral[1])
    face &= (z > ground_z) & (z < top)
    return _Riser(plane, np.flatnonzero(face), a0, ground_z, top, lateral[0], lateral[1], False)


def _far_end(a0: float, model: StairModel, config: TerrainConfig) -> float:
    """Where along the axis the last tread of ``model`` (first riser at ``a0``) ends; at
    least ``continue_min_run_m`` beyond ``a0``."""
    end = a0 + config.continue_min_run_m
    if model.steps:
        last = model.steps[-1]
        end = max(end, last.axis_position_m + (last.run_m or model.steps[0].run_m or 0.0))
    return end


def _ground_plane_holds(
    h_info: list,
    ground_z: float,
    s_lo: float,
    s_hi: float,
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> bool:
    """Whether the ground's planes (horizontal planes within ``tread_height_tolerance_m``
    of ``ground_z``: a floor's plane may be split in two a few centimetres apart) hold
    ``min_tread_points`` samples or more between ``s_lo`` and ``s_hi`` along the axis,
    within ``lateral``.

    The ground plane's samples are the matcher's well-placed ones: a painted riser's
    samples lie anywhere along their rays (on a realistic render, from 6 cm above the
    floor to 10 cm below it, 3-45 cm beyond the riser) and form no plane with the floor.
    Asked of a run's length in front of a foot (a staircase whose first riser the lines
    skipped has a tread there, not the floor: the ground plane held 1-4 samples there
    against 240-540 for the true first risers of the realistic renders) and of where the
    staircase would stand beyond it (a box's front and top edge, with its far top edge
    and the wall behind, fit a pitch of three steps; so does a line on the floor in front
    of the real first riser, or a plank floor's joints)."""
    count = 0
    for _h, hz, sh, vh in h_info:
        if abs(hz - ground_z) > config.tread_height_tolerance_m:
            continue
        count += int(np.sum((sh > s_lo) & (sh < s_hi) & (vh > lateral[0]) & (vh < lateral[1])))
    return count >= config.min_tread_points
