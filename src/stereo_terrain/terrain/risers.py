"""Riser candidates and their edges: the vertical planes that can be risers, their bottom
and top edge heights and lateral extent, and a tread's front edge (where a riser too
poorly matched to be a plane stands)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._numeric import group_percentile, median, percentile  # NumPy's bits, a fraction of its time (issue 13)
from ..cloud import GridSample
from ..msac import Plane
from ..planes.orientation import PlaneSegment
from ._kernels import riser_edge_slices
from .model import TerrainConfig


@dataclass(frozen=True)
class _Riser:
    plane: Plane
    idx: np.ndarray
    s: float
    z_lo: float
    z_hi: float
    v_lo: float
    v_hi: float
    touches_border: bool
    foot_hidden: bool = False  # its inliers reach the image's last rows: its foot is out of view
    in_wall: bool = False  # the part of a taller plane in line with a wall (_riser_beside_wall)


def face_riser(
    P: np.ndarray,
    along: np.ndarray,
    across: np.ndarray,
    plane: Plane,
    a: float,
    z_lo: float,
    z_hi: float,
    lateral: tuple[float, float],
    merge_distance_m: float,
) -> _Riser:
    """A riser that formed no plane of its own, placed at ``a`` along the stair axis
    (``plane``), from ``z_lo`` to ``z_hi`` and across ``lateral``: its inliers are the
    samples ``P`` on its face (``along``, ``across``: their positions along the axis and
    across it), within ``merge_distance_m`` of it (few or none on a painted riser)."""
    on_face = (np.abs(along - a) < merge_distance_m) & (across > lateral[0]) & (across < lateral[1])
    on_face &= (P[:, 2] > z_lo) & (P[:, 2] < z_hi)
    return _Riser(plane, np.flatnonzero(on_face), a, z_lo, z_hi, lateral[0], lateral[1], False)


def _riser_edges(
    P: np.ndarray, plane: Plane, v: np.ndarray, v_lo: float, v_hi: float, *, thr: float, seed_z: float
) -> tuple[float, float] | None:
    """Bottom and top edge heights of a riser from every sample on its plane (None when no
    sample is on it).

    Inliers alone stop short of the edges (normals there mix two faces); any sample within
    ``thr`` of the plane and inside its lateral extent is on the riser or on the surface
    meeting it at the edge, whose height is the edge's. Two things on the same plane are
    not the riser and must not stretch it:

    * stray matches far above or below it (a textureless sky, a wall's far end): only the
      samples connected in height to the riser's own (``seed_z``, its inliers' median; no
      gap over :data:`_EDGE_GAP_M`) count;
    * a newel post, a baluster or a door frame standing on the riser's line: the edges come
      from :data:`_EDGE_BINS` lateral slices of the riser (a high percentile of the slices'
      top edges, a low one of their bottoms), so that something narrow standing on the
      riser, in one or two slices, does not raise its top.
    """
    near = plane.residuals(P) < thr
    lat = P[near] @ v
    # The rest (extent, sort, connected heights, slices) in one compiled pass (issue 13).
    kept, lows, highs, lo_all, hi_all = riser_edge_slices(
        P[near, 2], lat, float(v_lo), float(v_hi), float(seed_z), _EDGE_GAP_M, _EDGE_BINS
    )
    if kept == 0:
        return None
    if len(lows) == 0:
        return float(lo_all), float(hi_all)
    # The top: a high percentile (a slice at the riser's ends may see less of it, two
    # slices of eight may hold a post). The bottom: the lowest slices (nothing stands
    # below a riser on its plane, while something in front, a box, may hide the bottom of
    # a wall behind it in the middle slices and make it look like a riser on the box).
    return float(percentile(lows, _EDGE_BOTTOM_QUANTILE)), float(percentile(highs, _EDGE_QUANTILE))


def edge_bias(links: list[tuple[_Riser | None, float]], cam_z: float, config: TerrainConfig) -> float:
    """How far the top edges found by :func:`_riser_edges` lie below the true ones, from a
    chain of steps ``links`` whose tops are their risers' top edges: ``(riser candidate,
    top height)`` per step, nearest first.

    The edges come from the samples nearest them, and near an edge a sample's box mixes
    the two faces and its normal leaves the riser's plane: the top edge is found low and
    the bottom edge high, each by about the same amount (2-3 cm on the realistic profile,
    nearly nothing on faces the matcher reads well; docs/benchmarks.md, "Tenth session").
    Where the next riser's foot is seen (the step's top below the cameras, the foot not
    cut by the image), a step's top and that foot should meet: half the median gap
    between them is the bias, clipped to ``[0, max_edge_bias_m]``; 0 where no pair shows
    it.
    """
    gaps = [
        nxt.z_lo - top
        for (_, top), (nxt, _) in zip(links, links[1:], strict=False)
        if nxt is not None and not nxt.foot_hidden and top < cam_z - config.edge_margin_m
    ]
    if not gaps or config.max_edge_bias_m <= 0:
        return 0.0
    return min(max(0.5 * float(median(np.asarray(gaps))), 0.0), config.max_edge_bias_m)


#: Lateral slices of a riser over which its edge heights are taken, and the percentiles
#: of the slices' top and bottom edges that are the riser's.
_EDGE_BINS = 8
_EDGE_QUANTILE = 70.0
_EDGE_BOTTOM_QUANTILE = 10.0


#: Largest gap in height between the samples of one riser face (the spacing of grid
#: samples on a riser 3 m away is about 3 cm).
_EDGE_GAP_M = 0.05


def _tread_front(
    P: np.ndarray,
    normals: np.ndarray,
    plane: Plane,
    u: np.ndarray,
    v: np.ndarray,
    v_lo: float,
    v_hi: float,
    *,
    thr: float,
) -> float | None:
    """Position along the stair axis of a tread's front edge (its nosing), from every sample
    on its plane inside the stair's lateral extent, except those on the staircase's side
    faces (normals along the lateral axis); None if too few."""
    near = (plane.residuals(P) < thr) & (np.abs(normals @ v) < 0.7)
    q = P[near]
    lat = q @ v
    s = (q @ u)[(lat > v_lo) & (lat < v_hi)]
    if len(s) < 10:
        return None
    return float(percentile(s, 2))


def riser_distance(riser: Plane, s_pos: float, u: np.ndarray) -> float:
    """A step's distance: where the frame's x axis (y = 0) meets its riser plane, or, for
    a riser nearly parallel to that axis, its position ``s_pos`` along the stair axis ``u``
    carried onto it."""
    n = riser.normal
    return float(-riser.offset / n[0] if abs(n[0]) > 0.2 else s_pos / max(abs(u[0]), 1e-6))


def _axis_from_normal(n: np.ndarray) -> np.ndarray:
    """Stair axis (horizontal unit vector pointing up the stairs) from a riser normal."""
    a = -np.array([n[0], n[1], 0.0])
    return a / max(np.linalg.norm(a), 1e-12)


#: A riser's points may not reach more than ``edge_margin_m`` below the level it stands on:
#: this low percentile of their heights (robust to a few stray points) is the test.
_LOW_INLIER_PCT = 5.0

#: A plane with this share (``_LOW_INLIER_PCT``) of its inliers in the grid's rows 0 to
#: this goes on above the image: its top edge is not seen (issue 11). Row 0's boxes reach
#: past the image and never hold samples, so these are the first two rows with samples.
#: Rows count from the view's top edge in each column (``GridSample.grid_rows_below_top``:
#: under ``rectify_fov="keep"`` the rows above the raw view have no source pixels).
_TOP_CUT_ROWS = 2


#: Lateral slices in which a plane too tall for a riser is looked at for a riser part.
_WALL_SLICE_M = 0.1
#: The narrowest riser part taken from such a plane: a staircase's opening in a wall
#: (building stairs are 0.6 m wide or more; a chair's or a shelf's low front beside its
#: tall parts is narrower).
_MIN_OPENING_M = 0.5


def _slice_spans(z: np.ndarray, which: np.ndarray, n_slices: int) -> np.ndarray:
    """Per slice (``which``: each sample's, ``0 .. n_slices - 1``), the 98th minus the 2nd
    percentile of the heights ``z`` (float64) of its samples; NaN where it has fewer than
    three: ``percentile(z[which == k], [2, 98])`` slice by slice, in one sort for all of
    them (a wide wall has 20-30 slices; issue 13)."""
    low, high = group_percentile(z, which, n_slices, [2.0, 98.0], min_count=3)
    return high - low


def _riser_beside_wall(
    P: np.ndarray, plane: Plane, v: np.ndarray, config: TerrainConfig
) -> tuple[float, float, np.ndarray] | None:
    """The lateral extent ``(v_lo, v_hi)`` of the riser in a vertical plane too tall for
    one, and the indices into ``P`` of the samples on the plane inside it, where the plane
    is a riser beside a wall in line with it (None where it is not).

    Stairs set in an opening of a wall whose face is flush with the first riser put the
    riser and the wall on one plane: the plane stage finds one plane, as tall as the wall.
    (:func:`_riser_candidates` keeps such a part only where it stands on the floor.)
    Across the plane (``v``, slices of :data:`_WALL_SLICE_M`), the samples within
    ``edge_band_m`` of it then stand from the floor up to a step's height in the opening
    and far higher beside it. The riser is the widest run of consecutive slices (one
    empty slice may interrupt it) whose samples span ``min_rise_m`` to ``max_rise_m`` (+
    ``edge_margin_m``), at least :data:`_MIN_OPENING_M` wide, with a slice taller than
    that next to it: a face with nothing taller beside it is not split.
    """
    near = np.flatnonzero(plane.residuals(P) < config.edge_band_m)
    q = P[near]
    lat = q @ v
    # Over every sample on the plane, not only its inliers' extent: the riser's own
    # samples, whose normals the edges and the noise tilted, may lie outside it.
    z = q[:, 2]
    if len(lat) < 3:
        return None
    v_lo, v_hi = float(lat.min()), float(lat.max()) + 1e-9
    n_slices = int(math.ceil((v_hi - v_lo) / _WALL_SLICE_M))
    if n_slices < 2:
        return None
    which = np.minimum(((lat - v_lo) / _WALL_SLICE_M).astype(np.int64), n_slices - 1)
    tallest = config.max_rise_m + config.edge_margin_m
    kind = np.zeros(n_slices, np.int8)  # 0 empty, 1 riser-like, 2 taller, 3 lower
    span = _slice_spans(z, which, n_slices)  # NaN where a slice has fewer than 3 samples
    seen = np.isfinite(span)
    kind[seen] = np.where(span[seen] > tallest, 2, np.where(span[seen] >= config.min_rise_m, 1, 3))
    best: tuple[int, int] | None = None
    k = 0
    while k < n_slices:
        if kind[k] != 1:
            k += 1
            continue
        end = k
        while end + 1 < n_slices and (
            kind[end + 1] == 1 or (kind[end + 1] == 0 and end + 2 < n_slices and kind[end + 2] == 1)
        ):
            end += 1
        beside = (k > 0 and kind[k - 1] == 2) or (end + 1 < n_slices and kind[end + 1] == 2)
        if beside and (best is None or end - k > best[1] - best[0]):
            best = (k, end)
        k = end + 1
    if best is None:
        return None
    # The part's extent from its samples above the floor (the slices' bounds would add up
    # to a slice at each end).
    in_run = (which >= best[0]) & (which <= best[1])
    raised = in_run & (z > float(percentile(z[in_run], 2)) + config.min_rise_m / 2)
    if raised.sum() < 3:
        return None
    a, b = percentile(lat[raised], [2, 98])
    if b - a < max(config.min_riser_width_m, _MIN_OPENING_M):
        return None
    return float(a), float(b), near[(lat > a) & (lat < b)]


#: The middle of a face :func:`face_sight` looks at: this share of its width and height is
#: left out at each edge (a face's outline mixes in what lies beyond its edges).
_SIGHT_MARGIN = 0.15

#: A sample lies beyond a face when it is this many times as far from the camera as the
#: face, along its ray; in front of it when the face is this many times as far as it.
_BEYOND_RATIO = 1.25

#: Fewest samples whose rays cross a face's middle for :func:`face_sight` to judge it.
_MIN_SIGHT = 20


@dataclass(frozen=True)
class FaceSight:
    """What the cameras see through the middle of a vertical face (:func:`face_sight`).

    Attributes
    ----------
    beyond : float
        Of the samples whose rays cross it, those not well in front of it: the share lying
        :data:`_BEYOND_RATIO` times as far as the face or farther (0 for a solid face, most
        of them for a railing).
    hidden : float
        Of all the samples whose rays cross it: the share standing well in front of it (the
        face as far as them times :data:`_BEYOND_RATIO` or more) on no plane (``planar``):
        scattered things. A railing's rail and balusters, a wall or a box front that the
        plane stage found hide a face too, but are accounted for: they are planes of
        their own.
    """

    beyond: float
    hidden: float


def face_sight(
    P: np.ndarray,
    cam: np.ndarray,
    plane: Plane,
    v: np.ndarray,
    lateral: tuple[float, float],
    z_range: tuple[float, float],
    planar: np.ndarray | None = None,
) -> FaceSight:
    """What the samples ``P`` whose rays from ``cam`` cross the middle of a vertical face (on
    ``plane``, across ``lateral`` along ``v`` and over ``z_range``; the outer
    :data:`_SIGHT_MARGIN` left out) say of it: see :class:`FaceSight`. ``planar`` (bool per
    sample, None: none) marks the samples on a plane the plane stage found. Both shares
    are 0 where fewer than :data:`_MIN_SIGHT` samples count toward them."""
    n = np.asarray(plane.normal, dtype=np.float64)
    d = np.asarray(P, dtype=np.float64) - cam
    along = d @ n
    crossing = abs(along) > 1e-9
    # Where each ray meets the plane, as a fraction of the way to its sample.
    t = np.full(len(d), np.inf)
    t[crossing] = -(float(cam @ n) + plane.offset) / along[crossing]
    hit = np.flatnonzero(np.isfinite(t) & (t > 0))
    X = cam + t[hit, None] * d[hit]
    lat, z = X @ v, X[:, 2]
    (l0, l1), (z0, z1) = lateral, z_range
    ml, mz = _SIGHT_MARGIN * (l1 - l0), _SIGHT_MARGIN * (z1 - z0)
    inside = hit[(lat > l0 + ml) & (lat < l1 - ml) & (z > z0 + mz) & (z < z1 - mz)]
    t_all = t[inside]
    in_front = t_all >= _BEYOND_RATIO
    scattered = in_front if planar is None else in_front & ~np.asarray(planar)[inside]
    # (What stands well in front of the face hides it, and says nothing of what it is: a
    # railing before a riser.)
    t_in = t_all[~in_front]
    return FaceSight(_share(t_in <= 1.0 / _BEYOND_RATIO), _share(scattered))


def _share(which: np.ndarray) -> float:
    """The share of ``which`` (bool) that is True; 0 under :data:`_MIN_SIGHT` entries."""
    return float(np.count_nonzero(which)) / len(which) if len(which) >= _MIN_SIGHT else 0.0


def _riser_candidates(
    samples: GridSample,
    P: np.ndarray,
    cam: np.ndarray,
    verticals: list[PlaneSegment],
    config: TerrainConfig,
    floor_z: float | None = None,
) -> list[_Riser]:
    """The vertical planes that can be risers (the first part of :func:`~.assemble._assemble`).
    ``floor_z``: the floor's height where the frame has one (a riser in line with a wall
    must stand on it, :func:`_riser_beside_wall`), else None."""
    # Candidate risers: short vertical planes facing the camera.
    col_lo, col_hi = samples.cols.min(), samples.cols.max()
    border = 2 * samples.stride_px
    grid_row = samples.grid_rows_below_top()  # from the view's top edge in each column
    above_bottom = samples.rows_above_bottom()  # 0: as low in the view as any sample reaches
    cos_face = math.cos(math.radians(config.max_facing_angle_deg))
    planar = np.zeros(len(P), dtype=bool)  # the samples on a vertical plane (face_sight)
    for seg in verticals:
        planar[seg.indices] = True
    cands: list[_Riser] = []
    for seg in verticals:
        if seg.count < config.min_riser_points:
            continue
        pts = P[seg.indices]
        n = seg.plane.normal
        to_cam = cam - median(pts, axis=0)
        to_cam[2] = 0.0
        if n @ to_cam < cos_face * np.linalg.norm(to_cam):
            continue
        u = _axis_from_normal(n)
        v = np.array([-u[1], u[0], 0.0])
        lat = pts @ v
        v_lo, v_hi = percentile(lat, [2, 98])
        if v_hi - v_lo < config.min_riser_width_m:
            continue
        edges = _riser_edges(
            P, seg.plane, v, v_lo, v_hi, thr=config.edge_band_m, seed_z=float(median(pts[:, 2]))
        )
        if edges is None:
            continue
        z_lo, z_hi = edges
        idx = seg.indices
        in_wall = False
        if z_hi - z_lo > config.max_rise_m + config.edge_margin_m:
            # Too tall for a riser, unless it is a riser in line with a wall beside it
            # (stairs in an opening of a wall flush with their first riser).
            part = _riser_beside_wall(P, seg.plane, v, config)
            if part is None:
                continue
            # The riser's samples: on the plane in the opening, between its edges (few of
            # them are the plane's inliers: their normals are what kept them out).
            v_lo, v_hi, in_part = part
            if len(in_part) < config.min_riser_points:
                continue
            edges = _riser_edges(
                P, seg.plane, v, v_lo, v_hi, thr=config.edge_band_m, seed_z=float(median(P[in_part, 2]))
            )
            if edges is None:
                continue
            z_lo, z_hi = edges
            idx = in_part[(P[in_part, 2] >= z_lo) & (P[in_part, 2] <= z_hi)]
            if len(idx) < config.min_riser_points:
                continue
            pts = P[idx]
            in_wall = True
            if z_hi - z_lo > config.max_rise_m + config.edge_margin_m:
                continue
            if floor_z is None or abs(z_lo - floor_z) > config.chain_tolerance_m:
                # The first riser only: a far wall's band cut by the depth range, standing
                # on a landing, is no riser.
                continue
        if z_hi - z_lo < config.min_rise_m / 2:
            continue
        sight = face_sight(P, cam, seg.plane, v, (float(v_lo), float(v_hi)), (z_lo, z_hi), planar)
        if sight.beyond > config.max_riser_see_through:
            continue  # a railing or clutter: the scene behind shows through it
        if sight.hidden > config.max_riser_hidden:
            continue  # a plane through scattered things, most of them nearer than it
        if float(percentile(grid_row[idx], _LOW_INLIER_PCT)) <= _TOP_CUT_ROWS:
            # The face goes on above the image (a wall, a cupboard's front): the height
            # seen is the image's, not a riser's, and no tread above it can be seen.
            continue
        cols = samples.cols[idx]
        touches = bool(cols.min() <= col_lo + border or cols.max() >= col_hi - border)
        foot_hidden = bool(above_bottom[idx].min() <= border)
        cands.append(
            _Riser(
                seg.plane,
                idx,
                float(median(pts @ u)),
                z_lo,
                z_hi,
                float(v_lo),
                float(v_hi),
                touches,
                foot_hidden,
                in_wall,
            )
        )
    return cands
