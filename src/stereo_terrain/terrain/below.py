"""Steps below a chain that starts above a known floor (issue 11).

With a rig, the frame's origin is on the floor the robot stands on. When the realistic
stairs' first riser forms no plane and the floor before it forms none either (a level
camera sees only a strip of it), the lowest surface the terrain stage finds is the first
tread, or the foot of the second riser: the chain of steps starts there, a step (or two)
above the floor, and the robot would be told of a first step a run beyond the real one, of
the wrong height. The floor is known, so those steps are there. Their risers are placed
where the samples show them:

1. the front edge of the horizontal plane the chain stands on, when it is one (a tread
   ends at its riser's top);
2. else a band of the samples no plane took, at one position along the stair axis between
   the floor and that height, a run before the chain (as :mod:`.continuation` finds a
   riser beyond the last one);

and, for a second step below, a run before that. The steps' rises split the height evenly
(a staircase's rises are equal); their number is the height over the chain's rise, which
must be a whole number of them within ``chain_tolerance_m``. Nothing is added where the
position is not seen: a step reported a run away from where it is would be worse than the
one reported late.

Without a rig the floor is the lowest large horizontal plane the scene shows
(``pipeline.gravity_steps.origin_on_floor``); where the floor before the stairs formed no
plane, that is the first tread, and nothing tells the chain it starts a step up.
:func:`samples_below_floor` counts what does: the first riser's samples, below that
"floor" and in front of the chain, where the "floor" does not run out of the view's
bottom (:func:`floor_to_view_bottom`; ``pipeline.second_opinions.floor_a_step_below``
then puts the floor a rise lower and builds the terrain again).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._numeric import median
from ..msac import Plane
from ..planes.orientation import HORIZONTAL, PlaneSet
from .continuation import free_samples, riser_band
from .model import Polytope, StairModel, Step, TerrainConfig, stair_axes
from .nosings import ImageLines, nosing_under_first
from .risers import _Riser, _tread_front, riser_distance

#: A link of the chain of steps: (riser candidate or None, top height, riser plane, tread
#: plane or None, position along the stair axis); as in :mod:`.assemble`.
Link = tuple[_Riser | None, float, Plane, Plane | None, float]


def steps_below(
    chain: list[Link],
    ground_z: float,
    ground_tread: Plane | None,
    planes: PlaneSet,
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    config: TerrainConfig,
) -> list[Link]:
    """The links of the steps between the floor (height 0) and a chain that starts at
    ``ground_z`` above it (module docstring), nearest first; empty where their number or
    their place is not clear.

    Parameters
    ----------
    chain : the chain from ``ground_z`` (at least one link)
    ground_z : the height the chain starts from, metres above the floor
    ground_tread : the horizontal plane at ``ground_z``, when it is one
    planes, P : the plane set and its samples' points (gravity-aligned frame)
    u, v : the stair axis and the lateral direction
    lateral : the staircase's lateral extent along ``v``
    config : TerrainConfig (``max_steps_below_chain``, ``chain_tolerance_m``,
        ``min_rise_m``, ``max_rise_m``, ``min_run_m``, ``continue_min_run_m``,
        ``continue_max_run_m``, ``continue_run_tolerance``, ``min_riser_points``,
        ``min_riser_width_m``, ``edge_margin_m``, ``edge_band_m``)
    """
    if config.max_steps_below_chain < 1 or not chain or ground_z < config.min_rise_m:
        return []
    tops = [link[1] for link in chain]
    rise = float(median(np.diff([ground_z] + tops)))
    if rise < config.min_rise_m:
        return []
    n = int(round(ground_z / rise))
    if not 1 <= n <= config.max_steps_below_chain or abs(ground_z - n * rise) > config.chain_tolerance_m:
        return []
    step_rise = ground_z / n
    if not config.min_rise_m <= step_rise <= config.max_rise_m:
        return []
    s0 = chain[0][4]
    runs = np.diff([link[4] for link in chain])
    run = float(median(runs)) if len(runs) else None
    front = _front(s0, ground_z, step_rise, ground_tread, planes, P, u, v, lateral, run, config)
    if front is None:
        return []
    run_below = s0 - front
    if not config.min_run_m <= run_below <= config.continue_max_run_m:
        return []
    links: list[Link] = []
    for k in range(1, n + 1):
        s_k = front - (n - k) * run_below
        links.append((None, k * step_rise, Plane(-u, s_k), ground_tread if k == n else None, s_k))
    return links


def _front(
    s0: float,
    ground_z: float,
    step_rise: float,
    ground_tread: Plane | None,
    planes: PlaneSet,
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    lateral: tuple[float, float],
    run: float | None,
    config: TerrainConfig,
) -> float | None:
    """Position along the stair axis of the riser just below the chain: the front edge of
    the plane it stands on, else a band of free samples a run before the chain's first at
    ``s0``; None if neither."""
    samples = planes.samples
    if ground_tread is not None:
        front = _tread_front(
            P, samples.normals, ground_tread, u, v, lateral[0], lateral[1], thr=config.edge_band_m
        )
        if front is not None:
            return front
    if run is None:
        lo, hi = s0 - config.continue_max_run_m, s0 - config.continue_min_run_m
    else:
        tol = config.continue_run_tolerance
        lo, hi = s0 - (1.0 + tol) * run, s0 - (1.0 - tol) * run
    s_all, v_all, z_all = P @ u, P @ v, P[:, 2]
    free, thr = free_samples(planes, s_all)
    heights = (ground_z - step_rise, ground_z)
    found = riser_band(free, s_all, v_all, z_all, thr, samples, (lo, hi), heights, step_rise, lateral, config)
    return None if found is None else found[1]


def samples_below_floor(planes: PlaneSet, model: StairModel, config: TerrainConfig) -> tuple[int, float]:
    """The samples of ``planes`` (their frame's floor at height 0) that lie under the
    floor, in front of ``model``'s first riser, across its extent (its polytope's): how
    many, and their median position along the stair axis (NaN where none). Under: more
    than ``edge_margin_m`` below the floor and less than the first rise and
    ``edge_margin_m`` below; in front: from ``merge_distance_m`` to ``continue_max_run_m``
    before the riser. A floor has nothing under it but the matcher's strays; a first
    tread taken for it has its riser there, a run in front of the chain."""
    if not model.steps or not model.polytope.vertices.size:
        return 0, float("nan")
    P = planes.samples.points.astype(np.float64)
    u, v, (v_lo, v_hi) = _axes_and_extent(model)
    first = model.steps[0]
    along = P @ u
    ahead = first.axis_position_m - along
    w, z = P @ v, P[:, 2]
    under = (z < -config.edge_margin_m) & (z > -first.rise_m - config.edge_margin_m)
    under &= (ahead > config.merge_distance_m) & (ahead < config.continue_max_run_m)
    under &= (w >= v_lo) & (w <= v_hi)
    count = int(np.count_nonzero(under))
    return count, float(median(along[under])) if count else float("nan")


def nosing_under_floor(model: StairModel, lines: ImageLines, config: TerrainConfig) -> bool:
    """Whether the image's segments show a nosing on the floor's height a run in front of
    ``model``'s first riser, across its extent (its polytope's):
    :func:`~.nosings.nosing_under_first`. A floor has no nosing on it; a first tread
    taken for it has its own, a run in front of the chain."""
    if not model.steps or not model.polytope.vertices.size:
        return False
    u, v, lateral = _axes_and_extent(model)
    return nosing_under_first(model.steps, u, v, lateral, lines, config)


def step_in_front(model: StairModel, lift: float, rise: float, position: float) -> StairModel:
    """``model`` in the frame whose origin is ``lift`` lower, with one more step in front:
    its riser at ``position`` along the stair axis, ``rise`` tall (inferred), its top the
    old ground, its tread from there to ``model``'s first riser. Every other height, tread
    plane and polytope vertex is ``lift`` higher; risers (vertical) stay where they were.

    For a staircase whose "floor" was its first tread, where the first riser's samples
    show under it a run in front of the chain (:func:`samples_below_floor`): the chain as
    it was, not built again in the lowered frame (which chains the planes at other
    heights)."""
    top = model.ground_z_m + lift
    up = np.array([0.0, 0.0, lift])
    u, v = stair_axes(model.yaw_rad)
    first = model.steps[0]
    steps = [
        dataclasses.replace(
            s, top_z_m=s.top_z_m + lift, tread=None if s.tread is None else s.tread.moved(np.eye(3), up)
        )
        for s in model.steps
    ]
    riser = Plane(-u, position)
    run = first.axis_position_m - position
    distance = riser_distance(riser, position, u)
    front = Step(rise, run, distance, None, top, position, riser, rise_inferred=True)
    vertices = model.polytope.vertices + up if model.polytope.vertices.size else np.empty((0, 3))
    across = vertices @ v if len(vertices) else np.array([-0.5, 0.5])
    lo, hi = float(across.min()), float(across.max())
    foot, head = np.array([0.0, 0.0, top - rise]), np.array([0.0, 0.0, top])
    corners = [
        position * u + lo * v + foot,
        position * u + hi * v + foot,
        position * u + hi * v + head,
        position * u + lo * v + head,
        first.axis_position_m * u + hi * v + head,
        first.axis_position_m * u + lo * v + head,
    ]
    k = len(vertices)
    faces = ((k, k + 1, k + 2, k + 3), (k + 3, k + 2, k + 4, k + 5), *model.polytope.faces)
    polytope = Polytope(np.vstack([vertices, np.array(corners)]), faces)
    return dataclasses.replace(model, steps=(front, *steps), ground_z_m=top - rise, polytope=polytope)


def _axes_and_extent(model: StairModel) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """``model``'s stair axis ``u``, lateral direction ``v`` and lateral extent along
    ``v`` (its polytope's, which must have vertices)."""
    u, v = stair_axes(model.yaw_rad)
    across = model.polytope.vertices @ v
    return u, v, (float(across.min()), float(across.max()))


def floor_to_view_bottom(planes: PlaneSet, config: TerrainConfig) -> bool:
    """Whether the floor's plane (the horizontal planes within ``tread_height_tolerance_m``
    of height 0) runs to the bottom of the view: it holds samples on the lowest grid row
    any sample has (within one grid step). Such a floor is the one under the cameras,
    nothing nearer in view; a first tread taken for the floor ends above its riser in
    the image, the riser's samples on the rows below it (on the realistic renders it ended
    two to forty grid rows above the bottom, where a real floor with the matcher's strays
    under it ran to the bottom)."""
    samples = planes.samples
    if not len(samples):
        return False
    above_bottom = samples.rows_above_bottom()  # 0: as low in the view as any sample reaches
    P = samples.points
    floor_above = [
        above_bottom[seg.indices]
        for seg in planes.segments
        if seg.kind == HORIZONTAL
        and len(seg.indices)
        and abs(float(median(P[seg.indices, 2]))) <= config.tread_height_tolerance_m
    ]
    if not floor_above:
        return False
    return int(min(a.min() for a in floor_above)) <= samples.stride_px
