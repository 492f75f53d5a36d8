"""A staircase none of whose risers formed a plane, from the first riser the image's lines
show (issue 11; :mod:`.nosings.first_riser`), finished as a chain of one riser plane is
(:func:`~.chain.finish_chain`: the nosings' pitch, the nosings beyond, their rise).

The pipeline asks for it last, where every pass and second opinion found nothing and the
floor is known (``TerrainConfig.lines_first_riser``): it adds staircases to frames that had
none and changes no other. After the risers' ends, where those found nothing either, it
asks once more with the first riser's foot where the floor the matcher holds ends in front
of the lines (:func:`floor_edge_feet`, ``TerrainConfig.floor_edge_foot``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..msac import Plane
from ..planes.orientation import PlaneSet
from .chain import Chain, finish_chain, horizontal_info, samples_along
from .model import STAIRS, StairModel, Step, TerrainConfig, stair_axes
from .nosings import FirstRiser, ImageLines, first_risers, line_axes, nosings_over
from .nosings.view import Segments, parallel_segments
from .risers import face_riser, riser_distance

#: The fewest steps a staircase from the lines must have: a lone pair of edges, or two, is
#: any box's or shelf's.
MIN_STEPS = 3

#: The fewest where the first riser's foot is the floor's far edge (:func:`floor_edge`):
#: the floor the matcher holds ends there, and the nosings over it rise by a stair's rise
#: twice (one more nosing at the second rise allowed with a line's foot made a 9 cm
#: "staircase" of an empty realistic render's floor lines; docs/benchmarks.md,
#: "Forty-eighth session").
MIN_STEPS_AT_FLOOR_EDGE = 2

#: The floor's far edge in front of a foot's line: this percentile of the floor's inliers'
#: positions along the axis there (the last few per cent are the strays of a painted
#: riser's samples, which lie along their rays beyond its foot).
FLOOR_EDGE_PCT = 98.0

#: Of the samples where a lines' staircase would stand, fewer than this share higher than
#: half its first rise is a floor's (:func:`_flat_where_it_stands`).
RISING_SHARE = 0.25

#: The ground's planes as :func:`_ground_holds` and :func:`floor_edge` take them: the
#: horizontal planes' heights, their inliers' positions along the stair axis and across
#: it, and the ground's height.
Ground = tuple[list[float], list[np.ndarray], list[np.ndarray], float]

#: How the note says where the steps come from (``finish_chain``'s "from N riser plane(s)").
ORIGIN = "from the image's lines (no riser formed a plane: the first riser's foot and nosing are lines)"
ORIGIN_AT_FLOOR_EDGE = (
    "from the floor's edge and the image's lines (no riser formed a plane: the first riser's foot "
    "is where the floor the matcher holds ends, its nosing a line)"
)


def staircase_from_lines(
    planes: PlaneSet, config: TerrainConfig, lines: ImageLines, *, at_floor_edge: bool = False
) -> StairModel | None:
    """The staircase of the first riser the image's lines show (:mod:`.nosings.first_riser`),
    finished as a one-riser chain, where it has ``MIN_STEPS`` or more; None where none does.
    The frame's origin is on the floor (``floor_known``). With ``at_floor_edge``, the first
    risers whose feet are where the floor ends in front of those lines instead
    (:func:`floor_edge_feet`), where they make ``MIN_STEPS_AT_FLOOR_EDGE`` or more.

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
    fewest, origin = (MIN_STEPS_AT_FLOOR_EDGE, ORIGIN_AT_FLOOR_EDGE) if at_floor_edge else (MIN_STEPS, ORIGIN)
    height = P[:, 2] - ground_z  # each sample's above the ground
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
        if at_floor_edge:
            feet = floor_edge_feet(feet, ground, lines, segs, u, v, samples.stride_px, config)
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
                chain = Chain(planes, P, (step,), (riser,), yaw, ground_z, h_info, lateral, False, 0, 0)
                models.append(finish_chain(chain, finishing, lines, origin=origin))
            beyond = [_ground_holds(ground, (s_lo, _far_end(a0, m, config)), lateral, config) for m in models]
            if all(beyond):
                continue  # a line on the floor, or a box's front: the floor goes on beyond it
            found = [
                m
                for m, b in zip(models, beyond, strict=True)
                if m.obstacle == STAIRS
                and len(m.steps) >= fewest
                and not b
                and not _flat_where_it_stands(m, a0, s_all, v_all, height, lateral, config)
            ]
            if found:
                along = max(found, key=lambda m: len(m.steps))
                if best is None or len(along.steps) > len(best.steps):
                    best = along
            break  # the first riser's foot: the staircase is its or none
    return best


def floor_edge_feet(
    feet: dict[float, list[FirstRiser]],
    ground: Ground,
    lines: ImageLines,
    segs: Segments,
    u: np.ndarray,
    v: np.ndarray,
    stride_px: int,
    config: TerrainConfig,
) -> dict[float, list[FirstRiser]]:
    """The first risers whose feet the floor's far edge shows in front of the feet of
    ``feet`` (foot position along the axis -> its first risers, nearest first;
    :func:`floor_edge`), with the nosings over each, nearest first. Not one within two
    ``merge_distance_m`` of a foot's line (that line is the foot), nor one where the
    samples' grid rows (``stride_px`` apart) lie more than half a short run
    (``continue_min_run_m``) apart on the floor (a level camera's ``depth**2 * stride /
    (focal * height)``): the edge is placed to a row, the nosing's height over it with it,
    and there the floor's samples end at the cloud's far limit as often as at a foot
    (OAK-D-like stairs 4 m ahead without a rig: an edge at 3.2 m, four steps of 27.4 cm
    for five of 18.4).

    A painted riser on a textured floor: its foot is a shading edge against the floor's
    grain and joints, which breaks into short segments, and the first long line on the
    floor is the first nosing, seen where its ray meets the floor (on realistic 41 scene
    48, 1.57 m for a riser at 1.22 m). The floor the matcher holds in front of that line
    ends at the true foot, and the nosing's line, met with the riser plane there, is at
    the stair's rise."""
    added: dict[float, list[FirstRiser]] = {}
    c = lines.centre
    height = float(c[2]) - ground[3]
    if height <= 0.0:
        return added
    for a0, over in feet.items():
        lateral = over[0].lateral
        edge = floor_edge(ground, a0, lateral, config)
        if edge is None or any(abs(edge - a) < 2.0 * config.merge_distance_m for a in [*feet, *added]):
            continue
        middle = edge * u + 0.5 * (lateral[0] + lateral[1]) * v + [0.0, 0.0, ground[3]]
        depth = float((middle - c) @ lines.T_frame_camera[:3, 2])  # along the optical axis
        if depth**2 * stride_px / (lines.focal_px * height) > 0.5 * config.continue_min_run_m:
            continue
        tops = nosings_over(lines, segs, u, v, edge, lateral, ground[3], config)
        if tops:
            added[edge] = [FirstRiser(edge, top, lateral) for top in tops]
    return dict(sorted(added.items()))


def floor_edge(
    ground: Ground,
    a0: float,
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> float | None:
    """Where the floor the matcher holds ends in front of ``a0`` (metres along the stair
    axis) within ``lateral``: the :data:`FLOOR_EDGE_PCT` percentile of the positions of
    the floor planes' inliers there (``ground`` as :func:`_ground_holds` takes it). None
    where they are fewer than four treads' worth (``min_tread_points``), or the edge is
    within half a short run (``continue_min_run_m``) of ``a0``: there the line is the
    foot."""
    h_z, s_h, v_h, ground_z = ground
    along = samples_along(h_z, s_h, v_h, ground_z, config.tread_height_tolerance_m, (-np.inf, a0), lateral)
    if len(along) < 4 * config.min_tread_points:
        return None
    edge = float(np.percentile(along, FLOOR_EDGE_PCT))
    return edge if edge < a0 - 0.5 * config.continue_min_run_m else None


def _flat_where_it_stands(
    model: StairModel,
    a0: float,
    s_all: np.ndarray,
    v_all: np.ndarray,
    height: np.ndarray,
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> bool:
    """Whether the samples where ``model`` (first riser at ``a0``) would stand, beyond its
    foot to its last tread's end (:func:`_far_end`) and across ``lateral``, lie at the
    floor's height: two treads' worth (``min_tread_points``) or more of them, and under
    :data:`RISING_SHARE` of them higher than half its first rise (``height``: each
    sample's above the ground). The floor's planes may hold few of a plank floor's
    samples (realistic 37 scene 48 with its rig, an empty corridor: two planes of about
    100 inliers, and 203 samples beyond a plank joint taken for a foot, none of them half a
    rise up, made three steps of the joints beyond). A staircase's samples there, however
    badly a painted face is matched, lie along rays that meet its risers and treads: of
    the 18 true staircases the lines found on the rendered sets, the 14 with 30 samples
    or more there had 72-100% of them higher (docs/benchmarks.md, "Forty-eighth
    session")."""
    far = _far_end(a0, model, config)
    inside = (s_all > a0 + config.merge_distance_m) & (s_all < far)
    inside &= (v_all > lateral[0]) & (v_all < lateral[1])
    if np.count_nonzero(inside) < 2 * config.min_tread_points:
        return False
    rising = float(np.mean(height[inside] > 0.5 * model.steps[0].rise_m))
    return rising < RISING_SHARE


def _far_end(a0: float, model: StairModel, config: TerrainConfig) -> float:
    """Where along the axis the last tread of ``model`` (first riser at ``a0``) ends; at
    least ``continue_min_run_m`` beyond ``a0``."""
    end = a0 + config.continue_min_run_m
    if model.steps:
        last = model.steps[-1]
        end = max(end, last.axis_position_m + (last.run_m or model.steps[0].run_m or 0.0))
    return end


def _ground_holds(
    ground: Ground,
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
    count = len(samples_along(h_z, s_h, v_h, ground_z, config.tread_height_tolerance_m, along, lateral))
    return count >= config.min_tread_points
