"""The terrain stage's values: its config (:class:`TerrainConfig`) and what it finds
(:class:`StairModel` of :class:`Step` and a :class:`Polytope`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..msac import Plane

STAIRS, BOX, NONE = "stairs", "box", "none"

#: A staircase's rises agree when the largest is at most this many times the smallest (a
#: stair's rises are equal; steps of 9 and 29 cm are a wrong match or a room's
#: furniture): the pipeline's second opinions keep only staircases whose measured rises
#: agree (``stereo_terrain.pipeline.config``), and the nosings' pitch rebuilds a one-riser
#: chain only at a rise that agrees with its measured one (:func:`.nosings.pitched_steps`).
AGREEING_RISE_RATIO = 1.5


def stair_axes(yaw_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """The stair axis ``u`` (horizontal unit vector up the stairs, ``yaw_rad`` from the
    frame's x axis) and the lateral direction ``v`` (``u`` turned +90 deg about z): a
    step's position is ``u . x``, its place across the staircase ``v . x``."""
    u = np.array([math.cos(yaw_rad), math.sin(yaw_rad), 0.0])
    return u, np.array([-u[1], u[0], 0.0])


@dataclass(frozen=True)
class TerrainConfig:
    """What counts as a step.

    Attributes
    ----------
    min_rise_m, max_rise_m : float
        A riser shorter than ``min_rise_m`` is noise; a vertical plane taller than
        ``max_rise_m`` (plus ``edge_margin_m``) is a wall, not a step. The ground must be
        ``min_rise_m`` or more below the cameras (a surface above them is seen from below);
        where ``build_terrain`` is not told whether the frame has a floor
        (``floor_known``), a camera less than that above the frame's origin means it has
        none (no rig, none found). A riser in front of the stairs whose top is the lowest plane
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
    min_run_m : float
        A step's run is at least this: a riser standing nearer than this beyond the one
        before it is not the next step of a staircase (ordinary stairs have runs of 22 cm
        or more; the default leaves room for steep stairs and measurement noise). A face
        that close behind a riser is an object's, e.g. the next leaf of a plant.
    max_facing_angle_deg : float
        A riser must face the robot: its normal within this of the direction to the camera.
    max_riser_see_through : float
        A riser is solid: of the samples whose rays cross the middle of its face (inside
        15% of its height and width from its edges), leaving out those a quarter or more in
        front of it, at most this share may lie a quarter or more beyond it along their
        rays. More, and the vertical plane is a railing, a handrail with balusters or
        clutter that the scene behind shows through, not a riser (the webcam-degraded real
        ``Staircase``'s railing at 0.7 m; issue 11). A riser's own samples scatter by
        centimetres, not by a quarter of their range. Past about 3.2 m the samples a
        quarter beyond are past the cloud's depth limit (``CloudConfig.max_depth_m``, 4 m),
        and the test cannot fire. 1 = off.
    max_riser_hidden : float
        A riser is seen: of all the samples whose rays cross the middle of its face, at most
        this share may stand a quarter or more in front of it on no vertical plane (a rail,
        balusters, a wall or a box front that formed a plane is accounted for). More, and
        the plane runs through scattered things, most of them nearer than it (the
        Middlebury ``Playroom``'s 14 cm "riser" through a beanbag's foot, a shelf and a
        poster: 68%). The real ``Staircase``'s first riser, behind its railing: 28-43% in
        the webcam-degraded runs looked at. 1 = off.
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
    continue_steps : bool
        Look for the next riser beyond the last riser plane of a staircase where the
        steps' spacing puts it, from its samples' positions alone (a far riser whose
        samples' normals are too noisy to form a plane); its rise is the median of the
        measured ones (``rise_inferred``). See :mod:`.continuation`.
    continue_run_tolerance : float
        Such a riser must stand within this fraction of the median run from the last one.
    continue_min_run_m, continue_max_run_m : float
        Where no run is known yet (a single step whose tread's far edge is not seen; its
        tread must be seen, a lone riser is not continued), the next riser must stand
        this far beyond it: the runs of ordinary building stairs (codes ask for 22-36
        cm) with a margin for the position's noise. A single step so continued is a
        staircase, not a box.
    max_continued_steps : int
        At most this many steps are added so.
    nosing_steps : bool
        Beyond those, where the pipeline passes the image's line segments
        (:class:`~stereo_terrain.terrain.nosings.ImageLines`: those its lines' job found
        for gravity or the Manhattan fill; none with a rig and the fill or its Manhattan
        step off), add the steps whose nosings
        the segments show at the staircase's rise and run (a far riser whose samples are
        too few or too noisy for either). Their rise is the median of the measured ones
        and their position the median run beyond the step before (``rise_inferred``). See
        :mod:`.nosings`.
    nosing_axis : bool
        Where the pipeline passes the image's line segments, the staircase's axis is the
        one its nosings' and risers' feet's segments show (near the risers' normals'): its
        chain is assembled and finished again along it, and kept where it has as many
        steps (:mod:`.nosings.axis`). Default true (issue 11: painted and carpeted risers are
        mostly a fill's plane, whose normal can be degrees off).
    lines_first_riser : bool
        Where every pass found nothing, the floor is known and the pipeline has the image's
        line segments: the staircase whose first riser's foot and nosing the segments show
        as lines (the floor the matcher holds in front of the foot, and not most of the
        samples beyond it), finished as a one-riser chain is (the nosings' pitch and the
        nosings beyond), kept where that makes three steps or more and the samples where
        they would stand do not all lie at the floor's height
        (:func:`~.from_lines.staircase_from_lines`, asked by the pipeline last). Default
        true (issue 11: painted stairs, whose risers form no plane).
    floor_edge_foot : bool
        With ``lines_first_riser``, where that and the risers' ends found nothing too: the
        first riser's foot is looked for where the floor the matcher holds ends, in front
        of each foot's line (a painted riser's foot on a textured floor breaks into short
        segments, and the first long line on the floor is the first nosing), with the
        nosings over it; kept where that makes two steps or more
        (:func:`~.from_lines.floor_edge_feet`, asked by the pipeline after every other
        opinion). Default true (issue 11).
    nosing_pitch : bool
        With ``nosing_steps``: a chain that stands on one riser plane is rebuilt on the
        pitch (rise and run) that puts the most nosings, from the first on, on the image's
        segments, anchored at the riser's foot (:func:`~stereo_terrain.terrain.nosings.pitched_steps`;
        its guards there). Default true (issue 11).
    max_nosing_steps : int
        At most this many steps are added so (and as many by ``riser_end_steps``).
    riser_end_steps : bool
        Carry a chain on beyond its last step where the image shows the next risers' ends:
        vertical edges a rise tall, about a run apart, that both images place
        (:func:`~stereo_terrain.terrain.nosings.end_steps`). Default true (issue 11:
        painted stairs seen at an angle, whose faces and nosings the matcher cannot hold).
    ends_staircase : bool
        Where the frame's result is a staircase or a step, the floor is known and the
        pipeline has the image's line segments: the staircase whose risers' ends both
        images place, one side of it showing three steps' ends or more from the floor up
        on one pitch, where it holds a riser the planes measured and has more steps, or as
        many from the same first riser with better rises (the result's off by 2 cm or more,
        its own treads disagreeing among themselves or lying on the ends' pitch)
        (:func:`~.from_ends.staircase_from_ends`, asked by the pipeline last). Default true
        (issue 11: painted stairs whose chain of riser planes starts late or stops early).
    ends_over_planes : bool
        With ``ends_staircase``: where the ends' staircase holds none of the riser planes'
        staircase's measured risers, it replaces that staircase where it shows its own
        first step's ends or has more steps, and it has as many steps or more
        (:func:`~.from_ends._outweighs`). Default true (issue 11: the planes' staircase
        put 13-42 deg off its axis, or a step late, where the ends lay within 2-5 deg).
    plumb_edges : bool
        The risers' ends (the vertical edges of ``riser_end_steps`` and ``ends_staircase``)
        are looked for in the grey levels too, where the line segments miss them: the
        horizontal gradient averaged along the rows, near-vertical lines where it peaks
        (:func:`~stereo_terrain.terrain.nosings.plumb.plumb_segments`). Default true
        (issue 11: painted risers ending against a wall of nearly their grey, whose ends LSD
        finds in pieces or not at all).
    nosing_run_tolerance : float
        A nosing counts where the segments put it within this fraction of a step (along
        the staircase's pitch line) from where the median rise and run put it.
    nosing_min_cover : float
        Share of the staircase's visible width the segments of one nosing must cover.
    nosing_min_foot_cover : float
        Where the cameras are above the last tread, share of the visible width that the
        segments at the next riser's foot must cover.
    nosing_edge_contrast : float
        Where no segments show the next nosing, it is looked for in the rectified image's
        grey levels (smoothed): a step edge along the predicted line, the two sides
        differing by at least this many grey levels over ``nosing_min_cover`` of the
        width, and its foot likewise (:func:`~stereo_terrain.terrain.nosings.edges.edge_nosing`).
        0 turns it off.
    face_bias_correlation : float
        Correlation of the shared disparity error of neighbouring faces (a tread and the
        surface below it), in [0, 1]: most of it moves both alike and cancels in a rise.
        Measured on the rendered approaches: single-frame rise errors are about 0.3 of
        what independent biases would give, i.e. a correlation near 0.9.
    max_steps_below_chain : int
        Where nothing chains from the ground, a chain of two or more riser planes that
        starts this many of its rises or fewer above the ground (a whole number, within
        ``chain_tolerance_m``) and whose risers stand a run apart is the staircase, the
        steps below it inferred at its rise and run (``rise_inferred``): realistic stairs
        whose first riser formed no plane. Also the most steps put between a known floor
        and a chain that starts above it (:mod:`.below`). 0 = off.
    common_rise_tolerance_m, common_run_tolerance_m : float
        A staircase's rises are equal, and so are its runs (building codes allow about a
        centimetre between the largest and the smallest); what differs between measured
        ones is mostly the measurement, worst on the far steps. Where ``common_min_steps``
        or more measured rises (``common_min_runs`` or more runs) lie within this of their
        median, each of those steps reports that median, the staircase's common rise (run;
        two runs must also lie within this of each other); its own stays in
        ``Step.measured_rise_m`` (``measured_run_m``), and the swing plan clears the larger
        of the two. A step further off keeps its own (a different step, or a measurement
        gone wrong: either way not averaged away; those pooled may differ by up to twice
        this between them), but for two neighbours on either side of the common rise,
        their mean within half of this of it, beside ``common_min_steps - 1`` or more
        others that agree: the top between them misplaced (:func:`.uniform.misplaced_top`).
        The run tolerance is wider: a riser's position is less sure
        than a height (0.05 until the twenty-eighth session, docs/benchmarks.md). 0 = off.
        See :mod:`.uniform`.
    common_min_steps : int
        Measured rises that must agree for a common one (with two, neither can be told to
        be the odd one: two rises that differ may be a first step on a thicker floor).
    common_min_runs : int
        Measured runs that must agree for a common one. Two are enough: two runs of one
        flight differ by their risers' disparity noise, and their mean is half the span
        from the first riser to the third, whose errors are independent, where each run
        shares the middle riser's error with a sign of its own (2 for the lab-like
        three-step staircases, whose two runs were otherwise never pooled).
    nosing_rise : bool
        Where the image's line segments show two or more of a staircase's nosings, its
        common rise is the one that puts them at their heights (a least-squares fit from
        the ground, each within ``common_rise_tolerance_m``), not the median of the
        measured rises; the measured rises within ``common_rise_tolerance_m`` of it report
        it (and two neighbours across a misplaced top). See :mod:`.uniform`.
    max_edge_bias_m : float
        A riser's top edge, found from the samples nearest it, lies low, and its bottom
        edge high, by about the same amount. In a staircase whose every top is its riser's
        edge (no tread formed a plane), the rises between them cancel it but the first
        step's, from the floor plane, keeps it all: there half the median gap between a
        top edge and the next riser's bottom edge (where that foot is in view) is added to
        every top, at most this much. 0 = off. See :func:`.risers.edge_bias`.
    photometric_risers : bool
        Where the pipeline passes the rectified pair (``ImageLines.stereo``), each riser of
        the staircase found (not those the image's lines place a run beyond the step
        before) is moved to the distance at which the two images of its face agree best,
        its normal kept; the runs between moved risers move with them (:mod:`.photometric`).
        Default true (issue 11: runs of real stairs).
    photometric_span : float
        The distances searched: the riser's disparity (``d + doffs``) scaled by ``1 +-
        photometric_span``, in (0, 0.5) (0.08: the depth from 7% nearer to 9% farther,
        -15 to +17 cm at 2 m).
    photometric_min_sharpness : float
        The search's best distance is kept where the cost (1 - the normalised correlation
        of the two images' horizontal gradients over the face) rises by at least this, on
        average, ``0.3 * photometric_span`` away on both sides; a flat cost (a uniform
        face, a face region mixing in the tread) leaves the riser where its samples put it.
    photometric_max_cost : float
        ... and where that least cost is at most this (a correlation of at least
        ``1 - photometric_max_cost``: the two images of the face do match there) ...
    photometric_max_spread : float
        ... and where the face's thirds across the image, searched each on its own, put
        their best distances within this fraction of the span of each other (a minimum
        that one part of the face makes, a baluster's edge or a repeated grain, is not
        where the others put theirs).
    box_top_gap_m : float
        A box's top ends where its samples along the stair axis, within its riser's
        width, leave a gap wider than this, nearest first (:func:`.polytope.box_depth`):
        the top's own samples follow each other a grid row apart, 2-13 cm at 1-2 m, and
        what stands at its height beyond (a wall, a shelf, the far floor) lies farther.
        A hole in the top's samples wider than this (a face the matcher does not hold)
        cuts the depth short; past about 2 m, with the cameras some 40 cm above the top,
        a grid row is wider than 15 cm and the depth comes out short too.
    """

    min_rise_m: float = 0.04
    max_rise_m: float = 0.30
    max_obstacle_rise_m: float = 0.50
    edge_margin_m: float = 0.06
    min_riser_width_m: float = 0.15
    min_riser_points: int = 25
    merge_distance_m: float = 0.06
    min_run_m: float = 0.15
    max_facing_angle_deg: float = 70.0
    max_riser_see_through: float = 0.4
    max_riser_hidden: float = 0.5
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
    continue_steps: bool = True
    continue_run_tolerance: float = 0.25
    continue_min_run_m: float = 0.20
    continue_max_run_m: float = 0.45
    max_continued_steps: int = 3
    nosing_steps: bool = True
    nosing_axis: bool = True
    lines_first_riser: bool = True
    floor_edge_foot: bool = True
    nosing_pitch: bool = True
    max_nosing_steps: int = 4
    riser_end_steps: bool = True
    ends_staircase: bool = True
    ends_over_planes: bool = True
    plumb_edges: bool = True
    nosing_run_tolerance: float = 0.35
    nosing_min_cover: float = 0.4
    nosing_min_foot_cover: float = 0.25
    nosing_edge_contrast: float = 4.0
    max_steps_below_chain: int = 2
    common_rise_tolerance_m: float = 0.03
    common_run_tolerance_m: float = 0.10
    common_min_steps: int = 3
    common_min_runs: int = 2
    nosing_rise: bool = True
    max_edge_bias_m: float = 0.04
    photometric_risers: bool = True
    photometric_span: float = 0.08
    photometric_min_sharpness: float = 0.01
    photometric_max_cost: float = 0.5
    photometric_max_spread: float = 0.6
    box_top_gap_m: float = 0.15

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "min_riser_points", "min_tread_points")
        check_min(
            self,
            0,
            "max_continued_steps",
            "max_nosing_steps",
            "max_steps_below_chain",
            "common_rise_tolerance_m",
            "common_run_tolerance_m",
            "max_edge_bias_m",
            "nosing_edge_contrast",
            "photometric_min_sharpness",
        )
        if not self.box_top_gap_m > 0:
            raise ConfigError(f"TerrainConfig.box_top_gap_m must be > 0, got {self.box_top_gap_m}")
        for name in ("photometric_max_cost", "photometric_max_spread"):
            # a cost is 1 - a correlation, in [0, 2]; the thirds' spread is at most 2 spans
            if not 0 < getattr(self, name) <= 2:
                raise ConfigError(f"TerrainConfig.{name} must be in (0, 2], got {getattr(self, name)}")
        if not 0 < self.photometric_span < 0.5:
            raise ConfigError(
                f"TerrainConfig.photometric_span must be in (0, 0.5), got {self.photometric_span}"
            )
        check_min(self, 2, "common_min_steps", "common_min_runs")
        if not 0 < self.continue_min_run_m < self.continue_max_run_m:
            raise ConfigError(
                "need 0 < continue_min_run_m < continue_max_run_m, got "
                f"{self.continue_min_run_m}, {self.continue_max_run_m}"
            )
        for name in ("nosing_run_tolerance", "nosing_min_cover", "nosing_min_foot_cover"):
            if not 0 < getattr(self, name) < 1:
                raise ConfigError(f"TerrainConfig.{name} must be in (0, 1), got {getattr(self, name)}")
        if not 0 < self.continue_run_tolerance < 1:
            raise ConfigError(
                f"TerrainConfig.continue_run_tolerance must be in (0, 1), got {self.continue_run_tolerance}"
            )
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
            "min_run_m",
            "tread_height_tolerance_m",
            "edge_band_m",
            "chain_tolerance_m",
        )
        for name in ("max_riser_see_through", "max_riser_hidden"):
            if not 0 < getattr(self, name) <= 1:
                raise ConfigError(f"TerrainConfig.{name} must be in (0, 1], got {getattr(self, name)}")
        for name in ("max_facing_angle_deg", "axis_spread_deg"):
            if not 0 < getattr(self, name) <= 90:
                raise ConfigError(f"TerrainConfig.{name} must be in (0, 90] deg, got {getattr(self, name)}")
        if not 0 < self.min_rise_m < self.max_rise_m <= self.max_obstacle_rise_m:
            raise ConfigError(
                "need 0 < min_rise_m < max_rise_m <= max_obstacle_rise_m, got "
                f"{self.min_rise_m}, {self.max_rise_m}, {self.max_obstacle_rise_m}"
            )


@dataclass(frozen=True)
class RiserMove:
    """A riser moved to where both rectified images of its face agree
    (:mod:`.photometric`).

    Attributes
    ----------
    sampled_riser : Plane
        The plane its samples gave, around which they lie (the step sigmas find them
        there).
    sampled_position_m : float
        Where along the stair axis its samples put it (the step's ``axis_position_m``
        before the move; the polytope and the step sigmas find the riser's samples there).
    sigma_m : float
        1-sigma of the moved plane's position along its normal, metres, from how far apart
        the face's thirds put it.
    """

    sampled_riser: Plane
    sampled_position_m: float
    sigma_m: float


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
        in front), and for a step found beyond the last riser plane from its samples'
        positions (:mod:`.continuation`) or its nosing's line segments (:mod:`.nosings`):
        its rise is the median of the other steps' rises; and for both halves of a double
        step split by :mod:`.nosings` (half the measured double rise).
    rise_sigma_m, run_sigma_m, distance_sigma_m, width_sigma_m : float or None
        1-sigma of ``rise_m``, ``run_m``, ``distance_m`` and ``width_m`` (issue 14,
        :func:`estimate_step_sigmas`); NaN until estimated, None where the value is None.
    measured_rise_m, measured_run_m : float or None
        The rise (run) measured for this step where ``rise_m`` (``run_m``) is the
        staircase's common one (:mod:`.uniform`); None where it is the step's own (or
        inferred, or not seen).
    position_inferred : bool
        True for a step the image's line segments show (:mod:`.nosings`): its riser is
        placed at the staircase's run from the step before, not measured; its position's
        sigma is the step before's and the runs' spread (:func:`estimate_step_sigmas`).
    riser_move : RiserMove or None
        Where ``riser`` was moved to where both images of its face agree
        (:mod:`.photometric`): the plane its samples gave and the moved position's sigma.
        None where it was not moved.
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
    measured_rise_m: float | None = None
    measured_run_m: float | None = None
    position_inferred: bool = False
    riser_move: RiserMove | None = field(repr=False, default=None)

    @property
    def own_rise_m(self) -> float:
        """The rise this step measured: ``measured_rise_m`` where ``rise_m`` is the
        staircase's common one, else ``rise_m``."""
        return self.rise_m if self.measured_rise_m is None else self.measured_rise_m

    @property
    def sampled_riser(self) -> Plane:
        """The riser plane its samples gave (``riser`` unless it was moved,
        :attr:`riser_move`): the samples lie around it."""
        return self.riser if self.riser_move is None else self.riser_move.sampled_riser

    @property
    def sampled_position_m(self) -> float:
        """Where along the stair axis its samples put the riser (``axis_position_m``
        unless it was moved, :attr:`riser_move`)."""
        return self.axis_position_m if self.riser_move is None else self.riser_move.sampled_position_m

    @property
    def own_run_m(self) -> float | None:
        """The run this step measured (as :attr:`own_rise_m`; None where not seen)."""
        return self.run_m if self.measured_run_m is None else self.measured_run_m


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
