"""The second opinions of the frame without a rig: the up most passes corroborate
(:func:`corroborated_up`, :func:`corroborated_frame`) and the floor a step below a first
tread taken for it (:func:`floor_a_step_below`)."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ...cloud import GridSample, transform_sample
from ...frames import Transform
from ...gravity import angle_deg
from ...planes.orientation import OrientationConfig, extract_planes_orientation, transform_planes
from ...swing import plan_swing
from ...terrain import (
    ImageLines,
    build_terrain,
    floor_to_view_bottom,
    nosing_under_floor,
    samples_below_floor,
)
from ...terrain.below import step_in_front
from ...terrain.model import NONE, STAIRS
from ..config import PipelineConfig
from ..gravity_steps import origin_on_floor
from ..result import TerrainResult
from .adopt import with_step_sigmas
from .replanned import FAR_PLANES_CHOICE, far_widenings
from .verdicts import Passes, steps_agree

#: Two passes' ups corroborate each other within this many of their combined sigmas (the
#: gravity stage's rule for two estimates that agree, :func:`combine_with_lines`).
_AGREE_SIGMAS = 3.0


def _ups_agree(a: tuple[np.ndarray, float] | None, b: tuple[np.ndarray, float] | None) -> bool:
    """Whether two passes' ups from the scene (:func:`scene_up`) corroborate each other:
    within ``_AGREE_SIGMAS`` of their combined sigmas (False where either is None)."""
    if a is None or b is None:
        return False
    return angle_deg(a[0], b[0]) <= _AGREE_SIGMAS * math.hypot(a[1], b[1])


def _ups_and_support(tried: Passes) -> tuple[list[tuple[np.ndarray, float] | None], list[int]]:
    """Each pass's up from the scene (:func:`scene_up`; rectified camera, with its sigma)
    and how many other passes corroborate it (:func:`_ups_agree`)."""
    ups = [scene_up(r) for _, r in tried]
    n = len(ups)
    support = [sum(_ups_agree(ups[i], ups[j]) for j in range(n) if j != i) for i in range(n)]
    return ups, support


def corroborated_up(tried: Passes, kept: TerrainResult) -> TerrainResult:
    """Where every pass of a frame without a rig found nothing and the first's result is
    kept: the result of the pass (of those that found nothing) whose up from the scene the
    most other passes corroborate (within ``_AGREE_SIGMAS`` combined sigmas), the first on
    a tie. The passes level their frames from their own disparities; a first matcher's
    junk plane can tilt its up by several degrees where the two rematches agree (realistic
    renders: 6.7 -> 0.1 deg on an empty view, 7.5 -> 2.9 deg on a lab-like staircase not
    found; docs/benchmarks.md, "Nineteenth session"). Its timings are the frame's.
    :class:`~..core.Pipeline` asks it twice: before the redrawn planes (which keep the
    frame it chooses), over the passes run so far, and, where the denoised passes ran and
    still nothing is found, over all of them (realistic renders: 5.7 -> 1.0 and 5.8 ->
    2.7 deg in two of 120 views, none worse; "Thirty-seventh session")."""
    if len(tried) < 2 or kept.gravity_source == "rig":
        return kept
    _, support = _ups_and_support(tried)
    nothing = [i for i in range(len(tried)) if tried[i][1].terrain.obstacle == NONE]
    best = max(nothing, key=lambda i: (support[i], -i))
    if support[best] <= support[0]:  # the first pass (found nothing, kept) as sure: kept
        return kept
    name, other = tried[best]
    gravity = other.gravity
    if gravity is not None:
        note = f"{gravity.note}; the {name}'s up, which {support[best]} other pass(es) corroborate"
        gravity = dataclasses.replace(gravity, note=note)
    return dataclasses.replace(other, gravity=gravity, timing_ms=kept.timing_ms)


def corroborated_frame(tried: Passes, kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """Without a rig, ``kept`` (an obstacle a pass found) found again in the frame of the
    up that the frame's passes corroborate, where they do not corroborate its own
    (``PipelineConfig.corroborated_frame``); else ``kept``.

    A result keeps the frame of the pass that found its obstacle, and each pass levels
    its frame from its own disparities: a denoised pass's far planes can find a
    staircase in a frame 13 deg off where the first matcher's and the coarse rematch's
    ups agree within a degree (realistic renders; docs/benchmarks.md, "Thirty-seventh
    session"). Each pass's support is how many others corroborate its up (within
    ``_AGREE_SIGMAS`` combined sigmas, as :func:`corroborated_up` counts). Where the
    best-supported pass has two or more, more than ``kept``'s up has, and does not
    corroborate ``kept``'s up either, ``kept``'s samples are expressed in that pass's
    frame, the origin put on the floor again, and the planes and terrain found there
    (with the plane stage's widened normal tests too where ``kept`` came from the far
    planes). The first terrain with an obstacle, and with steps that agree where it is
    a staircase (:func:`steps_agree`), is kept, with that frame and that pass's gravity,
    the notes saying so; where none is, ``kept`` stands. Only with ``method:
    orientation`` (the planes are found again by the orientation method)."""
    if config.method != "orientation":
        return kept
    if kept.gravity_source != "scene" or kept.terrain.obstacle == NONE or len(tried) < 2:
        return kept
    own = scene_up(kept)
    if own is None:
        return kept
    ups, support = _ups_and_support(tried)
    n = len(tried)
    # kept's own pass (the first whose up is kept's) does not corroborate kept
    same = [i for i, u in enumerate(ups) if u is not None and angle_deg(u[0], own[0]) < 1e-6]
    own_support = sum(_ups_agree(own, ups[j]) for j in range(n) if j not in same[:1])
    best = max(range(n), key=lambda i: (support[i], -i))
    if support[best] < 2 or support[best] <= own_support or _ups_agree(ups[best], own):
        return kept
    name, other = tried[best]
    T_move = other.T_yaw_camera_rect @ kept.T_yaw_camera_rect.inverse()
    samples = transform_sample(kept.planes.samples, T_move)
    plane_configs = [config.orientation]
    if kept.plane_choice.startswith(FAR_PLANES_CHOICE):
        plane_configs += [wide for wide, _ in far_widenings(config)]
    corroborated = f"the {name}'s up, which {support[best]} other pass(es) corroborate"
    for plane_config in plane_configs:
        found = _found_in_frame(kept, samples, other.T_yaw_camera_rect, plane_config, config)
        if found is None:
            continue
        again = f"found again in the frame of {corroborated} (corroborated_frame)"
        terrain = dataclasses.replace(found.terrain, note=f"{found.terrain.note}; {again}")
        gravity = other.gravity
        if gravity is not None:
            gravity = dataclasses.replace(gravity, note=f"{gravity.note}; {corroborated}")
        swing = plan_swing(terrain, config.swing)
        return dataclasses.replace(found, terrain=terrain, swing=swing, gravity=gravity)
    return kept


def _found_in_frame(
    kept: TerrainResult,
    samples: GridSample,
    T_levelled: Transform,
    plane_config: OrientationConfig,
    config: PipelineConfig,
) -> TerrainResult | None:
    """``kept`` with the planes and terrain found in ``samples`` (``kept``'s, expressed in
    the levelled frame of ``T_levelled``, a pass's ``T_yaw_camera_rect``), the origin put
    on the floor again (:func:`~..gravity_steps.origin_on_floor`); None where the terrain
    has no obstacle, or is a staircase of two steps or more whose steps do not agree
    (:func:`corroborated_frame`)."""
    up = np.array([0.0, 0.0, 1.0])  # the samples' frame is levelled
    planes = extract_planes_orientation(samples, plane_config, up=up, camera_position=samples.camera_position)
    planes, T, floor_known = origin_on_floor(planes, T_levelled, config.gravity.min_floor_drop_m)
    lines = _lines_in_frame(kept.image_lines, T)
    terrain = build_terrain(planes, config.terrain, floor_known=floor_known, lines=lines)
    if terrain.obstacle == NONE:
        return None
    if terrain.obstacle == STAIRS and len(terrain.steps) >= 2 and not steps_agree(terrain, config.terrain):
        return None
    terrain = with_step_sigmas(terrain, planes, kept, config)
    return dataclasses.replace(
        kept, terrain=terrain, planes=planes, T_yaw_camera_rect=T, floor_known=floor_known, image_lines=lines
    )


def _lines_in_frame(lines: ImageLines | None, T: Transform) -> ImageLines | None:
    """``lines`` with the camera in the frame of ``T`` (``T_yaw_camera_rect``)."""
    if lines is None:
        return None
    stereo = lines.stereo
    if stereo is not None:
        stereo = dataclasses.replace(stereo, T_frame_camera=T.matrix)
    return dataclasses.replace(lines, T_frame_camera=T.matrix, stereo=stereo)


def floor_a_step_below(kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """Without a rig: ``kept``, or its planes' terrain found again with the floor a rise
    lower, where the floor its frame stands on is its staircase's first tread
    (``PipelineConfig.floor_a_step_below``).

    Without a rig the floor is the lowest large horizontal plane
    (:func:`~..gravity_steps.origin_on_floor`); where the floor before the stairs formed
    none (a level camera sees a strip of it, or none), that is the first tread, and the
    chain counts the steps from the second riser on, their rises from the wrong floor.
    Asked of a staircase whose first riser stands on that floor (its rise measured: a
    first riser whose foot is out of view stands on no floor seen).
    The first riser shows under that "floor": ``terrain.min_riser_points`` samples or
    more (a riser's worth) in front of the chain, a run (``terrain.min_run_m``) or more
    in front of its first riser (:func:`~stereo_terrain.terrain.samples_below_floor`;
    where the floor is the floor, the strays under it lie at the chain's first riser, or
    spread), and the "floor" does not run to the view's bottom
    (:func:`~stereo_terrain.terrain.floor_to_view_bottom`: a floor that does is the one
    under the cameras; a tread ends above its riser in the image). The frame's floor is
    then put the staircase's first rise lower and the terrain found again, there with
    the floor known: the steps between it and the chain are placed as with a rig
    (:mod:`stereo_terrain.terrain.below`). Kept where that finds more steps, the first
    of them in front of ``kept``'s first riser by ``terrain.merge_distance_m`` to
    ``terrain.continue_max_run_m``; the result keeps the lowered frame and its note says
    so. ``timing_ms["floor_below"]``: the time it took, where it ran.

    Where the frame found no floor plane at all (its origin left at the cameras), the
    terrain measured the first rise from its own ground, the lowest horizontal surface
    below the cameras; with ``floor_below_floorless`` that surface is asked the same, in a
    frame whose origin is on it (a close level camera whose view's bottom falls on the
    first tread: realistic 41 scene 32 and 71 scene 30; docs/benchmarks.md, "Fifty-fourth
    session")."""
    terrain = kept.terrain
    floorless = not kept.floor_known
    ground_below = config.floor_below_floorless and terrain.ground_z_m <= -config.terrain.min_rise_m
    if (
        not config.floor_a_step_below
        or kept.gravity_source == "rig"
        or terrain.obstacle != STAIRS
        or terrain.steps[0].rise_inferred
        or (floorless and not ground_below)
    ):
        return kept
    t0 = time.perf_counter()
    result = kept
    tc = config.terrain
    if floorless:
        kept = _origin_lowered(kept, -terrain.ground_z_m)
    under, position = samples_below_floor(kept.planes, terrain, tc)
    ahead = terrain.steps[0].axis_position_m - position  # NaN where no sample is under it
    riser_shows = under >= tc.min_riser_points and ahead >= tc.min_run_m
    runs = [s.run_m for s in terrain.steps if s.run_m is not None]
    run = float(np.median(runs)) if runs else math.nan
    nosing_shows = (
        not riser_shows
        and config.floor_below_nosing
        and kept.image_lines is not None
        and nosing_under_floor(terrain, kept.image_lines, tc)
    )
    if (riser_shows or nosing_shows) and not floor_to_view_bottom(kept.planes, tc):
        rise = terrain.steps[0].rise_m
        moved = _origin_lowered(kept, rise)
        lowered = build_terrain(moved.planes, config.terrain, floor_known=True, lines=moved.image_lines)
        more = lowered.obstacle == STAIRS and len(lowered.steps) > len(terrain.steps)
        first_run = terrain.steps[0].axis_position_m - lowered.steps[0].axis_position_m if more else 0.0
        if nosing_shows:
            # The nosing stands a run in front of the chain: so must the step placed below.
            # (The nosing needs a measured run, so there is one.)
            more = more and abs(first_run - run) <= tc.continue_run_tolerance * run
        kept_chain = (
            config.floor_below_keep_chain
            and floorless
            and riser_shows
            and not (more and tc.merge_distance_m <= first_run <= tc.continue_max_run_m)
            and abs(ahead - run) <= tc.continue_run_tolerance * run
        )
        if kept_chain:
            # Built again in the lowered frame, the planes chain at other heights and can drop
            # or misplace a riser: without a floor plane, the chain as it was, raised a rise,
            # its first riser where its samples show it, where they stand a run (the
            # chain's) in front of it (PipelineConfig.floor_below_keep_chain). (Under a floor
            # plane such samples were as often strays: 5 counts made right, 3 wrong.) The
            # origin dropped onto the ground, then a rise.
            lowered = step_in_front(terrain, rise - terrain.ground_z_m, rise, position)
            more, first_run = True, ahead
        if more and tc.merge_distance_m <= first_run <= tc.continue_max_run_m:
            shown = (
                f"{under} samples of the first riser under it"
                if riser_shows
                else "the image's segments show its nosing a run in front of the chain (floor_below_nosing)"
            )
            if kept_chain:
                shown += ", the chain kept, its first riser where they stand (floor_below_keep_chain)"
            lowest = "the lowest horizontal plane" + (" (no floor plane found)" if floorless else "")
            why = (
                f"the floor put {100.0 * rise:.1f} cm lower (the first rise): {lowest} "
                f"is the first tread, {shown} (floor_a_step_below)"
            )
            lowered = dataclasses.replace(lowered, note=f"{lowered.note}; {why}")
            lowered = with_step_sigmas(lowered, moved.planes, kept, config)
            result = dataclasses.replace(moved, terrain=lowered, swing=plan_swing(lowered, config.swing))
    result.timing_ms["floor_below"] = (time.perf_counter() - t0) * 1000.0
    return result


def _origin_lowered(kept: TerrainResult, drop: float) -> TerrainResult:
    """``kept`` in the frame whose origin is ``drop`` metres lower, the floor known there
    (onto its terrain's ground, or a first rise lower): its planes, transform and lines
    moved; its terrain as it was (:func:`floor_a_step_below` replaces it or reads no
    height of it)."""
    shift = Transform.from_rt(np.eye(3), [0.0, 0.0, drop], "yaw", "yaw")
    T = shift @ kept.T_yaw_camera_rect
    planes = transform_planes(kept.planes, shift)
    lines = _lines_in_frame(kept.image_lines, T)
    return dataclasses.replace(kept, planes=planes, T_yaw_camera_rect=T, image_lines=lines, floor_known=True)


def scene_up(result: TerrainResult) -> tuple[np.ndarray, float] | None:
    """The up (rectified camera) that a pass without a rig found from the scene and its
    sigma, where the scene fixed it (a finite sigma); None otherwise (a rig's frame, an
    assumed level camera, a floor alone)."""
    g = result.gravity
    if g is None or result.gravity_source != "scene" or g.sigma_deg is None or not math.isfinite(g.sigma_deg):
        return None
    return g.up_camera, g.sigma_deg
