"""The orchestrator: config + stages -> :class:`TerrainResult` (the JSON contract).

::

    raw pair --rectify--> RectifiedPair --stereo--> DisparityMap --cloud--> PointCloud
      --(T_yaw_camera)--> PointCloud(yaw) --planes--> PlaneSet --terrain--> StairModel
      --swing--> SwingPlan

The gravity-aligned frame comes from the rig (``T_body_camera`` and body roll/pitch, the
paper's eq. 1). Without a rig "up" is found in the scene's plane families
(``gravity_source == "scene"``, :mod:`stereo_terrain.gravity`): the direction parallel to
the normals of its horizontal surfaces and orthogonal to those of its vertical ones. With
a rig the same estimate checks the rig.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
import os
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .calibration import StereoCalibration
from .checks import check_fields
from .cloud import (
    CloudConfig,
    GridSample,
    PointCloud,
    disparity_to_cloud,
    sample_disparity,
    transform_cloud,
    transform_sample,
)
from .drift import CorrectionUpdate, DriftConfig, OnlineRectifier
from .errors import ConfigError
from .frames import R_BODY_OPTICAL, Rig, Transform
from .gravity import (
    GravityConfig,
    GravityEstimate,
    GravityReport,
    angle_deg,
    estimate_up,
    floor_up,
    levelling,
    load_gravity_kernels,
    refine_up_from_planes,
    yaw_frame_from_up,
)
from .line_frame import up_from_lines_and_planes
from .planes.auto import combine_plane_sets
from .planes.contour import ContourConfig, extract_planes_contour
from .planes.orientation import (
    HORIZONTAL,
    VERTICAL,
    OrientationConfig,
    PlaneSet,
    extract_planes_orientation,
    transform_planes,
)
from .rectify import RECTIFY_FOVS, Rectification, RectifiedPair, compute_rectification, rectify
from .stereo import DisparityBackend, DisparityMap, check_max_disparity, default_max_disparity, make_backend
from .stereo._regions import warm_up as warm_up_fill_kernels
from .stereo.fill import FlatRegions, PlanarFillConfig, fill_planar_regions, find_flat_regions
from .stereo.manhattan import fill_manhattan_faces
from .stereo.manhattan import warm_up as warm_up_manhattan
from .stereo.opencv import OpenCVSGBMConfig
from .stereo.sgm import SGMConfig
from .stereo.vertical import VerticalAlignConfig, VerticalOffset, align_vertical
from .swing import SwingConfig, SwingPlan, plan_swing
from .terrain import StairModel, TerrainConfig, build_terrain, estimate_step_sigmas
from .tracking import TrackingConfig
from .vanishing import SceneLines, VerticalLinesConfig, combine_with_lines, horizontal_direction, scene_lines

RESULT_VERSION = 1

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
        (:mod:`stereo_terrain.vanishing`; ``vanishing.enabled``, on by default), combined
        with the planes' estimate (:func:`stereo_terrain.vanishing.combine_with_lines`).
    tracking : TrackingConfig
        The staircase tracked over frames by the live loop (``run``, ``replay``; issue
        14, :mod:`stereo_terrain.tracking`); ``tracking: {enabled: false}`` gives single
        frames. A single ``reconstruct`` does not use it.
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
    # Stage 1 options (rectify.py, stereo/vertical.py): issue 11.
    rectify_fov: str = "valid"
    vertical: VerticalAlignConfig = field(default_factory=VerticalAlignConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)  # issue 14
    vanishing: VerticalLinesConfig = field(default_factory=VerticalLinesConfig)  # issue 11

    def __post_init__(self) -> None:
        check_fields(self)
        mdp = self.max_disparity_px
        if mdp is not None and (isinstance(mdp, bool) or not isinstance(mdp, int)):
            raise ConfigError(f"max_disparity_px must be an integer or null, got {mdp!r}")
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
        from .checks import load_yaml_file  # UTF-8, nesting depth, YAML errors: one message

        data = load_yaml_file(path, "config file")
        try:
            return cls.from_dict({} if data is None else data)
        except ConfigError as exc:
            raise ConfigError(f"config file {path}: {exc}") from None


@dataclass(frozen=True)
class TerrainResult:
    """Everything one frame produced; :meth:`to_json_dict` gives the JSON contract.

    Attributes
    ----------
    terrain : StairModel
    swing : SwingPlan
    planes : PlaneSet (yaw frame)
    disparity : DisparityMap
    cloud : PointCloud (yaw frame), computed on first access
    rectified : RectifiedPair
    T_yaw_camera_rect : Transform
    gravity_source : str
        ``rig``, ``scene`` (no rig: up from the scene's plane families) or
        ``assumed-level`` (no rig and nothing in view fixes up: a level camera is assumed).
    gravity : GravityReport
        Its uncertainty, and with a rig how far the scene's own estimate is from it.
    timing_ms : dict of stage -> milliseconds
    plane_choice : str
        Why the planes are those of ``planes.method`` (``auto`` explains its pick).
    method_requested : str
    """

    terrain: StairModel
    swing: SwingPlan
    planes: PlaneSet = field(repr=False)
    disparity: DisparityMap = field(repr=False)
    rectified: RectifiedPair = field(repr=False)
    T_yaw_camera_rect: Transform = field(repr=False)
    gravity_source: str
    timing_ms: dict[str, float]
    gravity: GravityReport | None = field(default=None, repr=False)
    cloud_config: CloudConfig = field(default_factory=CloudConfig, repr=False)
    plane_choice: str = ""
    method_requested: str = "orientation"

    @functools.cached_property
    def cloud(self) -> PointCloud:
        """The full-resolution organized cloud in the yaw frame (computed on first use)."""
        return transform_cloud(disparity_to_cloud(self.disparity, self.cloud_config), self.T_yaw_camera_rect)

    def to_json_dict(self) -> dict[str, Any]:
        """The terrain result of CONVENTIONS.md (version 1)."""
        t = self.terrain

        def r(x: float | None, nd: int = 4) -> float | None:
            return None if x is None else round(float(x), nd)

        return {
            "version": RESULT_VERSION,
            "frame": "yaw",
            "obstacle": t.obstacle,
            "steps": [
                {
                    "rise": r(s.rise_m),
                    "run": r(s.run_m),
                    "distance": r(s.distance_m),
                    "width": r(s.width_m),
                    "rise_inferred": s.rise_inferred,
                    # issue 14: 1-sigma of each (null where the value is null or unknown)
                    "rise_sigma": _sigma(s.rise_sigma_m),
                    "run_sigma": _sigma(s.run_sigma_m),
                    "distance_sigma": _sigma(s.distance_sigma_m),
                    "width_sigma": _sigma(s.width_sigma_m),
                }
                for s in t.steps
            ],
            "yaw": r(t.yaw_rad),
            "yaw_sigma": _sigma(t.yaw_sigma_rad, 5),
            "planes": [
                {
                    "normal": [round(float(v), 5) for v in seg.plane.normal],
                    "offset": r(seg.plane.offset),
                    "kind": seg.kind,
                    "inliers": int(seg.count),
                    "rms": r(seg.rms_m, 5),
                }
                for seg in self.planes.segments
            ],
            "polytope": {
                "vertices": [[round(float(c), 4) for c in p] for p in t.polytope.vertices],
                "faces": [list(f) for f in t.polytope.faces],
            },
            "swing": {
                "height": r(self.swing.height_m),
                "trigger_distance": r(self.swing.trigger_distance_m),
                "traversable": self.swing.traversable,
            },
            "timing_ms": {k: round(v, 2) for k, v in self.timing_ms.items()},
            "gravity_source": self.gravity_source,
            "gravity": None if self.gravity is None else self.gravity.to_json_dict(),
            "note": t.note,
            "plane_stage": {
                "method_requested": self.method_requested,
                "method_used": self.planes.method,
                "reason": self.plane_choice,
                "stop_reason": self.planes.stop_reason,
                "parameters": self.planes.parameters,
            },
        }


def _sigma(x: float | None, nd: int = 4) -> float | None:
    """A 1-sigma for the JSON result: None when unknown (None or NaN), never below the
    rounding."""
    if x is None or not math.isfinite(x):
        return None
    return max(round(float(x), nd), 10.0**-nd)


class Pipeline:
    """Runs every stage on stereo pairs from one calibrated rig.

    Parameters
    ----------
    calibration : StereoCalibration
    rig : Rig, optional
        Mounting and body attitude; without it up comes from the scene (its level and
        upright planes and lines) and the result says ``gravity_source: "scene"``.
    config : PipelineConfig, optional

    backend : DisparityBackend, optional
        A disparity engine to use instead of the config's.
    warm_up : bool
        Load (or compile) the compiled kernels the configured stages use before the first
        frame, so that it costs about what a steady one does (:func:`warm_up_kernels`).

    Examples
    --------
    >>> from stereo_terrain.synthetic import default_scene_spec, render_scene
    >>> scene = render_scene(default_scene_spec())
    >>> result = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right)
    >>> result.terrain.obstacle
    'stairs'
    """

    def __init__(
        self,
        calibration: StereoCalibration,
        rig: Rig | None = None,
        config: PipelineConfig | None = None,
        *,
        backend: DisparityBackend | None = None,
        warm_up: bool = True,
    ) -> None:
        self.config = config or PipelineConfig()
        self.calibration = calibration
        self.rig = rig
        self.rectification: Rectification = compute_rectification(calibration, fov=self.config.rectify_fov)
        # Online drift correction (opt-in): owns the rectification from here on.
        self.rectifier: OnlineRectifier | None = (
            OnlineRectifier(self.rectification, self.config.drift) if self.config.drift.online else None
        )
        self.last_correction: CorrectionUpdate | None = None
        self.last_vertical: VerticalOffset | None = None  # stereo/vertical.py, last frame
        if self.config.max_disparity_px is not None:
            width = self.rectification.image_size[0]  # rectified (larger with rectify_fov="keep")
            self.max_disparity_px = check_max_disparity(self.config.max_disparity_px, width)
        else:
            self.max_disparity_px = default_max_disparity(self.rectification, self.config.min_depth_m)
        if backend is None:
            chosen = self.config.sgbm if self.config.backend == "opencv" else self.config.sgm
            options = dataclasses.asdict(chosen)
            backend = make_backend(self.config.backend, **options)
        self.backend = backend
        # Rectified left camera -> yaw frame from the rig (None without one: the floor decides).
        self.T_yaw_camera_rect: Transform | None = (
            None if rig is None else rig.T_yaw_camera @ self.rectification.T_camera_rect
        )
        if warm_up:
            warm_up_kernels(
                self.config, with_rig=rig is not None, backend=None if backend is None else self.backend
            )

    def reset_drift(self) -> None:
        """Forget what the online drift correction has seen and go back to the calibration's
        rectification (e.g. after a warm-up on a rendered pair)."""
        if self.rectifier is not None:
            self.rectifier.reset()
            self.rectification = self.rectifier.current
        self.last_correction = None

    def set_rig(self, rig: Rig) -> None:
        """Use ``rig`` from the next frame on (e.g. the body attitude from the state estimator)."""
        self.rig = rig
        self.T_yaw_camera_rect = rig.T_yaw_camera @ self.rectification.T_camera_rect

    def run(self, left: np.ndarray, right: np.ndarray) -> TerrainResult:
        """Process one raw stereo pair (grey or BGR uint8, the calibration's size)."""
        timing: dict[str, float] = {}
        t0 = t = time.perf_counter()

        def lap(name: str) -> None:
            nonlocal t
            now = time.perf_counter()
            timing[name] = (now - t) * 1000.0
            t = now

        pair = rectify(left, right, self.rectification)
        if self.rectifier is not None:
            self.last_correction = self.rectifier.update(pair)
            if self.last_correction.changed:  # re-rectify this frame with the corrected rig
                self.rectification = self.last_correction.rectification
                pair = rectify(left, right, self.rectification)
        pair, self.last_vertical = align_vertical(pair, self.config.vertical)  # residual vertical offset
        lap("rectify")
        regions = None
        if self.config.fill.enabled:
            # The fill's regions need only the left image: found on another core while the
            # matcher runs (OpenCV releases the GIL; issue 13).
            regions = _background().submit(
                find_flat_regions, pair.left, self.config.fill, pair.rectification.valid_left
            )
        lines_job = None
        want_up = self.T_yaw_camera_rect is None and self.config.vanishing.enabled
        want_horizontal = self.config.fill.enabled and self.config.fill.manhattan
        rig_up = None if self.T_yaw_camera_rect is None else self._rig_up_camera(self.T_yaw_camera_rect)
        if want_up or (want_horizontal and (rig_up is not None or self.config.vanishing.enabled)):
            # Image only, so found on the other core while the matcher runs, as the fill's
            # regions are: without a rig, up from the image's vertical lines; and the
            # scene's horizontal direction for the Manhattan fill.
            lines_job = _background().submit(
                scene_lines,
                pair.left,
                pair.rectification,
                self.config.vanishing,
                known_up=rig_up,
                want_up=want_up,
                want_horizontal=want_horizontal,
                prior_cone_deg=self.config.gravity.prior_cone_deg,
            )
        disp = self.backend.compute(pair, self.max_disparity_px)
        if regions is not None:
            disp = self._fill(disp, pair, regions.result(), lines_job, rig_up, want_horizontal)
        lap("disparity")
        cfg = self.config
        cam_sample = sample_disparity(
            disp, _identity_camera_rect(), cfg.cloud, target_points=cfg.orientation.target_points
        )
        lap("cloud")
        rig_T = self.T_yaw_camera_rect
        prior = rig_up  # the rig's up in the camera, as the lines' job had it
        lines: GravityEstimate | None = None  # up from the image's vertical lines (no rig)
        before_planes: GravityEstimate | None
        if rig_T is not None:
            # The local normals' estimate only checks the rig, and is needed only when the
            # planes do not settle the check (_rig_check, after the planes; issue 13).
            T, source, before_planes = rig_T, "rig", None
        else:  # before_planes: what levelled the frame (its up is in the start's frame)
            coarse = estimate_up(cam_sample, cfg.gravity, prior_up=prior)
            T, source, before_planes = self._level_from_scene(cam_sample, coarse)
            lines = None if lines_job is None else lines_job.result().up
            if lines is not None and lines.ok:
                T, source, before_planes = _level_with_lines(
                    T, source, before_planes, lines, cfg.vanishing.overrule_planes
                )
        lap("gravity")
        samples = transform_sample(cam_sample, T)
        planes = self._extract_planes(samples, pair.left)
        fine = refine_up_from_planes(planes, cfg.gravity)
        if lines is not None and lines.ok:
            # The final planes' up and the lines' (in the same, levelled frame).
            fine = combine_with_lines(
                fine,
                dataclasses.replace(lines, up=T.apply_vectors(lines.up), frame=fine.frame),
                overrule=cfg.vanishing.overrule_planes,
            )
        if rig_T is None and lines_job is not None and cfg.vanishing.frame:
            segments = lines_job.result().segments
            framed = _level_with_line_frame(fine, before_planes, source, T, segments, pair, cfg)
            if framed is not None:
                fine, source = framed, "scene"
        if source == "scene" and fine.ok:
            # The last, small correction from the final planes (more of them, tighter).
            correction = levelling(fine.up)
            T = correction @ T
            planes = transform_planes(planes, correction, up=np.array([0.0, 0.0, 1.0]))
        floor_known = source == "rig"
        if not floor_known:
            planes, T, floor_known = _origin_on_floor(planes, T, cfg.gravity.min_floor_drop_m)
        if before_planes is None:
            before_planes = _rig_check(cam_sample, fine, prior, cfg.gravity, cfg.orientation.angle_tol_deg)
        gravity = _gravity_report(source, T, before_planes, fine, cfg.gravity, cfg.orientation.angle_tol_deg)
        planes, terrain, choice = self._planes_and_terrain(planes, pair.left, lap, floor_known)
        rect = pair.rectification  # issue 14: a 1-sigma for every step and the yaw
        terrain = estimate_step_sigmas(
            terrain, planes, focal_px=rect.focal_px, baseline_m=rect.baseline_m, config=cfg.terrain
        )
        swing = plan_swing(terrain, self.config.swing)
        lap("polytope")
        timing["total"] = (time.perf_counter() - t0) * 1000.0
        return TerrainResult(
            terrain,
            swing,
            planes,
            disp,
            pair,
            T,
            source,
            timing,
            gravity,
            self.config.cloud,
            choice,
            self.config.method,
        )

    def _fill(
        self,
        disp: DisparityMap,
        pair: RectifiedPair,
        flat: FlatRegions,
        lines_job: Future[SceneLines] | None,
        rig_up: np.ndarray | None,
        manhattan: bool,
    ) -> DisparityMap:
        """Texture-poor faces: the planar fill (disparity from their outline, see
        stereo/fill.py), then the Manhattan fill (faces with one end in view: planes of the
        scene's three directions, see stereo/manhattan.py) when up and a horizontal
        direction are known: up from the rig, else from the image's vertical lines, else
        (they do not fix it) a first estimate from the planar-filled disparity's planes."""
        cfg = self.config
        occluded: list[int] = []
        values, filled = fill_planar_regions(
            disp.disparity,
            pair.left,
            cfg.fill,
            max_disparity_px=disp.max_disparity_px,
            valid=pair.rectification.valid_left,
            regions=flat,
            occluded=occluded,
        )
        found = None if lines_job is None else lines_job.result()
        if manhattan and found is not None:
            up, horizontal = rig_up, found.horizontal
            if up is None and found.up is not None and found.up.ok:
                up = found.up.up
            elif up is None:
                first = sample_disparity(
                    dataclasses.replace(disp, disparity=values, filled=filled),
                    _identity_camera_rect(),
                    cfg.cloud,
                    target_points=cfg.orientation.target_points,
                )
                coarse = estimate_up(first, cfg.gravity)
                if coarse.ok and coarse.sigma_deg <= cfg.fill.manhattan_max_up_sigma_deg:
                    up = coarse.up
                    horizontal = horizontal_direction(found.segments, pair.rectification, up, cfg.vanishing)
            if up is not None and horizontal is not None:
                values, filled = fill_manhattan_faces(
                    disp.disparity,
                    values,
                    filled,
                    flat.without(occluded) if occluded else flat,  # an occluder's edge holds them
                    pair.left,
                    pair.rectification,
                    up,
                    horizontal,
                    cfg.fill,
                    max_disparity_px=disp.max_disparity_px,
                )
        return dataclasses.replace(disp, disparity=values, filled=filled)

    def _rig_up_camera(self, rig_T: Transform) -> np.ndarray:
        """The rig's up in the rectified camera frame (read-only), computed once per rig
        transform rather than once per frame (issue 13)."""
        cached: tuple[Transform, np.ndarray] | None = getattr(self, "_rig_up_cache", None)
        if cached is None or cached[0] is not rig_T:
            up = rig_T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
            up.setflags(write=False)
            cached = self._rig_up_cache = (rig_T, up)
        return cached[1]

    def _level_from_scene(
        self, cam_sample: GridSample, coarse: GravityEstimate
    ) -> tuple[Transform, str, GravityEstimate]:
        """``T_yaw_camera_rect``, its source and the estimate behind it, without a rig.

        Two starts: the local normals' estimate (``coarse``) and the floor's normal
        (:func:`floor_up`: a plane fitted to points, exact where normals are noisy but
        blind without a floor). From each, planes are extracted with a wide orientation
        tolerance (``gravity.levelling_tol_deg``) and their normals, fitted to many points
        each, level the frame (:func:`refine_up_from_planes`). The start whose levelled
        frame puts most samples on horizontal and vertical planes wins (Manhattan
        structure). With neither, a level camera is assumed.
        """
        cfg = self.config
        starts = [coarse.up] if coarse.ok else []
        floor = floor_up(cam_sample)
        if floor is not None and coarse.ok and angle_deg(floor, coarse.up) < cfg.gravity.corroborated_deg:
            # Two independent estimates (local normals, the floor's points) agree: the plane
            # stage's own tolerance covers what is left; no levelling pass needed.
            return yaw_frame_from_up(coarse.up, "camera_rect"), "scene", coarse
        if floor is not None:
            starts.append(floor)
        if not starts:
            return (
                Transform.from_rt(R_BODY_OPTICAL, np.zeros(3), "yaw", "camera_rect"),
                "assumed-level",
                coarse,
            )
        wide = dataclasses.replace(
            cfg.orientation, angle_tol_deg=max(cfg.orientation.angle_tol_deg, cfg.gravity.levelling_tol_deg)
        )
        best: tuple[int, Transform, GravityEstimate] | None = None
        for up in starts:
            T = yaw_frame_from_up(up, "camera_rect")
            planes = extract_planes_orientation(transform_sample(cam_sample, T), wide)
            fine = refine_up_from_planes(planes, cfg.gravity)
            explained = sum(s.count for s in planes.segments if s.kind in (HORIZONTAL, VERTICAL))
            if fine.ok:
                T = levelling(fine.up) @ T
                why = fine
            elif coarse.ok and up is coarse.up:
                why = coarse
            else:  # sigma unknown: a floor that no other plane confirmed
                why = GravityEstimate(up, "camera_rect", math.inf, True, reason="the floor plane alone")
            if best is None or explained > best[0]:
                best = (explained, T, why)
        assert best is not None
        return best[1], "scene", best[2]

    def _extract_planes(self, samples: GridSample, image: np.ndarray) -> PlaneSet:
        """The primary plane set: the contour method's when asked for, else the
        orientation method's (``auto`` adds contour planes later, on the final frame)."""
        if self.config.method == "contour":
            return extract_planes_contour(samples, image, self.config.contour)
        return extract_planes_orientation(samples, self.config.orientation)

    def _planes_and_terrain(
        self, planes: PlaneSet, image: np.ndarray, lap: Callable[[str], None], floor_known: bool
    ) -> tuple[PlaneSet, StairModel, str]:
        """The terrain built on ``planes`` (from :meth:`_extract_planes`); ``floor_known``:
        the frame's origin is on the floor (:func:`build_terrain`).

        ``auto`` also runs the contour method; the union (orientation planes plus the
        contour planes that are new) replaces the orientation planes only when its
        staircase has more steps, since extra planes can also only add steps.
        """
        cfg = self.config
        if cfg.method == "contour":
            lap("planes")
            return planes, build_terrain(planes, cfg.terrain, floor_known=floor_known), "contour requested"
        if cfg.method == "orientation":
            lap("planes")
            terrain = build_terrain(planes, cfg.terrain, floor_known=floor_known)
            return planes, terrain, "orientation requested (the default)"
        contour = extract_planes_contour(planes.samples, image, cfg.contour)
        combined, added = combine_plane_sets(planes, contour)
        lap("planes")
        terrain = build_terrain(planes, cfg.terrain, floor_known=floor_known)
        if added == 0:
            why = "orientation: the contour method found no plane the orientation method missed"
            return planes, terrain, why
        terrain_c = build_terrain(combined, cfg.terrain, floor_known=floor_known)
        if len(terrain_c.steps) > len(terrain.steps):
            why = (
                f"combined: {added} contour plane(s) added {len(terrain_c.steps) - len(terrain.steps)} "
                f"step(s) to the orientation method's {len(terrain.steps)}"
            )
            return combined, terrain_c, why
        return planes, terrain, f"orientation: the {added} new contour plane(s) added no step"


@functools.cache
def _identity_camera_rect() -> Transform:
    """The identity of ``camera_rect``, built once (a Transform checks its matrix when
    built: issue 13)."""
    return Transform.identity("camera_rect")


_BACKGROUND: dict[int, ThreadPoolExecutor] = {}


def _background() -> ThreadPoolExecutor:
    """The process's one worker thread for work that overlaps the disparity matcher (shared
    by every pipeline, so that many pipelines do not leave many idle threads). Keyed by
    process id: a child forked after a frame has no thread behind its parent's executor,
    and would wait on it forever."""
    pid = os.getpid()
    if pid not in _BACKGROUND:
        _BACKGROUND.clear()
        _BACKGROUND[pid] = ThreadPoolExecutor(max_workers=1, thread_name_prefix="stereo-terrain")
    return _BACKGROUND[pid]


#: Configurations already warmed up in this process (see :func:`warm_up_kernels`).
_WARMED: set[tuple[Any, ...]] = set()
#: Size of the warm-up pair (pixels) and its rig: a level camera 0.5 m above the floor.
_WARM_SIZE, _WARM_FOCAL_PX, _WARM_BASELINE_M, _WARM_HEIGHT_M = (160, 120), 100.0, 0.1, 0.5


def _warm_up_scene() -> tuple[StereoCalibration, Rig, np.ndarray, np.ndarray]:
    """A tiny ideal rig looking at two steps, and its pair: a textured image warped by the
    scene's disparity, with an untextured face for the planar fill. Only its shape
    matters (every stage must find something to work on), not its accuracy."""
    w, h = _WARM_SIZE
    f, B, cam_h = _WARM_FOCAL_PX, _WARM_BASELINE_M, _WARM_HEIGHT_M
    K = np.array([[f, 0.0, w / 2], [0.0, f, h / 2], [0.0, 0.0, 1.0]])
    calib = StereoCalibration(
        K, np.zeros(5), K.copy(), np.zeros(5), np.eye(3), np.array([-B, 0.0, 0.0]), (w, h)
    )
    T_body_camera = Transform.from_rt(R_BODY_OPTICAL, [0.0, 0.0, cam_h], "body", "camera")
    # Depth of each pixel: floor, two 0.2 m steps (risers at 1.0 and 1.3 m), a wall at 1.6 m.
    ray_down = (np.arange(h, dtype=np.float64)[:, None] - h / 2 + 0.5) / f  # y / Z along each row
    depth = np.full((h, 1), 1.6)
    for riser_m, top_m in ((1.3, 2 * 0.2), (1.0, 0.2), (np.inf, 0.0)):  # far to near
        with np.errstate(divide="ignore"):
            on_top = np.where(ray_down > 0, (cam_h - top_m) / ray_down, np.inf)  # this level's floor
        hits_riser = (ray_down * riser_m <= cam_h - top_m + 0.2) if np.isfinite(riser_m) else True
        level = np.where(on_top < riser_m, on_top, riser_m)
        depth = np.where((on_top < depth) | (hits_riser & (level < depth)), np.minimum(level, depth), depth)
    disparity = np.broadcast_to(f * B / depth, (h, w)).astype(np.float32)
    rng = np.random.default_rng(0)
    left = cv2.GaussianBlur(rng.integers(0, 256, (h, w)).astype(np.uint8), (3, 3), 0.8)
    left[h // 2 + 22 : h // 2 + 36, w // 4 : 3 * w // 4] = 128  # an untextured riser face
    xs = np.arange(w, dtype=np.float32)[None, :] + disparity  # right(x) = left(x + d)
    ys = np.broadcast_to(np.arange(h, dtype=np.float32)[:, None], (h, w))
    right = cv2.remap(left, np.ascontiguousarray(xs), np.ascontiguousarray(ys), cv2.INTER_LINEAR)
    return calib, Rig(T_body_camera), left, right


def warm_up_kernels(
    config: PipelineConfig, *, with_rig: bool = True, backend: DisparityBackend | None = None
) -> None:
    """Run the pipeline of ``config`` once on a tiny rendered-by-warping pair, so that every
    compiled (Numba) kernel its stages use is loaded from the cache (or compiled) now rather
    than in the first real frame. Once per process and configuration of the compiled
    stages (backend and its device, plane method, fill, with or without a rig); a few
    milliseconds when already cached on disk."""
    key = (
        config.backend,
        getattr(config.sgm, "device", None) if config.backend == "sgm" else None,
        config.method,
        config.fill.enabled,
        config.fill.texture,
        config.fill.manhattan,
        with_rig,
        None if backend is None else type(backend).__name__,
    )
    if key in _WARMED:
        return
    calib, rig, left, right = _warm_up_scene()
    warm_config = dataclasses.replace(
        config,
        max_disparity_px=None,
        drift=dataclasses.replace(config.drift, online=False),
        rectify_fov="valid",
    )
    try:
        pipeline = Pipeline(calib, rig if with_rig else None, warm_config, backend=backend, warm_up=False)
        pipeline.run(left, right)
        load_gravity_kernels()  # the rig check's, which a rig that agrees with the pair skips
        if config.fill.enabled:
            warm_up_fill_kernels()  # the planar fill's, for frames that have a region
            if config.fill.manhattan:
                warm_up_manhattan()
    except Exception:  # an optimisation only: a config the tiny pair does not suit runs cold
        logging.getLogger(__name__).debug("kernel warm-up skipped", exc_info=True)
    _WARMED.add(key)


def _rig_check(
    cam_sample: GridSample,
    fine: GravityEstimate,
    rig_up: np.ndarray | None,
    config: GravityConfig,
    orientation_tol_deg: float,
) -> GravityEstimate:
    """With a rig, the local normals' estimate of up (camera frame) that checks it, or a
    placeholder when the planes settle the check alone.

    The planes were extracted in the rig's frame: when their up (``fine``) is sure and
    within ``rig_tolerance_deg`` of the rig's, the rig is not off by more than the
    orientation tolerance (a rig that far off leaves the planes of at most one family
    within the tolerance, and one family does not fix up), so the local normals are not
    estimated (issue 13: about 2 ms a frame). :func:`_gravity_report` then reports the
    planes' estimate; before, it reported the local normals' where they put the rig more
    than the orientation tolerance away (on renders with their true rig, 13 of 120 such
    reports were false alarms of the coarse estimate). Otherwise a coarse estimate, with
    ``rig_check_hypotheses`` scored on half the points (it only has to catch a rig off by
    more than the orientation tolerance)."""
    if fine.ok and angle_deg(fine.up, [0.0, 0.0, 1.0]) <= min(config.rig_tolerance_deg, orientation_tol_deg):
        return GravityEstimate(np.full(3, np.nan), "camera_rect", math.inf, False, reason="the planes agree")
    cheap = dataclasses.replace(
        config, hypotheses=config.rig_check_hypotheses, score_points=max(1, config.score_points // 2)
    )
    return estimate_up(cam_sample, cheap, prior_up=rig_up)


def _origin_on_floor(planes: PlaneSet, T: Transform, min_drop_m: float) -> tuple[PlaneSet, Transform, bool]:
    """Put the yaw frame's origin on the floor below the camera (CONVENTIONS: a rig off a
    robot has its body origin on the ground below the left camera). The floor is the lowest
    large horizontal plane (a quarter of the largest one's inliers or more) at least
    ``min_drop_m`` below the camera; with none, the origin stays at the camera. The flag
    says whether a floor was found."""
    P = planes.samples.points
    flat = [s for s in planes.segments if s.kind == HORIZONTAL]
    cam_z = float(planes.camera_position[2])
    if not flat:
        return planes, T, False
    biggest = max(s.count for s in flat)
    heights = [float(np.median(P[s.indices, 2])) for s in flat if s.count >= 0.25 * biggest]
    below = [z for z in heights if z <= cam_z - min_drop_m]
    if not below:
        return planes, T, False
    shift = Transform.from_rt(np.eye(3), [0.0, 0.0, -min(below)], "yaw", "yaw")
    return transform_planes(planes, shift), shift @ T, True


def _level_with_lines(
    T: Transform, source: str, before: GravityEstimate, lines: GravityEstimate, overrule: bool
) -> tuple[Transform, str, GravityEstimate]:
    """``T_yaw_camera_rect`` levelled again with the up of the image's vertical lines
    (:func:`combine_with_lines` of the planes' start and the lines), before the planes are
    extracted in it: where the lines fill in for a start without a sigma (or, with
    ``vanishing.overrule_planes``, overrule one that a junk plane tilted), the plane stage
    then classifies the faces in the lines' frame."""
    start_up = T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
    start = GravityEstimate(
        start_up, "camera_rect", before.sigma_deg, source == "scene", reason=before.reason
    )
    both = combine_with_lines(start, lines, overrule=overrule)
    return levelling(T.apply_vectors(both.up)) @ T, "scene", both


def _level_with_line_frame(
    fine: GravityEstimate,
    before: GravityEstimate | None,
    source: str,
    T: Transform,
    segments: np.ndarray,
    pair: RectifiedPair,
    config: PipelineConfig,
) -> GravityEstimate | None:
    """Without a rig, where the scene's up so far (the final planes', else the one that
    levelled the frame) is less certain than ``vanishing.frame_above_deg``: up from the
    Manhattan frame of all the image's line segments (:func:`up_from_lines_and_planes`),
    with that up as its prior (the camera's up where there is none), in ``fine``'s frame. None
    where the planes are sure enough or the lines do not fix up."""
    v = config.vanishing
    prior, width = None, math.inf
    if fine.ok:
        prior, width = T.inverse().apply_vectors(fine.up), fine.sigma_deg
    elif source == "scene" and before is not None and before.ok and math.isfinite(before.sigma_deg):
        prior, width = T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0])), before.sigma_deg
    if width <= v.frame_above_deg:
        return None
    found = up_from_lines_and_planes(
        segments,
        pair.rectification,
        prior,
        width,
        v,
        prior_cone_deg=config.gravity.prior_cone_deg,
        unsure_max_sigma_deg=config.gravity.max_sigma_deg,
        overrule=v.overrule_planes,
    )
    if not found.ok:
        return None
    why = f"{fine.reason}, then {found.reason}" if fine.ok else found.reason
    return dataclasses.replace(
        found,
        up=T.apply_vectors(found.up),
        frame=fine.frame,
        horizontal_fraction=fine.horizontal_fraction,
        reason=why,
    )


def _gravity_report(
    source: str,
    T: Transform,
    coarse: GravityEstimate,
    fine: GravityEstimate,
    config: GravityConfig,
    orientation_tol_deg: float,
) -> GravityReport:
    """What the result says about gravity: where it came from, how sure, and with a rig
    how far the scene's own estimate is from it (the planes' estimate when the rig is close
    enough for the planes to have been found, else the local normals').

    ``coarse`` is, with a rig, the local normals' estimate in the camera frame; without
    one, the estimate that levelled the frame (only its sigma and reason are used).
    """
    up_cam = T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
    if source == "rig":
        # Planes were found in the rig's frame: the fine estimate measures small
        # disagreements exactly; the coarse one (independent of the rig) the large ones.
        far = coarse.ok and angle_deg(coarse.up, up_cam) > orientation_tol_deg
        if fine.ok and not far:
            angle, sigma = angle_deg(fine.up, [0.0, 0.0, 1.0]), fine.sigma_deg
        elif coarse.ok:
            angle, sigma = angle_deg(coarse.up, up_cam), coarse.sigma_deg
        else:
            return GravityReport(source, up_cam, None, None, "the scene does not fix up: rig not checked")
        if angle > config.rig_tolerance_deg:
            note = f"the scene's up is {angle:.1f} deg from the rig's (check the rig file or the IMU)"
        else:
            note = f"the scene agrees with the rig within {config.rig_tolerance_deg:g} deg"
        return GravityReport(source, up_cam, None, angle, note, sigma)
    if source == "scene":
        best = fine if fine.ok else coarse
        return GravityReport(source, up_cam, best.sigma_deg, None, best.reason)
    return GravityReport(source, up_cam, None, None, coarse.reason)
