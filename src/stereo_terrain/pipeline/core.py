"""The orchestrator: :class:`Pipeline` runs the stages in order on each stereo pair."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any, NamedTuple

import numpy as np

from ..calibration import StereoCalibration
from ..cloud import GridSample, transform_sample
from ..drift import CorrectionUpdate, OnlineRectifier
from ..errors import ConfigError, InputError
from ..frames import Rig, Transform
from ..gravity import (
    GravityEstimate,
    SceneLines,
    combine_with_lines,
    estimate_up,
    levelling,
    refine_up_from_planes,
    scene_lines,
)
from ..planes.auto import combine_plane_sets
from ..planes.contour import extract_planes_contour
from ..planes.orientation import (
    PlaneSet,
    extract_planes_orientation,
    transform_planes,
)
from ..rectify import Rectification, RectifiedPair, compute_rectification, rectify
from ..stereo import DisparityBackend, check_max_disparity, default_max_disparity, make_backend
from ..stereo.bands import BandFillConfig, BandPlanes, sweep_bands
from ..stereo.blur import match_blur
from ..stereo.denoise import denoise_pair
from ..stereo.fill import FlatRegions, find_flat_regions
from ..stereo.vertical import VerticalOffset, align_vertical
from ..swing import plan_swing
from ..terrain import ImageLines, StairModel, StereoView, build_terrain, estimate_step_sigmas
from ..terrain.model import NONE
from .config import PipelineConfig
from .fill_steps import camera_sample, fill_faces, fill_faces_later, known_up
from .gravity_steps import (
    _gravity_report,
    _level_from_scene,
    _level_with_line_frame,
    _level_with_lines,
    _rig_check,
    origin_on_floor,
)
from .result import TerrainResult
from .second_opinions import (
    COARSE_NOTE,
    DENOISED_COARSE_NOTE,
    DENOISED_NOTE,
    FOCUS_NOTE,
    REMATCH_NOTE,
    Passes,
    agreed_lone_step,
    corroborated_frame,
    corroborated_up,
    far_planes,
    finer_lines_noted,
    floor_a_step_below,
    redrawn_planes,
    rematch_kept,
    scene_up,
    staircase_at_floor_edge,
    staircase_of_ends,
    staircase_of_finer_lines,
    staircase_of_lines,
    wants_rematch,
    whole_box,
)
from .threads import background, find_blas, one_blas_thread
from .warm_up import warm_up_kernels


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
        _check_arguments(calibration, rig, config)
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
        custom_backend = backend
        if backend is None:
            chosen = self.config.sgbm if self.config.backend == "opencv" else self.config.sgm
            options = dataclasses.asdict(chosen)
            backend = make_backend(self.config.backend, **options)
        self.backend = backend
        # Issue 11: a second matcher for frames in which the first finds nothing (only when
        # the config's own OpenCV matcher is the first: never behind a backend passed in).
        self._rematcher: DisparityBackend | None = None
        if custom_backend is None and self.config.backend == "opencv" and self.config.rematch:
            self._rematcher = make_backend("opencv", **dataclasses.asdict(self.config.rematch_sgbm))
        self._coarse_rematcher: DisparityBackend | None = None
        if self._rematcher is not None and self.config.rematch_coarse:
            coarse = dataclasses.replace(self.config.rematch_sgbm, downsample=2)
            self._coarse_rematcher = make_backend("opencv", **dataclasses.asdict(coarse))
        # The far planes (issue 11): the orientation method's normal tests only.
        self._far_planes_on = self.config.far_planes_sigmas > 0 and self.config.method == "orientation"
        # The redrawn planes (issue 11): the orientation method's random draws.
        self._redraw_on = self.config.redraw_planes > 0 and self.config.method == "orientation"
        # Rectified left camera -> yaw frame from the rig (None without one: the floor decides).
        self.T_yaw_camera_rect: Transform | None = (
            None if rig is None else rig.T_yaw_camera @ self.rectification.T_camera_rect
        )
        if warm_up:
            warm_up_kernels(
                self.config, with_rig=rig is not None, backend=None if backend is None else self.backend
            )
        find_blas()

    def reset_drift(self) -> None:
        """Forget what the online drift correction has seen and go back to the calibration's
        rectification (e.g. after a warm-up on a rendered pair)."""
        if self.rectifier is not None:
            self.rectifier.reset()
            self.rectification = self.rectifier.current
        self.last_correction = None

    def set_rig(self, rig: Rig | None) -> None:
        """Use ``rig`` from the next frame on (e.g. the body attitude from the state
        estimator); None: gravity from the scene from then on."""
        _check_arguments(self.calibration, rig, self.config)
        self.rig = rig
        self.T_yaw_camera_rect = None if rig is None else rig.T_yaw_camera @ self.rectification.T_camera_rect

    def run(
        self, left: np.ndarray, right: np.ndarray, *, rematch: bool = True, denoised: bool = True
    ) -> TerrainResult:
        """Process one raw stereo pair (grey or BGR uint8, the calibration's size).

        ``rematch``: False skips the second opinions for this frame (the rematch, the
        coarse, focus and denoised rematches, the far planes, the agreed lone step, the
        whole box, the redrawn planes and the staircase of the lines:
        ``PipelineConfig.rematch``, ``far_planes_sigmas``, ``agreed_lone_step``,
        ``whole_box``, ``redraw_planes``, ``rematch_denoised`` and
        ``TerrainConfig.lines_first_riser``; the live loop runs them on every other pair
        while they keep nothing). ``denoised``: False skips only the denoised opinions
        (the dearest; the live loop runs them on every ``LoopConfig.denoised_every``-th
        pair that runs the others while nothing is kept). On the main thread the
        process's BLAS is held to one thread while the frame runs (see
        :func:`~.threads.one_blas_thread`); the caller's setting is back afterwards."""
        with one_blas_thread():
            return self._run(left, right, rematch, denoised)

    def _run(
        self, left: np.ndarray, right: np.ndarray, rematch: bool = True, denoised: bool = True
    ) -> TerrainResult:
        t0 = time.perf_counter()
        pair = rectify(left, right, self.rectification)
        if self.rectifier is not None:
            self.last_correction = self.rectifier.update(pair)
            if self.last_correction.changed:  # re-rectify this frame with the corrected rig
                self.rectification = self.last_correction.rectification
                pair = rectify(left, right, self.rectification)
        pair, self.last_vertical = align_vertical(pair, self.config.vertical)  # residual vertical offset
        t1 = time.perf_counter()
        image_jobs = self._image_jobs(pair)
        result = self._from_pair(pair, self.backend, image_jobs, {"rectify": (t1 - t0) * 1000.0}, t1)
        tried = [("first matcher", result)]  # each pass's name and own result
        second = rematch and self._rematcher is not None
        if second and wants_rematch(result.terrain, self.config):
            # Nothing found, a lone step, or steps whose rises disagree: match the pair again
            # (issue 11; PipelineConfig.rematch, rematch_coarse, rematch_disagreeing).
            passes = [(self._rematcher, REMATCH_NOTE), (self._coarse_rematcher, COARSE_NOTE)]
            # The second opinions' passes get the band fill (PipelineConfig.bands)
            found = scene_up(result)  # without a rig, the band fill's up where the lines give none
            image_jobs = self._with_bands(pair, image_jobs, None if found is None else found[0])
            result = self._rematched(pair, image_jobs, result, tried, passes)
        if rematch and result.terrain.obstacle == NONE and self._far_planes_on:
            # No pass found an obstacle: their samples' planes with the far normal tests
            # widened, a second opinion too (issue 11; PipelineConfig.far_planes_sigmas).
            result = far_planes(tried, result, self.config)
        if rematch and result.terrain.obstacle == NONE and self.config.agreed_lone_step:
            # Still nothing: a lone step (a box) that two second opinions find alike
            # (issue 11; PipelineConfig.agreed_lone_step).
            result = agreed_lone_step(tried, result, self.config)
        if rematch and result.terrain.obstacle == NONE and self.config.whole_box:
            # Else a box that one second opinion sees whole (PipelineConfig.whole_box).
            result = whole_box(tried, result, self.config)
        if result is tried[0][1] and result.terrain.obstacle == NONE:
            result = corroborated_up(tried, result)
        if rematch and wants_rematch(result.terrain, self.config) and self._redraw_on and len(tried) > 1:
            # Still nothing, a lone step or steps that disagree: the last pass's samples with
            # other draws of the plane stage, in the frame kept (issue 11;
            # PipelineConfig.redraw_planes).
            result = redrawn_planes(tried, result, self.config)
        if second and self.config.rematch_focus and wants_rematch(result.terrain, self.config):
            # Every opinion so far leaves the frame wanting: where one camera's image is
            # blurrier, the pair once more with the two focused alike, and its own far
            # planes (issue 11; PipelineConfig.rematch_focus). After the others, so that it
            # changes nothing they found.
            left, right, sigma = match_blur(
                pair.left, pair.right, pair.rectification.valid_left, pair.rectification.valid_right
            )
            if left is not pair.left or right is not pair.right:
                side = "left" if sigma > 0 else "right"
                name, how = FOCUS_NOTE
                how = f"the {side} image blurred by {abs(sigma):.2f} px to the other's focus; {how}"
                focused = dataclasses.replace(pair, left=left, right=right)
                before = len(tried)
                result = self._rematched(focused, image_jobs, result, tried, [(self._rematcher, (name, how))])
                if result.terrain.obstacle == NONE and self._far_planes_on:
                    result = far_planes(tried[before:], result, self.config)
                if wants_rematch(result.terrain, self.config) and self._redraw_on:
                    result = redrawn_planes(tried[before:], result, self.config)
        denoise = second and denoised and self.config.rematch_denoised > 0
        if denoise and wants_rematch(result.terrain, self.config):
            # Still wanting: the pair with the sensor's noise taken out, matched again by the
            # rematch and the coarse rematch, then those passes' own far planes, lone step,
            # box (with a rig) and redrawn planes (issue 11; PipelineConfig.rematch_denoised).
            # Last, so that it changes nothing the others found (but a lone step or steps
            # that disagree, which a staircase of its own may replace).
            before = len(tried)
            result = self._denoised_opinions(pair, image_jobs, result, tried)
            if len(tried) > before and result.terrain.obstacle == NONE:
                # Still nothing: the up that most of all the passes corroborate, the
                # denoised ones' too (issue 11; corroborated_up asked again).
                first = dataclasses.replace(tried[0][1], timing_ms=result.timing_ms)
                result = corroborated_up(tried, first)
        if rematch and self.config.corroborated_frame and self.T_yaw_camera_rect is None:
            # Without a rig: an obstacle found in a pass's frame that the other passes do
            # not corroborate, found again in the frame they do (issue 11;
            # PipelineConfig.corroborated_frame).
            result = corroborated_frame(tried, result, self.config)
        finer_lines = None  # the frame's lines, where the full-size image's found the staircase
        if rematch:
            # Nothing found: the staircase whose first riser the image's lines show, where
            # the floor is known (issue 11; TerrainConfig.lines_first_riser). A second
            # opinion, the last: on wooden stairs whose other opinions were turned off it
            # put the staircase a riser's position off (tests/test_far_planes.py).
            result = staircase_of_lines(result, self.config)
            # Still nothing, the frame's lines found at half size (a rig's): the lines of the
            # full-size image (issue 11; VerticalLinesConfig.finer_scale).
            lines = None if image_jobs.lines is None else image_jobs.lines.result()
            nothing = result
            result = staircase_of_finer_lines(result, pair.left, lines, self.config)
            finer_lines = lines if result is not nothing else None
        # A staircase or a step: the staircase its risers' ends show, where it has more
        # steps and holds a riser the planes measured, or holds none and outweighs their
        # staircase (issue 11; TerrainConfig.ends_staircase, ends_over_planes).
        ended = staircase_of_ends(result, self.config)
        if len(ended.terrain.steps) <= len(result.terrain.steps):
            # Without a rig, a staircase whose "floor" is its first tread: found again with
            # the floor a rise lower, and its ends asked there (issue 11;
            # PipelineConfig.floor_a_step_below). Not where the ends found more steps from
            # the floor they were given: lowered, their heights would fit no pitch.
            lowered = floor_a_step_below(result, self.config)
            if lowered.terrain is not result.terrain:
                ended = staircase_of_ends(lowered, self.config)
        result = ended
        if rematch:
            # Still nothing: the staircase whose first riser stands where the floor the
            # matcher holds ends, in front of the lines on the floor (issue 11;
            # TerrainConfig.floor_edge_foot). After the ends: its foot is a grid row or so off.
            result = staircase_at_floor_edge(result, self.config)
        if finer_lines is not None:  # (the ends, asked in those lines, gave a note of their own)
            result = finer_lines_noted(result, finer_lines, self.config)
        result.timing_ms["total"] = (time.perf_counter() - t0) * 1000.0
        return result

    def _denoised_opinions(
        self, pair: RectifiedPair, jobs: _ImageJobs, result: TerrainResult, tried: Passes
    ) -> TerrainResult:
        """``result`` or what the second opinions make of ``pair`` denoised
        (``PipelineConfig.rematch_denoised``): the rematch's and the coarse rematch's passes,
        each kept as the coarse rematch's is (steps that agree:
        :func:`~.second_opinions.rematch_kept`), then, on those two passes only, the far
        planes, the lone step they agree on, with a rig a box one of them sees whole, and
        the redrawn planes, each where the frame still wants it as after the first passes.
        Without a rig the "ground" beyond a box is the floor the scene's own gravity chose,
        in a room as likely a table's top: there a denoised pass's box made the real
        Middlebury ``Playroom`` a false one (docs/benchmarks.md, "Thirtieth session"). A
        lone step that both denoised passes find alike is kept without a rig too: two
        passes agreeing is the stronger evidence, and none did so on the real rooms.
        ``timing_ms["denoise"]``: the time the denoising took. A result kept from a
        denoised pass carries the denoised pair as its ``rectified`` (as the focus
        rematch's carries its blurred one)."""
        t0 = time.perf_counter()
        quiet = denoise_pair(pair, self.config.rematch_denoised)
        denoise_ms = (time.perf_counter() - t0) * 1000.0
        before = len(tried)
        passes = [(self._rematcher, DENOISED_NOTE), (self._coarse_rematcher, DENOISED_COARSE_NOTE)]
        result = self._rematched(quiet, jobs, result, tried, passes)
        new = tried[before:]
        if result.terrain.obstacle == NONE and self._far_planes_on:
            result = far_planes(new, result, self.config)
        # (the lone step and the box look at the second opinions of a frame's passes, those
        # after its first: the first pass heads the list so that they see these two alone)
        if result.terrain.obstacle == NONE and self.config.agreed_lone_step:
            result = agreed_lone_step(tried[:1] + new, result, self.config)
        if result.terrain.obstacle == NONE and self.config.whole_box and self.T_yaw_camera_rect is not None:
            result = whole_box(tried[:1] + new, result, self.config)
        if wants_rematch(result.terrain, self.config) and self._redraw_on:
            result = redrawn_planes(new, result, self.config)
        result.timing_ms["denoise"] = denoise_ms
        return result

    def _rematched(
        self,
        pair: RectifiedPair,
        jobs: _ImageJobs,
        first: TerrainResult,
        tried: Passes,
        passes: list[tuple[DisparityBackend | None, tuple[str, str]]],
    ) -> TerrainResult:
        """``first`` or what the second opinions ``passes`` (matcher, and the name and how
        of the note) make of ``pair``: the rematch, then (with ``rematch_coarse``) the
        coarse rematch at half size; or the focus rematch alone; or the rematch and the
        coarse rematch of the denoised pair. Each runs while the
        result kept so far still wants one (:func:`~.second_opinions.wants_rematch`); each
        pass's name and own result are appended to ``tried``. A pass's staircase replaces
        the one kept as :func:`~.second_opinions.rematch_kept` decides.

        ``timing_ms["rematch"]`` is the time of every pass run (in the frame)."""
        t0 = time.perf_counter()
        result = first
        for matcher, (name, how) in passes:
            if matcher is None or not wants_rematch(result.terrain, self.config):
                break
            other = self._from_pair(pair, matcher, jobs, {}, time.perf_counter())
            tried.append((name, other))
            terrain = other.terrain
            better, why = rematch_kept(name, terrain, result.terrain, self.config)
            if better:
                timing = {**result.timing_ms, **{k: v for k, v in other.timing_ms.items() if k != "total"}}
                result = dataclasses.replace(
                    other,
                    terrain=dataclasses.replace(
                        terrain, note=f"{terrain.note}; found by the {name} ({why}; {how})"
                    ),
                    timing_ms=timing,
                    rematched=True,
                )
        # added to what earlier second opinions of the frame took (the focus and denoised
        # rematches)
        took = (time.perf_counter() - t0) * 1000.0
        result.timing_ms["rematch"] = first.timing_ms.get("rematch", 0.0) + took
        return result

    def _image_jobs(self, pair: RectifiedPair) -> _ImageJobs:
        """The work that needs only the rectified left image, started on the other core while
        the matcher runs (OpenCV releases the GIL; issue 13): the fill's regions, and the
        image's lines (without a rig, up from its vertical lines; the scene's horizontal
        direction for the Manhattan fill)."""
        regions = None
        if self.config.fill.enabled:
            regions = background().submit(
                find_flat_regions, pair.left, self.config.fill, pair.rectification.valid_left
            )
        lines_job = None
        want_up = self.T_yaw_camera_rect is None and self.config.vanishing.enabled
        want_horizontal = self.config.fill.enabled and self.config.fill.manhattan
        rig_up = None if self.T_yaw_camera_rect is None else self._rig_up_camera(self.T_yaw_camera_rect)
        if want_up or (want_horizontal and (rig_up is not None or self.config.vanishing.enabled)):
            lines_job = background().submit(
                scene_lines,
                pair.left,
                pair.rectification,
                self.config.vanishing,
                known_up=rig_up,
                want_up=want_up,
                want_horizontal=want_horizontal,
                prior_cone_deg=self.config.gravity.prior_cone_deg,
            )
        return _ImageJobs(regions, lines_job, rig_up, want_horizontal, None)

    def _with_bands(
        self, pair: RectifiedPair, jobs: _ImageJobs, scene_up: np.ndarray | None = None
    ) -> _ImageJobs:
        """``jobs`` with the band fill's sweep started on the lines' thread (after the lines;
        the caller's next matcher runs meanwhile), for the passes after the first
        (``PipelineConfig.bands``); ``jobs`` where it is off or there are no lines.
        ``scene_up``: the first pass's up from the scene (rectified camera), for a frame
        without a rig whose lines do not fix up."""
        if jobs.lines is None or not self.config.bands.enabled or jobs.bands is not None:
            return jobs
        job = background().submit(
            _band_planes, jobs.lines, pair, jobs.rig_up, self.max_disparity_px, self.config.bands, scene_up
        )
        return jobs._replace(bands=job)

    def _from_pair(
        self,
        pair: RectifiedPair,
        backend: DisparityBackend,
        jobs: _ImageJobs,
        timing: dict[str, float],
        t_start: float,
    ) -> TerrainResult:
        """Every stage after rectification, with ``backend`` as the matcher; ``timing`` gets
        each stage's milliseconds (from ``t_start``)."""
        t = t_start

        def lap(name: str) -> None:
            nonlocal t
            now = time.perf_counter()
            timing[name] = (now - t) * 1000.0
            t = now

        regions, lines_job, rig_up, want_horizontal, bands_job = jobs
        disp = matched = backend.compute(pair, self.max_disparity_px)
        faces = None
        if regions is not None:
            lines_found = None if lines_job is None else lines_job.result()
            flat = regions.result()
            faces = fill_faces(disp, pair, flat, lines_found, rig_up, want_horizontal, self.config)
            disp = faces.disparity
        # waited for after the matcher, which ran while the lines' thread swept the bands
        band_planes = None if bands_job is None else bands_job.result()
        if band_planes is not None:
            disp = band_planes.fill(disp)
        lap("disparity")
        cfg = self.config
        cam_sample = camera_sample(disp, cfg)
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
            T, source, before_planes = _level_from_scene(cam_sample, coarse, cfg)
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
            seen = lines_job.result()
            # with frame_at_border, the lines that run out of the view too
            segments = seen.every_segment if cfg.vanishing.frame_at_border else seen.segments
            framed = _level_with_line_frame(fine, before_planes, source, T, segments, pair, cfg)
            if framed is not None:
                fine, source = framed, "scene"
        if source == "scene" and fine.ok:
            # The last, small correction from the final planes (more of them, tighter).
            correction = levelling(fine.up)
            T = correction @ T
            planes = transform_planes(planes, correction, up=np.array([0.0, 0.0, 1.0]))
        levelled = source == "rig" or (source == "scene" and fine.ok)
        if faces is not None and faces.waited and levelled and cfg.fill.manhattan_after_gravity:
            assert lines_job is not None  # a Manhattan fill that waited had the lines
            # The Manhattan fill waited for up or a horizontal direction, which the frame now
            # has (the scene's up, or the rig's; its vertical planes): fill the faces and
            # find the planes again in the same frame (issue 11).
            refilled = fill_faces_later(matched, faces, pair, lines_job.result(), planes, T, cfg)
            if refilled is not None:
                disp = refilled if band_planes is None else band_planes.fill(refilled)
                cam_sample = camera_sample(disp, cfg)
                planes = self._extract_planes(transform_sample(cam_sample, T), pair.left)
        floor_known = source == "rig"
        if not floor_known:
            planes, T, floor_known = origin_on_floor(planes, T, cfg.gravity.min_floor_drop_m)
        if before_planes is None:
            before_planes = _rig_check(cam_sample, fine, prior, cfg.gravity, cfg.orientation.angle_tol_deg)
        gravity = _gravity_report(source, T, before_planes, fine, cfg.gravity, cfg.orientation.angle_tol_deg)
        image_lines = None
        if lines_job is not None and (cfg.terrain.nosing_steps or cfg.terrain.nosing_rise):
            image_lines = _image_lines(lines_job.result(), pair, T, cfg.terrain.plumb_edges)
        planes, terrain, choice = self._planes_and_terrain(planes, pair.left, lap, floor_known, image_lines)
        rect = pair.rectification  # issue 14: a 1-sigma for every step and the yaw
        terrain = estimate_step_sigmas(
            terrain, planes, focal_px=rect.focal_px, baseline_m=rect.baseline_m, config=cfg.terrain
        )
        swing = plan_swing(terrain, self.config.swing)
        lap("polytope")
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
            floor_known=floor_known,
            image_lines=image_lines,
        )

    def _rig_up_camera(self, rig_T: Transform) -> np.ndarray:
        """The rig's up in the rectified camera frame (read-only), computed once per rig
        transform rather than once per frame (issue 13)."""
        cached: tuple[Transform, np.ndarray] | None = getattr(self, "_rig_up_cache", None)
        if cached is None or cached[0] is not rig_T:
            up = rig_T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
            up.setflags(write=False)
            cached = self._rig_up_cache = (rig_T, up)
        return cached[1]

    def _extract_planes(self, samples: GridSample, image: np.ndarray) -> PlaneSet:
        """The primary plane set: the contour method's when asked for, else the
        orientation method's (``auto`` adds contour planes later, on the final frame)."""
        if self.config.method == "contour":
            return extract_planes_contour(samples, image, self.config.contour)
        return extract_planes_orientation(samples, self.config.orientation)

    def _planes_and_terrain(
        self,
        planes: PlaneSet,
        image: np.ndarray,
        lap: Callable[[str], None],
        floor_known: bool,
        lines: ImageLines | None = None,
    ) -> tuple[PlaneSet, StairModel, str]:
        """The terrain built on ``planes`` (from :meth:`_extract_planes`); ``floor_known``:
        the frame's origin is on the floor, ``lines``: the image's line segments
        (:func:`build_terrain`).

        ``auto`` also runs the contour method; the union (orientation planes plus the
        contour planes that are new) replaces the orientation planes only when its
        staircase has more steps, since extra planes can also only add steps.
        """
        cfg = self.config
        if cfg.method == "contour":
            lap("planes")
            terrain = build_terrain(planes, cfg.terrain, floor_known=floor_known, lines=lines)
            return planes, terrain, "contour requested"
        if cfg.method == "orientation":
            lap("planes")
            terrain = build_terrain(planes, cfg.terrain, floor_known=floor_known, lines=lines)
            return planes, terrain, "orientation requested (the default)"
        contour = extract_planes_contour(planes.samples, image, cfg.contour)
        combined, added = combine_plane_sets(planes, contour)
        lap("planes")
        terrain = build_terrain(planes, cfg.terrain, floor_known=floor_known, lines=lines)
        if added == 0:
            why = "orientation: the contour method found no plane the orientation method missed"
            return planes, terrain, why
        terrain_c = build_terrain(combined, cfg.terrain, floor_known=floor_known, lines=lines)
        if len(terrain_c.steps) > len(terrain.steps):
            why = (
                f"combined: {added} contour plane(s) added {len(terrain_c.steps) - len(terrain.steps)} "
                f"step(s) to the orientation method's {len(terrain.steps)}"
            )
            return combined, terrain_c, why
        return planes, terrain, f"orientation: the {added} new contour plane(s) added no step"


def _image_lines(lines: SceneLines, pair: RectifiedPair, T: Transform, plumb_edges: bool) -> ImageLines:
    """The lines' job's segments with the rectified left camera in the yaw frame ``T``
    (``T_yaw_camera_rect``), for the terrain stage's steps beyond the last (issue 11);
    ``plumb_edges``: ``TerrainConfig.plumb_edges``."""
    rect = pair.rectification
    h, w = pair.left.shape[:2]
    stereo = StereoView(
        pair.left,
        pair.right,
        rect.focal_px,
        rect.cx,
        rect.cy,
        rect.baseline_m,
        rect.doffs_px,
        T.matrix,
        rect.valid_left,
        rect.valid_right,
    )
    # The vertical edges (the risers' ends) take the shorter segments too
    # (VerticalLinesConfig.terrain_min_length_px).
    camera = (rect.focal_px, rect.cx, rect.cy, (w, h), T.matrix)
    return ImageLines(lines.segments, *camera, lines.at_border, pair.left, stereo, lines.short, plumb_edges)


def _band_planes(
    lines_job: Future[SceneLines],
    pair: RectifiedPair,
    rig_up: np.ndarray | None,
    max_disparity_px: int,
    config: BandFillConfig,
    scene_up: np.ndarray | None = None,
) -> BandPlanes | None:
    """The band fill's planes of ``pair`` (:func:`~stereo_terrain.stereo.bands.sweep_bands`)
    from the lines' job's segments, with the rig's up, else the image's vertical lines',
    else ``scene_up`` (the first pass's up from the scene's planes); None where none
    fixes up."""
    lines = lines_job.result()
    up = known_up(rig_up, lines)
    if up is None:
        up = scene_up
    if up is None:
        return None
    return sweep_bands(pair, lines.every_segment, up, max_disparity_px, config)


def _check_arguments(calibration: Any, rig: Any, config: Any) -> None:
    """A Pipeline's arguments are what it takes (a path or a mapping is a common slip: say
    how to make the object instead of failing on an attribute deep inside)."""
    if not isinstance(calibration, StereoCalibration):
        raise InputError(
            f"the calibration must be a StereoCalibration (read_calibration(path) reads one), "
            f"got {type(calibration).__name__}"
        )
    if rig is not None and not isinstance(rig, Rig):
        got = type(rig).__name__
        raise InputError(f"the rig must be a Rig or None (load_rig(path) reads one), got {got}")
    if config is not None and not isinstance(config, PipelineConfig):
        raise ConfigError(
            "the config must be a PipelineConfig (PipelineConfig.from_dict or from_yaml builds one), "
            f"got {type(config).__name__}"
        )


class _ImageJobs(NamedTuple):
    """A frame's work on the rectified left image alone (:meth:`Pipeline._image_jobs`)."""

    regions: Future[FlatRegions] | None
    lines: Future[SceneLines] | None
    rig_up: np.ndarray | None
    want_horizontal: bool
    bands: Future[BandPlanes | None] | None
