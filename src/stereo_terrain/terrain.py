"""Stage 5: a polytope (stairs, box, or nothing) from unordered planes (paper section 3.3).

Input is a :class:`PlaneSet` in a gravity-aligned frame (``yaw``: z up). The vertical
planes that can be risers (short, facing the robot, all facing the same way) are ordered
by their position along the stair axis; between each consecutive pair the *active*
horizontal plane is the one with most inliers in between; neighbouring planes are
intersected to get the edges and vertices of every step.

Step height comes from the tread plane when it is visible; treads above the cameras are
not, and then the height comes from the riser's top edge.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ._numeric import median, percentile  # NumPy's bits, a fraction of its time (issue 13)
from ._terrain_kernels import riser_edge_slices
from .checks import check_fields, check_min
from .errors import ConfigError
from .msac import Plane
from .planes.orientation import HORIZONTAL, VERTICAL, PlaneSet

STAIRS, BOX, NONE = "stairs", "box", "none"


@dataclass(frozen=True)
class TerrainConfig:
    """What counts as a step.

    Attributes
    ----------
    min_rise_m, max_rise_m : float
        A riser shorter than ``min_rise_m`` is noise; a vertical plane taller than
        ``max_rise_m`` (plus ``edge_margin_m``) is a wall, not a step. The ground must be
        ``min_rise_m`` or more below the cameras (a surface above them is seen from below);
        a camera less than that above the frame's origin means a frame without a floor
        (no rig, none found). A riser in front of the stairs whose top is the lowest plane
        stands on a floor that formed no plane when its bottom edge is this much lower and
        its own samples span this much (issue 11).
    max_obstacle_rise_m : float
        Safety net. When no obstacle is found with ``max_rise_m``, the vertical planes up
        to this height are tried again, so that a step too high to climb (above the
        swing's reach, ``SwingConfig.max_height_m``) is reported, and planned as not
        traversable, instead of being taken for a wall and ignored. Only then: raising
        ``max_rise_m`` itself would merge two noisy risers into one tall step more often.
    min_riser_width_m : float
    min_riser_points : int
        Grid samples a riser needs.
    merge_distance_m : float
        Risers closer than this along the stair axis are one.
    max_facing_angle_deg : float
        A riser must face the robot: its normal within this of the direction to the camera.
    axis_spread_deg : float
        Risers of one staircase face the same way within this angle (every pair of them).
    tread_height_tolerance_m : float
        A horizontal plane is the tread above a riser if its height is within this of the
        riser's top edge.
    min_tread_points : int
        Samples of a horizontal plane a tread needs (between its riser and the next); as
        many samples of the ground seen in front of a riser make it the floor, not a
        tread on it (issue 11).
    edge_band_m : float
        Samples this close to a riser plane count when finding its top and bottom edges.
    chain_tolerance_m : float
        A riser's bottom edge must be within this of the level the step before it ended
        (unless that level is above the cameras and the edge is hidden).
    disparity_sigma_px : float
        1-sigma of one pixel's disparity (matching noise, independent from pixel to pixel
        beyond ``matching_window_px``), for the step sigmas (:func:`estimate_step_sigmas`).
        Measured on the rendered approaches (``benchmarks/bench_tracking.py --noise``): the
        robust spread of plane inliers' disparities about their plane, median 0.14 px
        (p90 0.24 px) over 10 approaches, 320x240 and 640x480.
    disparity_bias_px : float
        1-sigma of the disparity error shared by all pixels of one face (sub-pixel bias,
        fill, smoothing), which averaging over the face does not reduce; measured the same
        way from the first riser's position error of single frames: 0.13 px rms.
    matching_window_px : float
        Pixels closer than this share their matching errors (the SGBM block and its
        smoothing): a plane's ``n`` samples count as ``n (stride / window)**2`` when the
        grid stride is smaller.
    edge_sigma_cells : float
        1-sigma of an edge found from the samples (a riser's top edge, a tread's front
        edge, a riser's lateral ends) in grid cells: the samples are a grid of
        ``stride_px`` pixels, so an edge is known to about a cell.
    width_loss_cells : float
        A riser's inliers stop up to this many grid cells short of each lateral end (local
        normals there mix the riser with the side faces and the wall; the orientation
        method's ``sample_radius_cells``), so its width is short by up to twice that: part
        of ``width_sigma_m``.
    face_bias_correlation : float
        Correlation of the shared disparity error of neighbouring faces (a tread and the
        surface below it), in [0, 1]: most of it moves both alike and cancels in a rise.
        Measured on the rendered approaches: single-frame rise errors are about 0.3 of
        what independent biases would give, i.e. a correlation near 0.9.
    """

    min_rise_m: float = 0.04
    max_rise_m: float = 0.30
    max_obstacle_rise_m: float = 0.50
    edge_margin_m: float = 0.06
    min_riser_width_m: float = 0.15
    min_riser_points: int = 25
    merge_distance_m: float = 0.06
    max_facing_angle_deg: float = 70.0
    axis_spread_deg: float = 20.0
    tread_height_tolerance_m: float = 0.06
    edge_band_m: float = 0.02
    chain_tolerance_m: float = 0.08
    min_tread_points: int = 15
    disparity_sigma_px: float = 0.14
    disparity_bias_px: float = 0.13
    matching_window_px: float = 5.0
    edge_sigma_cells: float = 0.7
    face_bias_correlation: float = 0.9
    width_loss_cells: float = 5.0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "min_riser_points", "min_tread_points")
        check_min(self, 0, "disparity_sigma_px", "disparity_bias_px", "edge_sigma_cells", "width_loss_cells")
        if not 0 <= self.face_bias_correlation <= 1:
            raise ConfigError(
                f"TerrainConfig.face_bias_correlation must be in [0, 1], got {self.face_bias_correlation}"
            )
        if not self.matching_window_px > 0:
            raise ConfigError(f"TerrainConfig.matching_window_px must be > 0, got {self.matching_window_px}")
        check_min(
            self,
            0,
            "edge_margin_m",
            "min_riser_width_m",
            "merge_distance_m",
            "tread_height_tolerance_m",
            "edge_band_m",
            "chain_tolerance_m",
        )
        for name in ("max_facing_angle_deg", "axis_spread_deg"):
            if not 0 < getattr(self, name) <= 90:
                raise ConfigError(f"TerrainConfig.{name} must be in (0, 90] deg, got {getattr(self, name)}")
        if not 0 < self.min_rise_m < self.max_rise_m <= self.max_obstacle_rise_m:
            raise ConfigError(
                "need 0 < min_rise_m < max_rise_m <= max_obstacle_rise_m, got "
                f"{self.min_rise_m}, {self.max_rise_m}, {self.max_obstacle_rise_m}"
            )


@dataclass(frozen=True)
class Step:
    """One step of a staircase (or the box) in the gravity-aligned frame.

    Attributes
    ----------
    rise_m : float
        Height of this tread above the surface before it.
    run_m : float or None
        Tread depth along the stair axis; None when not seen whole.
    distance_m : float
        Where the frame's x axis (y = 0) meets the riser plane.
    width_m : float or None
        Lateral extent of the riser; None when it leaves the image.
    top_z_m : float
        Height of the tread above the frame origin.
    axis_position_m : float
        Riser position along the stair axis.
    riser : Plane
    tread : Plane or None
        None when the tread was not seen (height from the riser's top edge).
    rise_inferred : bool
        True for a first step whose foot is out of view (stairs filling the image, no floor
        in front): its rise is the median of the other steps' rises.
    rise_sigma_m, run_sigma_m, distance_sigma_m, width_sigma_m : float or None
        1-sigma of ``rise_m``, ``run_m``, ``distance_m`` and ``width_m`` (issue 14,
        :func:`estimate_step_sigmas`); NaN until estimated, None where the value is None.
    """

    rise_m: float
    run_m: float | None
    distance_m: float
    width_m: float | None
    top_z_m: float
    axis_position_m: float
    riser: Plane = field(repr=False)
    tread: Plane | None = field(repr=False, default=None)
    rise_inferred: bool = False
    rise_sigma_m: float = math.nan
    run_sigma_m: float | None = math.nan
    distance_sigma_m: float = math.nan
    width_sigma_m: float | None = math.nan


@dataclass(frozen=True)
class Polytope:
    """Vertices and quadrilateral faces (riser, then tread, per step)."""

    vertices: np.ndarray = field(repr=False)  # (V, 3) float64, metres
    faces: tuple[tuple[int, int, int, int], ...] = ()


@dataclass(frozen=True)
class StairModel:
    """What the terrain stage found.

    Attributes
    ----------
    obstacle : str
        ``stairs``, ``box`` or ``none``.
    steps : tuple of Step, nearest first
    yaw_rad : float
        Stair axis w.r.t. the frame's x axis.
    ground_z_m : float
    polytope : Polytope
    frame : str
    note : str
        Why the result is what it is (e.g. why nothing was found).
    yaw_sigma_rad : float
        1-sigma of ``yaw_rad`` (issue 14); NaN until estimated.
    """

    obstacle: str
    steps: tuple[Step, ...]
    yaw_rad: float
    ground_z_m: float
    polytope: Polytope
    frame: str
    note: str = ""
    yaw_sigma_rad: float = math.nan


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


#: Lateral slices of a riser over which its edge heights are taken, and the percentiles
#: of the slices' top and bottom edges that are the riser's.
_EDGE_BINS = 8
_EDGE_QUANTILE = 70.0
_EDGE_BOTTOM_QUANTILE = 10.0


#: A merged riser whose refit normal has a larger vertical component (sin of ~6 deg, the
#: orientation method's tolerance) was two different faces.
_MAX_MERGED_RISER_TILT = 0.1

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


def _axis_from_normal(n: np.ndarray) -> np.ndarray:
    """Stair axis (horizontal unit vector pointing up the stairs) from a riser normal."""
    a = -np.array([n[0], n[1], 0.0])
    return a / max(np.linalg.norm(a), 1e-12)


def _no_obstacle(planes: PlaneSet, note: str, ground_z: float = 0.0) -> StairModel:
    return StairModel(NONE, (), 0.0, ground_z, Polytope(np.zeros((0, 3))), planes.frame, note)


#: A riser's points may not reach more than ``edge_margin_m`` below the level it stands on:
#: this low percentile of their heights (robust to a few stray points) is the test.
_LOW_INLIER_PCT = 5.0

#: A plane with this share (``_LOW_INLIER_PCT``) of its inliers in the image's first grid
#: rows goes on above the image: its top edge is not seen (issue 11).
_TOP_CUT_ROWS = 2


def build_terrain(
    planes: PlaneSet, config: TerrainConfig | None = None, *, floor_known: bool | None = None
) -> StairModel:
    """Assemble a staircase, a box, or nothing from unordered planes.

    Parameters
    ----------
    planes : PlaneSet
        In a gravity-aligned frame with ``planes.up == +z``.
    config : TerrainConfig
    floor_known : bool, optional
        Whether the frame's origin is on the floor (a rig, or a floor plane found below
        the cameras). Where it is not and every horizontal plane is above the cameras,
        there is no ground to measure a first rise from and nothing is reported. None:
        taken as unknown when the cameras are less than ``min_rise_m`` above the origin
        (the origin left at the cameras).

    Returns
    -------
    StairModel; ``obstacle == "none"`` (with a note) is a normal result.
    """
    config = config or TerrainConfig()
    if not np.allclose(planes.up, [0.0, 0.0, 1.0], atol=1e-6):
        raise ConfigError("build_terrain needs planes in a gravity-aligned frame (up = +z)")
    if floor_known is None:
        floor_known = bool(planes.camera_position[2] >= config.min_rise_m)
    model = _assemble(planes, config, floor_known=floor_known)
    if model.obstacle != NONE or config.max_obstacle_rise_m <= config.max_rise_m:
        return model
    # Safety net: is there a step too tall for a stair, that the robot cannot climb?
    # (A first riser inferred from a tread alone is not enough for a step too tall to be a
    # stair: that is a table top.)
    tall = _assemble(
        planes,
        dataclasses.replace(config, max_rise_m=config.max_obstacle_rise_m),
        tread_first=False,
        floor_known=floor_known,
    )
    if tall.obstacle == NONE or max(s.rise_m for s in tall.steps) <= config.max_rise_m:
        return model
    if any(s.rise_m > config.max_rise_m and s.tread is None for s in tall.steps):
        # A vertical face taller than a stair rise whose top is not seen is a wall or a
        # piece of furniture's front as much as a step: the net needs the top.
        return model
    note = f"a step taller than a stair rise ({config.max_rise_m:.2f} m): {tall.note}"
    return dataclasses.replace(tall, note=note)


def _assemble(
    planes: PlaneSet, config: TerrainConfig, *, tread_first: bool = True, floor_known: bool = True
) -> StairModel:
    """:func:`build_terrain` for one set of limits (``tread_first``: see :func:`_assemble_along`)."""
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

    # Candidate risers: short vertical planes facing the camera.
    col_lo, col_hi = samples.cols.min(), samples.cols.max()
    row_hi = samples.rows.max()
    border = 2 * samples.stride_px
    grid_row = samples.grid_index // samples.grid_shape[1]
    cos_face = math.cos(math.radians(config.max_facing_angle_deg))
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
        if z_hi - z_lo > config.max_rise_m + config.edge_margin_m or z_hi - z_lo < config.min_rise_m / 2:
            continue
        if float(percentile(grid_row[seg.indices], _LOW_INLIER_PCT)) <= _TOP_CUT_ROWS:
            # The face goes on above the image (a wall, a cupboard's front): the height
            # seen is the image's, not a riser's, and no tread above it can be seen.
            continue
        cols = samples.cols[seg.indices]
        touches = bool(cols.min() <= col_lo + border or cols.max() >= col_hi - border)
        foot_hidden = bool(samples.rows[seg.indices].max() >= row_hi - border)
        cands.append(
            _Riser(
                seg.plane,
                seg.indices,
                float(median(pts @ u)),
                z_lo,
                z_hi,
                float(v_lo),
                float(v_hi),
                touches,
                foot_hidden,
            )
        )
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
        model = _assemble_along(
            planes, config, family, yaw, horizontals, h_z, tread_first=tread_first, floor_known=floor_known
        )
        if best is None or len(model.steps) > len(best.steps):
            best = model
    assert best is not None
    return best


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
) -> StairModel:
    """The staircase (or box, or nothing) whose risers are ``family`` along the stair axis
    at ``yaw`` (the rest of :func:`_assemble`). ``tread_first``: the first step may stand at
    a tread's front edge when its riser is no plane and a riser plane chains behind it.
    ``floor_known``: as in :func:`build_terrain`."""
    samples = planes.samples
    P = samples.points.astype(np.float64)
    cam = planes.camera_position
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
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
    def chain_from(virtual_first: bool) -> list[tuple[_Riser | None, float, Plane, Plane | None, float]]:
        chain: list[tuple[_Riser | None, float, Plane, Plane | None, float]] = []
        level, last_s = ground_z, -np.inf
        for s_pos, top, cand, riser_plane, tread_plane in cands_all:
            if top < level + config.min_rise_m or top - level > config.max_rise_m + config.edge_margin_m:
                continue
            if s_pos < last_s + config.merge_distance_m:
                continue
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

    # Stairs filling the view: the first riser's foot (and the floor before it) is below
    # the image, so the first tread was taken for the ground. A riser in front of the
    # chain, cut by the image's bottom edge, whose top is that "ground", is the first step;
    # its rise is not seen and is taken as the median of the others (a staircase's rises
    # are equal), and said so.
    inferred_first = False
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
            and not _ground_before(s_h, v_h, h_z, horizontals, ground_z, r, config)
        ]
        if cut_off:
            r0 = max(cut_off, key=lambda r: r.s)  # the one just before the chain
            ground_tread = _tread_between(horizontals, h_z, s_h, ground_z, r0.s, first_s)
            chain.insert(0, (r0, ground_z, r0.plane, ground_tread, r0.s))
            if r0.foot_hidden:
                inferred_first = True
            else:
                ground_z = r0.z_lo
    rises_seen = [chain[i][1] - chain[i - 1][1] for i in range(1, len(chain))]
    if inferred_first:
        ground_z = ground_z - float(median(rises_seen)) if rises_seen else ground_z - config.min_rise_m

    steps: list[Step] = []
    prev_top = ground_z
    for i, (cand, top, riser_plane, tread_plane, s_pos) in enumerate(chain):
        rise = top - prev_top
        run = chain[i + 1][4] - s_pos if i + 1 < len(chain) else None
        n = riser_plane.normal
        distance = -riser_plane.offset / n[0] if abs(n[0]) > 0.2 else s_pos / max(abs(u[0]), 1e-6)
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
                rise_inferred=inferred_first and i == 0,
            )
        )
        prev_top = top
    ordered = [c[0] for c in chain if c[0] is not None]

    if not steps:
        return _no_obstacle(planes, "risers found but no step rises above the ground", ground_z)
    h_info = list(zip(horizontals, h_z, s_h, v_h, strict=True))

    obstacle = STAIRS
    note = f"{len(steps)} step(s) from {len(ordered)} riser plane(s)"
    if inferred_first:
        note += "; the first riser's foot is out of view: its rise is the median of the others"
    if len(steps) == 1:
        obstacle, note, steps = _classify_single_step(steps[0], h_info, ground_z, config, note)
    poly = _polytope(steps, ordered, u, v, ground_z)
    return StairModel(obstacle, tuple(steps), yaw, ground_z, poly, planes.frame, note)


def _stands_below(P: np.ndarray, r: _Riser, ground_z: float, config: TerrainConfig) -> bool:
    """Whether riser ``r`` (its foot in view) stands a step below ``ground_z``: its bottom
    edge is ``min_rise_m`` or more below it and its own points (not only its edge band,
    which takes in the surface at its foot) span ``min_rise_m`` of height."""
    z = P[r.idx, 2]
    lo, hi = percentile(z, [_LOW_INLIER_PCT, 100.0 - _LOW_INLIER_PCT])
    return r.z_lo < ground_z - config.min_rise_m and float(hi - lo) >= config.min_rise_m


def _ground_before(s_h, v_h, h_z, horizontals, ground_z: float, r: _Riser, config: TerrainConfig) -> bool:
    """Whether the surface at ``ground_z`` is seen in front of riser ``r`` (before it along
    the stair axis, within its lateral extent): then it is the floor the riser stands on or
    beside, not a tread on top of it (issue 11)."""
    count = 0
    for hz, sh, vh in zip(h_z, s_h, v_h, strict=True):
        if abs(hz - ground_z) <= config.tread_height_tolerance_m / 2:
            count += int(np.sum((sh < r.s - config.merge_distance_m) & (vh > r.v_lo) & (vh < r.v_hi)))
    return count >= config.min_tread_points


def _tread_between(horizontals, h_z, s_h, z: float, s_lo: float, s_hi: float) -> Plane | None:
    """The horizontal plane at height ``z`` with most inliers between ``s_lo`` and ``s_hi``
    along the stair axis, or None."""
    best, best_count = None, 0
    for h, hz, sh in zip(horizontals, h_z, s_h, strict=True):
        count = int(np.sum((sh > s_lo) & (sh < s_hi)))
        if abs(hz - z) < 1e-9 and count > best_count:
            best, best_count = h.plane, count
    return best


def _classify_single_step(
    step: Step, h_info: list, ground_z: float, config: TerrainConfig, note: str
) -> tuple[str, str, list[Step]]:
    """One step is a box when its top is bounded: ground seen again beyond it."""
    if step.tread is None:
        return STAIRS, note + "; top not seen, reported as a one-step staircase", [step]
    top_z = step.top_z_m
    top_far = None
    for _h, z, s_h, _v in h_info:
        if abs(z - top_z) < 1e-9:
            top_far = (
                float(percentile(s_h[s_h > step.axis_position_m - 0.02], 98))
                if np.any(s_h > step.axis_position_m - 0.02)
                else None
            )
    if top_far is None:
        return STAIRS, note, [step]
    for _h, z, s_h, _v in h_info:
        if abs(z - ground_z) < config.min_rise_m and np.sum(s_h > top_far + 0.02) >= config.min_tread_points:
            boxed = dataclasses.replace(step, run_m=float(top_far - step.axis_position_m))
            return BOX, note + "; ground seen beyond the top: a box", [boxed]
    return STAIRS, note, [step]


def _intersect_all(triplets: list[list[tuple[np.ndarray, float]]]) -> np.ndarray:
    """Points where each triplet of planes ``(n, d)`` meets, solved in one batch; NaN rows
    for (near) parallel triplets."""
    A = np.array([[p[0] for p in t] for t in triplets], dtype=np.float64).reshape(-1, 3, 3)
    b = -np.array([[p[1] for p in t] for t in triplets], dtype=np.float64).reshape(-1, 3)
    ok = np.abs(np.linalg.det(A)) > 1e-9
    out = np.full((len(A), 3), np.nan)
    if ok.any():
        out[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    return out


def _polytope(steps: list[Step], risers: list[_Riser], u, v, ground_z: float) -> Polytope:
    """Vertices from plane intersections: riser x horizontal x lateral bounds.

    Per step a riser quad (riser plane with the surface below, the tread above and the two
    lateral bounds) and a tread quad (tread plane with this riser, the next one, and the
    lateral bounds).
    """
    by_s = {round(r.s, 6): r for r in risers}
    # Steps without a riser plane of their own span the staircase's lateral extent.
    default_lat = (min(r.v_lo for r in risers), max(r.v_hi for r in risers)) if risers else (-0.5, 0.5)
    triplets: list[list[tuple[np.ndarray, float]]] = []
    prev_plane = (np.array([0.0, 0.0, 1.0]), -ground_z)
    for i, st in enumerate(steps):
        r = by_s.get(round(st.axis_position_m, 6))
        v_lo, v_hi = (r.v_lo, r.v_hi) if r is not None else default_lat
        riser = (st.riser.normal, st.riser.offset)
        top = (
            (st.tread.normal, st.tread.offset)
            if st.tread is not None
            else (np.array([0.0, 0.0, 1.0]), -st.top_z_m)
        )
        lat_lo, lat_hi = (v, -v_lo), (v, -v_hi)
        if i + 1 < len(steps):
            nxt = (steps[i + 1].riser.normal, steps[i + 1].riser.offset)
        else:
            depth = st.run_m if st.run_m is not None else 0.3
            nxt = (-u, st.axis_position_m + depth)  # the plane u . x = s_back
        triplets += [
            [riser, prev_plane, lat_lo],
            [riser, prev_plane, lat_hi],
            [riser, top, lat_hi],
            [riser, top, lat_lo],
            [riser, top, lat_lo],
            [riser, top, lat_hi],
            [nxt, top, lat_hi],
            [nxt, top, lat_lo],
        ]
        prev_plane = top
    if not triplets:
        return Polytope(np.zeros((0, 3)))
    pts = _intersect_all(triplets)
    faces: list[tuple[int, int, int, int]] = []
    keep: list[np.ndarray] = []
    for q in range(len(pts) // 4):
        quad = pts[4 * q : 4 * q + 4]
        if np.isfinite(quad).all():
            base = 4 * len(keep)
            keep.append(quad)
            faces.append((base, base + 1, base + 2, base + 3))
    verts = np.vstack(keep) if keep else np.zeros((0, 3))
    return Polytope(verts, tuple(faces))


# --------------------------------------------------------------------------- uncertainty (issue 14)


def _wrap_angle(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


#: A sample is on a face when its local normal is within about 30 deg of the face's.
_FACE_COS = 0.85


@dataclass(frozen=True)
class _FaceError:
    """What the samples on one face say about its uncertainty."""

    range_m: float  # median distance of its samples from the camera
    ray: np.ndarray  # (3,) unit, camera -> the samples' median
    n_eff: float  # samples, discounted for shared matching errors
    rms_m: float  # spread of the samples about the plane
    count: int
    centre: np.ndarray  # (3,) the samples' median point (where a fitted plane pivots)


def _face_error(
    P: np.ndarray, normals: np.ndarray, cam: np.ndarray, plane: Plane, mask: np.ndarray, *, n_factor: float
) -> _FaceError | None:
    """The samples on ``plane`` (within ``mask``; local normal within 30 deg of the plane's)."""
    sel = mask & (np.abs(normals @ plane.normal) > _FACE_COS)
    q = P[sel]
    if len(q) < 3:
        return None
    med = median(q, axis=0)
    rel = med - cam
    rng = float(np.linalg.norm(rel))
    if rng < 1e-6:
        return None
    res = plane.signed_distance(q)
    rms = float(np.sqrt(np.mean(res * res)))
    return _FaceError(rng, rel / rng, max(1.0, len(q) * n_factor), rms, len(q), med)


def estimate_step_sigmas(
    model: StairModel,
    planes: PlaneSet,
    *,
    focal_px: float,
    baseline_m: float,
    config: TerrainConfig | None = None,
) -> StairModel:
    """``model`` with a 1-sigma for every step's rise, run, distance and width and for the
    stair yaw, propagated from the disparity noise and the plane fits.

    Per face (riser, tread, ground), from its samples in ``planes``: a disparity error
    ``sigma_d`` moves a point at range ``r`` by ``r**2 sigma_d / (f b)`` along its ray, so
    the face moves along its normal by that times ``|ray . n|``. The shared part
    (``disparity_bias_px``) does not average out over the face; the independent part
    (``disparity_sigma_px``) and the samples' spread about the plane (its fit residual) do,
    over the effective sample count (:attr:`TerrainConfig.matching_window_px`). Added to
    that:

    * a top from the riser's top edge (its tread not seen), a riser put at a tread's front
      edge, and the riser's lateral ends are edges of the sample grid: ``edge_sigma_cells``
      grid cells at the face's range (a cell on the ground is longer by
      ``1 / |ray . z|``);
    * an inferred rise (``rise_inferred``, the foot out of view) is the median of the other
      rises: their spread and their own sigma;
    * the yaw: each riser's normal turns when its two ends move by their position sigma
      independently (``sqrt(2) sigma / extent``), and by its fit (spread over sqrt(n)
      and the lateral spread); the risers are combined as the stage combines them
      (weighted by inliers), and their weighted spread about the stair yaw is added (a
      riser plane fitted a few degrees off pulls the mean);
    * the distance: where the frame's x axis meets a riser plane turns with the riser's own
      yaw error about its samples' centre, by ``|c_y| / cos^2(yaw)`` per radian (a riser
      seen only off to one side, its plane turned, also meets the axis short or long).

    Parameters
    ----------
    model : StairModel
        From :func:`build_terrain` on ``planes``.
    planes : PlaneSet
        Yaw frame (z up).
    focal_px, baseline_m : float
        Of the rectified pair (``Rectification.focal_px``, ``baseline_m``).
    config : TerrainConfig

    Returns
    -------
    StairModel
        The same model with ``rise_sigma_m``, ``run_sigma_m``, ``distance_sigma_m``,
        ``width_sigma_m`` of each step and ``yaw_sigma_rad`` set (None where the value is
        None, NaN where the samples say nothing).
    """
    config = config or TerrainConfig()
    if not (focal_px > 0 and baseline_m > 0):
        raise ConfigError(
            f"estimate_step_sigmas needs focal_px, baseline_m > 0, got {focal_px}, {baseline_m}"
        )
    if not model.steps:
        return model
    samples = planes.samples
    P = samples.points.astype(np.float64)
    normals = samples.normals.astype(np.float64)
    cam = np.asarray(planes.camera_position, dtype=np.float64)
    fb = float(focal_px * baseline_m)
    stride = float(samples.stride_px)
    n_factor = min(1.0, (stride / config.matching_window_px) ** 2)
    u = np.array([math.cos(model.yaw_rad), math.sin(model.yaw_rad), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    s_all, v_all = P @ u, P @ v
    band = config.edge_band_m

    def random_var(face: _FaceError) -> float:
        """Variance of the face's position along its ray from what averages out over it."""
        scale = face.range_m**2 / fb
        return ((scale * config.disparity_sigma_px) ** 2 + face.rms_m**2) / face.n_eff

    def bias_m(face: _FaceError) -> float:
        """1-sigma of the face's position along its ray from the shared disparity error."""
        return face.range_m**2 / fb * config.disparity_bias_px

    def shift_sigma(face: _FaceError) -> float:
        """1-sigma of the face's position along its normal (before the projection)."""
        return math.sqrt(bias_m(face) ** 2 + random_var(face))

    def height(face: _FaceError, edge_m: float = 0.0) -> tuple[float, float]:
        """Of a face's height: the independent variance and the signed coefficient of the
        shared disparity error (a closer face moves along its ray, up or down)."""
        rz = float(face.ray[2])
        return random_var(face) * rz * rz + edge_m * edge_m, bias_m(face) * rz

    def cell_m(face: _FaceError) -> float:
        return stride * face.range_m / focal_px

    steps = list(model.steps)
    positions: list[float] = []  # 1-sigma of each riser's position along the axis
    levers: list[float] = []  # 1-sigma of the distance from the riser's own yaw error
    tops: list[tuple[float, float]] = []  # each step's top height: (independent var, bias coef)
    widths: list[float | None] = []
    yaw_info: list[tuple[float, float, float]] = []  # (weight, 1-sigma of the riser's yaw, its yaw)
    s_prev = -np.inf
    for i, st in enumerate(steps):
        s_next = steps[i + 1].axis_position_m if i + 1 < len(steps) else np.inf
        s_pos = st.axis_position_m
        on_riser = (st.riser.residuals(P) < band) & (s_all > s_prev) & (s_all < s_next)
        riser = _face_error(P, normals, cam, st.riser, on_riser, n_factor=n_factor)
        virtual = riser is None or riser.count < config.min_riser_points
        tread_face = None
        if st.tread is not None:
            on_tread = (st.tread.residuals(P) < band) & (s_all > s_pos - band) & (s_all < s_next + band)
            tread_face = _face_error(P, normals, cam, st.tread, on_tread, n_factor=n_factor)
        # Riser position along the stair axis.
        lever = 0.0
        if not virtual:
            assert riser is not None
            sig_pos = shift_sigma(riser) * abs(float(riser.ray @ st.riser.normal))
            # the riser's own samples (the band also holds the tread's and the ground's
            # edges along the riser, which run on beyond a riser seen only in part)
            lat = v_all[on_riser & (np.abs(normals @ st.riser.normal) > _FACE_COS)]
            if len(lat) > 2:
                lo, hi = percentile(lat, [2, 98])
                # the riser's own extent (its samples' band may run on along the plane)
                hi = min(hi, lo + st.width_m) if st.width_m is not None else hi
                if hi - lo > 1e-3:
                    # The riser's two ends move independently by the position sigma: the
                    # normal turns by their difference over the riser's extent; the fit
                    # itself adds its spread over sqrt(n) and the lateral spread.
                    turn = math.sqrt(2.0) * sig_pos / float(hi - lo)
                    fit = riser.rms_m / math.sqrt(riser.n_eff) / max(float(np.std(lat)), 1e-3)
                    riser_yaw = math.atan2(-st.riser.normal[1], -st.riser.normal[0])
                    sig_yaw = math.hypot(turn, fit)
                    yaw_info.append((float(riser.count), sig_yaw, riser_yaw))
                    # The plane turns about its samples' centre: where it meets the frame's
                    # x axis (y = 0), x = c_x + c_y tan(yaw), moves by c_y / cos^2(yaw) per
                    # radian (a riser seen only off to one side and turned is also short).
                    cos2 = max(math.cos(riser_yaw) ** 2, 0.04)
                    lever = abs(float(riser.centre[1])) / cos2 * sig_yaw
        elif tread_face is not None:  # at a tread's front edge: an edge on the ground grid
            ground_cell = cell_m(tread_face) / max(abs(float(tread_face.ray[2])), 0.1)
            sig_pos = math.hypot(config.edge_sigma_cells * ground_cell, shift_sigma(tread_face))
        else:
            sig_pos = math.nan
        positions.append(sig_pos)
        levers.append(lever)
        # Top of the step: the tread plane, else the riser's top edge.
        if tread_face is not None:
            tops.append(height(tread_face))
        elif riser is not None:
            tops.append(height(riser, config.edge_sigma_cells * cell_m(riser)))
        else:
            tops.append((math.nan, math.nan))
        if st.width_m is None:
            widths.append(None)
        elif riser is not None:
            # Two edges of the grid, and the inliers' shortfall at both ends (up to
            # width_loss_cells each; uniform: 1/sqrt(3) of it as a sigma).
            loss = 2.0 * config.width_loss_cells * cell_m(riser) / math.sqrt(3.0)
            widths.append(math.hypot(math.sqrt(2.0) * config.edge_sigma_cells * cell_m(riser), loss))
        else:
            widths.append(math.nan)
        s_prev = s_pos

    # The surface before the first step: the ground (the horizontal samples at its height
    # in front of the first riser).
    first_s = steps[0].axis_position_m
    ground_plane = Plane(np.array([0.0, 0.0, 1.0]), -model.ground_z_m)
    on_ground = (ground_plane.residuals(P) < band) & (s_all < first_s)
    ground = _face_error(P, normals, cam, ground_plane, on_ground, n_factor=n_factor)
    below_first = height(ground) if ground is not None else tops[0]
    rho = config.face_bias_correlation

    def rise_sigma(top: tuple[float, float], below: tuple[float, float]) -> float:
        # The shared disparity error of two neighbouring faces is correlated (rho): it
        # moves both heights alike and largely cancels in their difference.
        (va, a), (vb, b) = top, below
        var_bias = a * a + b * b - 2.0 * rho * a * b
        return math.sqrt(va + vb + max(var_bias, 0.0))

    rises = np.array([s.rise_m for s in steps])
    out: list[Step] = []
    for i, st in enumerate(steps):
        sig_rise = rise_sigma(tops[i], below_first if i == 0 else tops[i - 1])
        if st.rise_inferred:
            others = rises[1:]
            spread = float(np.std(others)) if len(others) > 1 else 0.0
            own = float(np.nanmean([rise_sigma(tops[k], tops[k - 1]) for k in range(1, len(steps))]))
            # the median of n values: its own error, and how far a rise may differ from it
            sig_rise = math.sqrt(own**2 / max(len(others), 1) + spread**2 + (config.min_rise_m / 2) ** 2)
        n_x = abs(float(st.riser.normal[0]))
        sig_dist = math.hypot(positions[i] / max(n_x, 0.2), levers[i])
        sig_run = None
        if st.run_m is not None:
            nxt = positions[i + 1] if i + 1 < len(positions) else math.nan
            sig_run = math.hypot(positions[i], nxt)
        out.append(
            dataclasses.replace(
                st,
                rise_sigma_m=float(sig_rise),
                run_sigma_m=None if sig_run is None else float(sig_run),
                distance_sigma_m=float(sig_dist),
                width_sigma_m=widths[i],
            )
        )
    if yaw_info:
        w = np.array([a for a, _, _ in yaw_info])
        w = w / w.sum()
        sig = np.array([b for _, b, _ in yaw_info])
        dev = np.array([_wrap_angle(c - model.yaw_rad) for _, _, c in yaw_info])
        # The risers' own disagreement (one riser plane fitted a few degrees off pulls the
        # weighted mean): their weighted spread about the stair yaw.
        spread = float(np.sqrt(np.sum(w * dev**2)))
        yaw_sigma = math.hypot(float(np.sqrt(np.sum(w**2 * sig**2))), spread)
    else:
        yaw_sigma = math.nan
    return dataclasses.replace(model, steps=tuple(out), yaw_sigma_rad=yaw_sigma)
