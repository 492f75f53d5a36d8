"""The pipeline's configuration: :class:`PipelineConfig` (every stage's config with SI
defaults), built from a mapping or a YAML file."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..checks import check_fields, check_min
from ..cloud import CloudConfig
from ..drift import DriftConfig
from ..errors import ConfigError
from ..gravity import GravityConfig, VerticalLinesConfig
from ..planes.contour import ContourConfig
from ..planes.orientation import OrientationConfig
from ..rectify import RECTIFY_FOVS
from ..stereo.bands import BandFillConfig
from ..stereo.denoise import MAX_STRENGTH_GREY
from ..stereo.fill import PlanarFillConfig
from ..stereo.opencv import OpenCVSGBMConfig
from ..stereo.sgm import SGMConfig
from ..stereo.vertical import VerticalAlignConfig
from ..swing import SwingConfig
from ..terrain import TerrainConfig
from ..terrain.model import AGREEING_RISE_RATIO as AGREEING_RISE_RATIO
from ..tracking import TrackingConfig

#: The rematch's matcher (``PipelineConfig.rematch_sgbm``): issue 11, wood seen by webcams.
REMATCH_SGBM = OpenCVSGBMConfig(match_exposure=True, p1_per_px=24, p2_per_px=96, penalty_width_px=640)

#: ``AGREEING_RISE_RATIO`` (:mod:`stereo_terrain.terrain.model`): the coarse rematch's
#: staircase must agree (``PipelineConfig.rematch_coarse``), and one that does not is
#: matched again (``rematch_disagreeing``).

#: Plane extraction methods (``PipelineConfig.method``, ``reconstruct --method``).
PLANE_METHODS = ("orientation", "contour", "auto")


@dataclass(frozen=True)
class PipelineConfig:
    """Configuration of the whole pipeline; every stage's config with SI defaults.

    Attributes
    ----------
    backend : str
        Disparity backend: ``opencv`` (default; StereoSGBM) or ``sgm`` (the project's own
        engine; more accurate on textured real scenes, slower; see the README).
    sgbm, sgm : OpenCVSGBMConfig, SGMConfig
        Options of the two backends (only the chosen one's are used); e.g. ``sgm: {device:
        auto}`` runs our engine on a GPU when one is present.
    max_disparity_px : int or None
        Disparity search range; None chooses it from ``min_depth_m`` (a multiple of 16).
    fill : PlanarFillConfig
        Planar fill of texture-poor faces after matching (``fill.enabled``).
    min_depth_m : float
        Closest depth the disparity range must reach when chosen automatically.
    method : str
        Plane extraction: ``orientation`` (default; paper 3.2.2), ``contour`` (paper
        3.2.1) or ``auto`` (both; the contour planes are added when that gives more steps,
        and the result's ``plane_stage`` says which was used and why).
    gravity : GravityConfig
        Gravity from the scene's plane families without a rig, and the check of a rig
        against the scene (:mod:`stereo_terrain.gravity`).
    drift : DriftConfig
        Online correction of the rectification for a rig that moved since calibration
        (``drift.online``, off by default; see :mod:`stereo_terrain.drift`).
    rectify_fov : str
        What the rectified view keeps (:data:`stereo_terrain.rectify.RECTIFY_FOVS`):
        ``valid`` (default; OpenCV alpha 0), ``full-height`` (the raw images' whole height:
        for a camera close to stairs whose floor is a thin strip at the bottom), ``keep``
        (alpha 0's focal length in a larger image that holds the whole raw left image) or
        ``all``.
    vertical : VerticalAlignConfig
        Per-frame correction of a residual vertical offset of the right image
        (:mod:`stereo_terrain.stereo.vertical`; ``vertical.enabled``, on by default).
    vanishing : VerticalLinesConfig
        Without a rig, up also from the vanishing point of the image's vertical lines
        (:mod:`stereo_terrain.gravity.from_lines`; ``vanishing.enabled``, on by default), combined
        with the planes' estimate (:func:`stereo_terrain.gravity.from_lines.combine_with_lines`).
    tracking : TrackingConfig
        The staircase tracked over frames by the live loop (``run``, ``replay``; issue
        14, :mod:`stereo_terrain.tracking`); ``tracking: {enabled: false}`` gives single
        frames. A single ``reconstruct`` does not use it.
    rematch : bool
        With the ``opencv`` backend: when a frame finds no obstacle, or a staircase of one
        step, match its pair again with ``rematch_sgbm`` and run the later stages on that
        disparity; its result is kept when it finds a staircase of two steps or more, none
        taller than ``terrain.max_rise_m`` (the terrain note says so; a lone step from the
        harder smoothing is as likely an object's front; a taller step, two steps taken for
        one: ``second_opinions.stair_rises``). Default true (issue 11:
        wooden stairs seen by webcams; docs/benchmarks.md, "Eleventh session"). A frame
        with nothing in view pays for both passes.
    rematch_sgbm : OpenCVSGBMConfig
        The second matcher: the right image's exposure matched to the left's and harder
        penalties (``p1_per_px`` 24, ``p2_per_px`` 96, scaled with the image width from
        640 px), which hold the rows of a face with horizontal grain together.
    rematch_coarse : bool
        With ``rematch``: when the rematch too finds no staircase of two steps or more,
        match the pair once more at half size (``rematch_sgbm`` with ``downsample: 2``),
        whose smoothness reaches twice as far across a texture-poor face. Its staircase
        is kept only when it is one: two steps or more whose measured rises agree (the
        largest at most ``AGREEING_RISE_RATIO`` times the smallest), none taller than
        ``terrain.max_rise_m``, and whose runs are at most ``terrain.continue_max_run_m``;
        the terrain note says so. Default true
        (issue 11; docs/benchmarks.md, "Thirteenth session"). A frame with nothing in view
        pays for a third pass (a half-size match and the later stages).
    rematch_focus : bool
        With ``rematch``: when every opinion before it (the rematch, the coarse rematch,
        the far planes) leaves the frame wanting one (as above), and one camera's image
        is blurrier than the other's by :data:`stereo_terrain.stereo.blur.MIN_BLUR_PX`
        or more (two webcams focus apart), the sharper image is blurred to the other's
        focus and the pair matched once more with ``rematch_sgbm``
        (:func:`stereo_terrain.stereo.blur.match_blur`), then its own far planes. Its
        staircase is kept as the coarse rematch's is (steps that agree). After the
        others (but the denoised opinions), so that it changes nothing they found
        (blurring in the rematch itself found more
        staircases and lost others). Default false (issue 11): on the realistic renders
        it adds 0-9 points of detection, but a control pass that blurs the wrong image
        adds nearly as much, so the gain is mostly a fourth pass's second chance, and a
        frame with nothing in view and cameras focused apart pays for that pass (empty
        realistic views 1.45x, docs/benchmarks.md, "Fifteenth session"). For webcams
        whose images look differently sharp.
    rematch_denoised : float
        With ``rematch``: when every opinion before it (the passes, the far planes, the
        lone step, the box, the redrawn planes and the focus rematch) still leaves the frame
        wanting one (nothing, a lone step, or steps that disagree), both rectified images
        are denoised by non-local means of this strength (grey levels, about the noise's
        standard deviation; :func:`stereo_terrain.stereo.denoise.denoise_pair`) and
        matched again by the rematch and the coarse rematch, each kept as the coarse
        rematch's is (steps that agree); then, on those two passes only, the far planes,
        the lone step they agree on, with a rig a box one sees whole (without one, the
        ground beyond a "box" can be a table's top), and the redrawn planes, as for the
        passes before. Last, so that it changes nothing the others found (but a lone step
        or steps that disagree, which its staircase may replace); the terrain note says
        "found by the denoised rematch" or "... coarse rematch". A webcam's noise,
        blotchy after its own smoothing and JPEG, is most of what the matcher sees on
        near-uniform paint and plain walls. Default 3 (issue 11; docs/benchmarks.md,
        "Thirtieth session": realistic detection +4 to +6 points with a rig, boxes +13;
        a control pass on a noisier pair gives about two thirds of the realistic gain,
        a second chance at the margin, and less on boxes). A frame with nothing in view
        pays for it (about 150 ms here, the denoising of a 640x480 pair 100 ms of it:
        empty realistic renders 2.3x, the OAK-D rooms 1.5-2.6x); 0 turns it off. At most
        :data:`stereo_terrain.stereo.denoise.MAX_STRENGTH_GREY` (50).
    rematch_disagreeing : bool
        With ``rematch``: a staircase whose steps disagree (its largest measured rise more
        than ``AGREEING_RISE_RATIO`` times its smallest, or a run longer than
        ``terrain.continue_max_run_m``) is matched again too, by the rematch and then the
        coarse rematch; the first of their staircases whose steps agree, with at most one
        step fewer, replaces it (the terrain note says so). A real staircase with one odd
        step keeps it: the other passes measure that step too. Default true (issue 11;
        docs/benchmarks.md, "Thirteenth session").
    far_planes_sigmas : float
        When no pass (the first matcher and the second opinions that ran) finds an
        obstacle, the plane stage runs again on each pass's samples, the last pass first
        (the coarse rematch's disparity is the best far away), with the normal tests
        widened by the far samples' noise
        (``orientation.normal_noise_sigmas`` set to this); the first staircase whose steps
        agree (as ``rematch_coarse`` asks) is kept, and the terrain note says so. Far
        away a riser's samples have normals tens of degrees off (2 m at a 7 cm baseline:
        about 27 deg), which the default test refuses; widened for every frame it also
        moves staircases that were found without it. Only with ``method: orientation``;
        0 turns it off. Default 1.1 (issue 11: the wooden lab stairs 1.5-2.5 m ahead;
        docs/benchmarks.md, "Fourteenth session").
    far_planes_wider_sigmas, far_planes_wider_max_deg : float
        With the far planes on: where they keep nothing, they run once more with the
        normal tests widened further (``normal_noise_sigmas`` set to
        ``far_planes_wider_sigmas``, capped at ``far_planes_wider_max_deg`` instead of
        ``orientation.max_noise_tolerance_deg``: at 1.6 sigmas the usual 35 deg cap is
        reached from 2 m and would widen nothing beyond it). Same acceptance, and the note
        says "widened further". Defaults 1.6 and 40 deg; ``far_planes_wider_sigmas: 0``
        turns it off (issue 11; docs/benchmarks.md, "Fifteenth session").
    redraw_planes : int
        When every pass and the far planes still find no obstacle, or only a lone step or
        steps whose rises disagree (what the rematch is run for too, with
        ``rematch_disagreeing``), the plane stage runs again on the last pass's samples
        (the coarse rematch's, where it ran) with this many other seeds of its random
        draws (``orientation.seed`` + 1, + 2, ...),
        expressed in the frame the result keeps (the rig's, or the up from the scene the
        passes corroborate) so that its gravity stays that frame's; the first staircase
        whose steps agree and whose first riser stands on the ground seen (as the far
        planes ask) is kept, and the terrain note says so. A staircase at the margin of
        what the samples hold is found or not by the draws (lab-like renders: a rig
        pitch changed by 0.2 deg found 4 of 9 misses). Only with ``method: orientation``
        and ``rematch``; 0 turns it off. Default 3 (issue 11; docs/benchmarks.md,
        "Twentieth session"): realistic detection +1 to +8 points, 4 lone steps made
        whole staircases with the right count, 6 of 7 disagreeing staircases nearer the
        truth (one at most a step fewer), no false positive on the empty renders or
        the real rooms; a frame with nothing in view pays for the draws on the half-size
        samples (8-10 ms on the empty renders, 19-64 ms on the real rooms: 10-15% of
        their frame).
    agreed_lone_step : bool
        With ``rematch``: when no pass finds an obstacle (nor do the far planes), the lone
        step (a box, a one-step staircase) that the rematch and the coarse rematch each
        find alike (the same riser, rises within ``terrain.common_rise_tolerance_m``, its
        top seen, no taller than ``terrain.max_rise_m``) is kept, and the terrain note says
        so (:func:`~.second_opinions.agreed_lone_step`). One second opinion's lone step is
        not enough. Default true (issue 11; docs/benchmarks.md, "Twenty-fifth session").
    whole_box : bool
        With ``rematch``: where that keeps nothing either, the first box that one second
        opinion sees whole (the terrain stage found its front, its top and the ground
        beyond the top; no taller than ``terrain.max_rise_m``) is kept, and the note says
        so (:func:`~.second_opinions.whole_box`). Default true (issue 11; docs/benchmarks.md,
        "Twenty-fifth session").
    corroborated_frame : bool
        Without a rig, with ``rematch``: where the frame keeps an obstacle found by a pass
        whose up from the scene the other passes do not corroborate, and two or more of
        them corroborate another pass's up (within three combined sigmas, as
        :func:`~.second_opinions.corroborated_up` asks), that pass's samples are
        expressed in the corroborated pass's frame and the terrain is found again there;
        the result keeps that frame and its gravity, and the notes say so
        (:func:`~.second_opinions.corroborated_frame`). Where the terrain found there is
        no obstacle, or steps that disagree, the result is left as it was. Only with
        ``method: orientation``. Default true
        (issue 11; docs/benchmarks.md, "Thirty-seventh session": a denoised pass's far
        planes 13 deg off became 0.4 deg; 1 of 240 rendered runs and 2 of 187 real room
        runs changed).
    floor_a_step_below : bool
        Without a rig, where the frame's floor (the lowest large horizontal plane) is the
        staircase's first tread: its first riser has ``terrain.min_riser_points`` samples
        or more under that floor, a run or more in front of the chain, and that floor
        does not run to the view's bottom (a floor that does is the one under the
        cameras). The terrain is found again with
        the floor the first rise lower (with the floor known, as with a rig), and kept
        where it has more steps, the first in front of the one before; the result keeps
        that frame and its note says so (:func:`~.second_opinions.floor_a_step_below`;
        ``timing_ms["floor_below"]``). Default true (issue 11: a level camera that sees
        no floor before the stairs; docs/benchmarks.md, "Forty-fourth session").
    floor_below_nosing : bool
        ``floor_a_step_below`` also where its first riser shows no samples under the
        floor but the image's segments show that riser's nosing: on the floor's height,
        a run in front of the chain, across the staircase
        (:func:`~stereo_terrain.terrain.nosing_under_floor`); the step then placed below
        must stand there too (its run within ``terrain.continue_run_tolerance`` of the
        chain's median run). Default true (issue 11:
        the first riser's strip under its nosing, painted, held no disparity;
        docs/benchmarks.md, "Fifty-second session").
    floor_below_floorless : bool
        ``floor_a_step_below`` also in a frame that found no floor plane below the
        cameras (its origin left at them): the staircase's ground, the lowest horizontal
        surface below the cameras that its first rise was measured from, is asked the
        same, in a frame whose origin is on it (a close level camera whose view's bottom
        falls on the first tread). Default true (issue 11; docs/benchmarks.md,
        "Fifty-fourth session").
    floor_below_keep_chain : bool
        In a frame that found no floor plane (``floor_below_floorless``), where
        ``floor_a_step_below``'s terrain built again in the lowered frame has no more
        steps in front (the planes chained at other heights drop or misplace a riser),
        but the first riser's samples under the staircase's ground stand a run (the
        chain's median, within ``terrain.continue_run_tolerance``) in front of the chain:
        the chain as it was, raised a rise, with its first riser there
        (:func:`~stereo_terrain.terrain.below.step_in_front`). Not under a floor plane,
        where such samples were as often the matcher's strays. Default true (issue 11;
        docs/benchmarks.md, "Fifty-fifth session").
    bands : BandFillConfig
        The band fill (``bands.enabled``, :mod:`stereo_terrain.stereo.bands`): the faces
        between parallel horizontal lines of the rectified left image (a riser between
        its nosing and its foot, a plank between two gaps) get the disparity of the one
        plane, vertical or horizontal, that a photometric sweep over the whole face finds,
        where the sweep is sure of it. The second opinions' passes use it (the rematch and
        the coarse rematch, so the far and redrawn planes on their samples, and the focus
        rematch): the sweep starts on the lines' thread when the first pass wants a
        rematch (``rematch``; nothing found, a lone step, steps that disagree) and runs
        while the rematch's matcher does; the first pass goes without it. Needs up in
        the camera: the rig's, or the image's vertical lines', or else the up the first
        pass found from the scene (without a rig, where its sigma is finite). Default on
        (issue 11; docs/benchmarks.md, "Twenty-third session" and "Twenty-fifth
        session").
    """

    backend: str = "opencv"
    max_disparity_px: int | None = None
    min_depth_m: float = 0.7
    method: str = "orientation"
    sgbm: OpenCVSGBMConfig = field(default_factory=OpenCVSGBMConfig)
    sgm: SGMConfig = field(default_factory=SGMConfig)
    fill: PlanarFillConfig = field(default_factory=PlanarFillConfig)
    cloud: CloudConfig = field(default_factory=CloudConfig)
    orientation: OrientationConfig = field(default_factory=OrientationConfig)
    contour: ContourConfig = field(default_factory=ContourConfig)
    terrain: TerrainConfig = field(default_factory=TerrainConfig)
    swing: SwingConfig = field(default_factory=SwingConfig)
    drift: DriftConfig = field(default_factory=DriftConfig)
    gravity: GravityConfig = field(default_factory=GravityConfig)
    # Stage 1 options (rectify/, stereo/vertical.py): issue 11.
    rectify_fov: str = "valid"
    vertical: VerticalAlignConfig = field(default_factory=VerticalAlignConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)  # issue 14
    vanishing: VerticalLinesConfig = field(default_factory=VerticalLinesConfig)  # issue 11
    rematch: bool = True  # issue 11
    rematch_sgbm: OpenCVSGBMConfig = field(default_factory=lambda: REMATCH_SGBM)
    rematch_coarse: bool = True  # issue 11
    rematch_focus: bool = False  # issue 11
    rematch_disagreeing: bool = True  # issue 11
    rematch_denoised: float = 3.0  # issue 11
    far_planes_sigmas: float = 1.1  # issue 11
    far_planes_wider_sigmas: float = 1.6  # issue 11
    far_planes_wider_max_deg: float = 40.0  # issue 11
    redraw_planes: int = 3  # issue 11
    agreed_lone_step: bool = True  # issue 11
    whole_box: bool = True  # issue 11
    corroborated_frame: bool = True  # issue 11
    floor_a_step_below: bool = True  # issue 11
    floor_below_nosing: bool = True  # issue 11
    floor_below_floorless: bool = True  # issue 11
    floor_below_keep_chain: bool = True  # issue 11
    bands: BandFillConfig = field(default_factory=BandFillConfig)  # issue 11

    def __post_init__(self) -> None:
        check_fields(self)
        mdp = self.max_disparity_px
        if mdp is not None and (isinstance(mdp, bool) or not isinstance(mdp, int)):
            raise ConfigError(f"max_disparity_px must be an integer or null, got {mdp!r}")
        if mdp is not None and mdp <= 0:
            # (the backend checks the rest, against the image: a multiple of 16 below its width)
            raise ConfigError(f"max_disparity_px must be positive (or null: from the calibration), got {mdp}")
        check_min(
            self, 0, "far_planes_sigmas", "far_planes_wider_sigmas", "redraw_planes", "rematch_denoised"
        )
        if self.rematch_denoised > MAX_STRENGTH_GREY:
            raise ConfigError(
                f"PipelineConfig.rematch_denoised must be at most {MAX_STRENGTH_GREY:g} grey levels "
                f"(about the noise's standard deviation; 0 turns it off), got {self.rematch_denoised}"
            )
        if self.far_planes_wider_sigmas > 0 and not (
            self.orientation.normal_agreement_deg <= self.far_planes_wider_max_deg < 45
        ):
            raise ConfigError(
                "far_planes_wider_max_deg must be at least orientation.normal_agreement_deg and below 45 "
                f"(a wider test lets every normal seed both families), got {self.far_planes_wider_max_deg}"
            )
        if self.rematch_sgbm.downsample != 1:
            raise ConfigError(
                "rematch_sgbm.downsample must be 1: the coarse rematch is rematch_sgbm at half size "
                "(rematch_coarse: true)"
            )
        if self.backend not in ("opencv", "sgm"):
            raise ConfigError(f"unknown backend '{self.backend}'; choose one of: opencv, sgm")
        if self.method not in PLANE_METHODS:
            raise ConfigError(f"unknown method '{self.method}'; choose one of: {', '.join(PLANE_METHODS)}")
        if not self.min_depth_m > 0:
            raise ConfigError(f"min_depth_m must be > 0, got {self.min_depth_m}")
        if self.rectify_fov not in RECTIFY_FOVS:
            choices = ", ".join(RECTIFY_FOVS)
            raise ConfigError(f"unknown rectify_fov '{self.rectify_fov}'; choose one of: {choices}")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PipelineConfig:
        """Build from a nested mapping (as loaded from YAML); unknown keys are errors."""
        if not isinstance(data, dict):
            raise ConfigError("pipeline config must be a mapping")
        kwargs: dict[str, Any] = {}
        nested = {f.name: f.type for f in dataclasses.fields(cls)}
        sub_types = {
            "sgbm": OpenCVSGBMConfig,
            "rematch_sgbm": OpenCVSGBMConfig,
            "sgm": SGMConfig,
            "fill": PlanarFillConfig,
            "cloud": CloudConfig,
            "orientation": OrientationConfig,
            "contour": ContourConfig,
            "terrain": TerrainConfig,
            "swing": SwingConfig,
            "drift": DriftConfig,
            "gravity": GravityConfig,
            "vertical": VerticalAlignConfig,
            "tracking": TrackingConfig,
            "vanishing": VerticalLinesConfig,
            "bands": BandFillConfig,
        }
        for key, value in data.items():
            if key not in nested:
                raise ConfigError(f"unknown pipeline config key '{key}'; known: {sorted(nested)}")
            if key in sub_types:
                sub = sub_types[key]
                known = {f.name for f in dataclasses.fields(sub)}
                if not isinstance(value, dict):
                    raise ConfigError(f"config '{key}' must be a mapping of {sorted(known)}")
                if not set(value) <= known:
                    raise ConfigError(
                        f"config '{key}': unknown keys {set(value) - known}; known: {sorted(known)}"
                    )
                try:
                    if key == "rematch_sgbm":  # its own defaults, with what the file changes
                        kwargs[key] = dataclasses.replace(REMATCH_SGBM, **value)
                    else:
                        kwargs[key] = sub(**value)
                except (TypeError, ValueError) as exc:  # ConfigError included: name the section
                    raise ConfigError(f"config '{key}': {exc}") from None
            else:
                kwargs[key] = value
        try:
            return cls(**kwargs)
        except ConfigError:
            raise
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"pipeline config: {exc}") from None

    @classmethod
    def from_yaml(cls, path: str | Path) -> PipelineConfig:
        from ..checks import load_yaml_file  # UTF-8, nesting depth, YAML errors: one message

        data = load_yaml_file(path, "config file")
        try:
            return cls.from_dict({} if data is None else data)
        except ConfigError as exc:
            raise ConfigError(f"config file {path}: {exc}") from None
