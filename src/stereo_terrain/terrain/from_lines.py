"""A staircase none of whose risers formed a plane, from the first riser the image's lines
show (issue 11; :mod:`.nosings.first_riser`), finished as a chain of one riser plane is
(:func:`~.assemble._finish`: the nosings' pitch, the nosings beyond, their rise).

The pipeline asks for it last, where every pass and second opinion found nothing and the
floor is known (``TerrainConfig.lines_first_riser``): it adds staircases to frames that had
none and changes no other.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..msac import Plane
from ..planes.orientation import PlaneSet
from .assemble import _Chain, _finish, _samples_at, horizontal_info
from .model import STAIRS, StairModel, Step, TerrainConfig, stair_axes
from .nosings import FirstRiser, ImageLines, first_risers, line_axes
from .nosings.view import parallel_segments
from .risers import face_riser, riser_distance

#: The fewest steps a staircase from the lines must have: a lone pair of edges, or two, is
#: any box's or shelf's.
MIN_STEPS = 3

#: How the note says where the steps come from (``_finish``'s "from N riser plane(s)").
ORIGIN = "from the image's lines (no riser formed a plane: the first riser's foot and nosing are lines)"


def staircase_from_lines(planes: PlaneSet, config: TerrainConfig, lines: ImageLines) -> StairModel | None:
    """The staircase of the first riser the image's lines show (:mod:`.nosings.first_riser`),
    finished as a one-riser chain, where it has ``MIN_STEPS`` or more; None where none does.
    The frame's origin is on the floor (``floor_known``).

    Along each stair axis the lines show, the feet are taken nearest first. A foot without
    the ground's plane a run's length in front of it is no first riser's; one with the
    ground's plane beyond it, where each staircase it makes would stand
    (:func:`_ground_holds`), is a line on the floor (or a box's front), and the next is
    looked at. The first other foot is the first riser's: its staircase with most steps
    (of the nosings over it), or none where it makes none: a farther foot would skip the
    first riser and put the staircase a step or more too far (on a realistic render 0.7
    m). Of the axes, the staircase with most steps."""
    samples = planes.samples
    P = samples.points.astype(np.float64)
    ground_z = 0.0
    # Not the photometric risers: a painted riser's two images have nothing to agree on.
    finishing = dataclasses.replace(config, photometric_risers=False)
    best: StairModel | None = None
    for yaw in line_axes(lines):
        u, v = stair_axes(yaw)
        segs = parallel_segments(lines, v)
        if segs is None:
            continue
        s_all, v_all = P @ u, P @ v
        h_info = horizontal_info(planes, P, u, v)
        ground = ([h[1] for h in h_info], [h[2] for h in h_info], [h[3] for h in h_info], ground_z)
        feet: dict[float, list[FirstRiser]] = {}
        for first in first_risers(lines, segs, u, v, ground_z, config):
            feet.setdefault(first.axis_position_m, []).append(first)
        for a0, over in feet.items():  # nearest first
            lateral = over[0].lateral
            if not _ground_holds(ground, (a0 - config.continue_max_run_m, a0), lateral, config):
                continue  # no floor seen just in front of it: no foot on the floor
            s_lo = a0 + config.merge_distance_m
            if _ground_holds(ground, (s_lo, a0 + config.continue_min_run_m), lateral, config):
                continue  # the floor goes on just beyond it: a line on the floor (no chain needed)
            plane = Plane(-u, a0)  # vertical, facing the robot, u . x = a0
            models = []
            for first in over:
                top = first.top_z_m
                riser = face_riser(
                    P, s_all, v_all, plane, a0, ground_z, top, lateral, config.merge_distance_m
                )
                width = lateral[1] - lateral[0]
                step = Step(top - ground_z, None, riser_distance(plane, a0, u), width, top, a0, plane)
                chain = _Chain(planes, P, (step,), (riser,), yaw, ground_z, h_info, lateral, False, 0, 0)
                models.append(_finish(chain, finishing, lines, origin=ORIGIN))
            beyond = [_ground_holds(ground, (s_lo, _far_end(a0, m, config)), lateral, config) for m in models]
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
    return best


def _far_end(a0: float, model: StairModel, config: TerrainConfig) -> float:
    """Where along the axis the last tread of ``model`` (first riser at ``a0``) ends; at
    least ``continue_min_run_m`` beyond ``a0``."""
    end = a0 + config.continue_min_run_m
    if model.steps:
        last = model.steps[-1]
        end = max(end, last.axis_position_m + (last.run_m or model.steps[0].run_m or 0.0))
    return end


def _ground_holds(
    ground: tuple[list[float], list[np.ndarray], list[np.ndarray], float],
    along: tuple[float, float],
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> bool:
    """Whether the ground's planes (``ground``: the horizontal planes' heights, their
    inliers' positions along the axis and across, the ground's height; those within
    ``tread_height_tolerance_m`` of it count: a floor's plane may be split in two a few
    centimetres apart) hold ``min_tread_points`` samples or more between ``along`` and
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
    h_z, s_h, v_h, ground_z = ground
    count = _samples_at(h_z, s_h, v_h, ground_z, config.tread_height_tolerance_m, along, lateral)
    return count >= config.min_tread_points
