"""The second opinions that find the planes again in a pass's samples: with the plane
stage's normal tests widened by the far samples' noise (:func:`far_planes`), and with
other seeds of its random draws (:func:`redrawn_planes`)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...cloud import transform_sample
from ...planes.orientation import OrientationConfig, extract_planes_orientation, noise_widened
from ...terrain import build_terrain
from ..config import PipelineConfig
from ..result import TerrainResult
from .adopt import kept_staircase
from .verdicts import Passes, at_most_one_step_fewer, unconvincing


def far_planes(tried: Passes, kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept`` (no obstacle found), or the first staircase that a pass of ``tried``, last
    pass first, gives from its samples with the plane stage's normal tests widened by
    the far samples' noise (``PipelineConfig.far_planes_sigmas``; where none does, once
    more widened further, ``far_planes_wider_sigmas`` up to
    ``far_planes_wider_max_deg``): one whose steps agree (:func:`steps_agree`) and
    whose first riser's foot is seen (its rise measured from the ground: the weakest
    evidence of the pipeline's, it must not stand on an inferred step; a real room's
    chair did). ``timing_ms["far_planes"]``: the time it took, added to the far planes'
    earlier in the frame (those of the focus and denoised rematches come after the
    others')."""
    t0 = time.perf_counter()
    result = kept
    for wide, option in far_widenings(config):
        found = _far_planes_with(tried, kept, wide, option, config)
        if found is not None:
            result = found
            break
    took = (time.perf_counter() - t0) * 1000.0
    result.timing_ms["far_planes"] = kept.timing_ms.get("far_planes", 0.0) + took  # the focus pass's too
    return result


#: How a far planes' result's ``plane_choice`` begins (:func:`_far_planes_with`).
FAR_PLANES_CHOICE = "orientation, normal tests widened"


def far_widenings(config: PipelineConfig) -> list[tuple[OrientationConfig, str]]:
    """The plane stage's configs the far planes try in turn, each with the option that
    names it: the normal tests widened by ``far_planes_sigmas``, then (unless 0)
    further by ``far_planes_wider_sigmas`` up to ``far_planes_wider_max_deg``."""
    widenings = [(config.far_planes_sigmas, config.orientation.max_noise_tolerance_deg, "far_planes_sigmas")]
    if config.far_planes_wider_sigmas > 0:
        widenings.append(
            (config.far_planes_wider_sigmas, config.far_planes_wider_max_deg, "far_planes_wider_sigmas")
        )
    return [
        (dataclasses.replace(config.orientation, normal_noise_sigmas=k, max_noise_tolerance_deg=deg), option)
        for k, deg, option in widenings
    ]


def _far_planes_with(
    tried: Passes, kept: TerrainResult, wide: OrientationConfig, option: str, config: PipelineConfig
) -> TerrainResult | None:
    """:func:`far_planes` at one widening, ``wide`` (the plane stage's config), named
    ``option`` in the note; None when no pass's staircase is kept."""
    # The last pass first: the coarse rematch's disparity is the best far away (on
    # wooden stairs 1.5-2.5 m ahead, risers within 0.5 px: 57% against the first
    # matcher's 32%; docs/benchmarks.md, "Fourteenth session").
    for which, done in reversed(tried):
        samples = done.planes.samples
        widened = noise_widened(samples, wide, wide.normal_agreement_deg)
        if widened is None or not np.any(widened > np.radians(wide.normal_agreement_deg)):
            continue  # nothing far: the same planes as before
        planes = extract_planes_orientation(
            samples, wide, up=done.planes.up, camera_position=done.planes.camera_position
        )
        lines = done.image_lines
        terrain = build_terrain(planes, config.terrain, floor_known=done.floor_known, lines=lines)
        further = " further" if option != "far_planes_sigmas" else ""
        found = kept_staircase(
            done,
            planes,
            terrain,
            config,
            found_by=(
                f"found by the far planes (no pass found an obstacle; the {which}'s samples with "
                f"normal tests widened{further} by the far samples' noise, {option})"
            ),
            plane_choice=f"{FAR_PLANES_CHOICE}{further} ({option})",
            timing_ms=kept.timing_ms,
        )
        if found is not None:
            return found
    return None


def redrawn_planes(tried: Passes, kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept`` (no obstacle found, a lone step, or steps whose rises disagree:
    :func:`wants_rematch`), or the staircase that the plane stage finds in the last
    pass's samples with another seed of its random draws, of
    ``PipelineConfig.redraw_planes`` tried in turn: the first whose steps agree and
    whose first riser's foot is seen (as :func:`_far_planes_with` asks), and in place
    of steps that disagree, with at most one step fewer (as :meth:`Pipeline._rematched` asks).
    The samples are expressed in ``kept``'s frame first (the rig's, or the up from the
    scene that the passes corroborate; a coarse pass's own up is the least sure), and
    the result is ``kept``'s with that terrain. ``timing_ms["redraw"]``: the time it
    took.

    The plane stage's hypotheses are random draws (seeded, so a frame gives the same
    planes every time); a staircase at the margin of what its samples hold is found by
    some draws and not others (docs/benchmarks.md, "Nineteenth session": a rig pitch
    0.2-0.6 deg off found 4 of 9 lab-like misses). Of the realistic staircases a
    redraw found, 11 of 12 came from the coarse rematch's samples, the last pass
    ("Twentieth session"): the others are not redrawn."""
    t0 = time.perf_counter()
    which, done = tried[-1]
    T = kept.T_yaw_camera_rect @ done.T_yaw_camera_rect.inverse()
    samples = transform_sample(done.planes.samples, T)
    up = np.array([0.0, 0.0, 1.0])  # the frame's: it is gravity-aligned
    result = kept
    for k in range(1, config.redraw_planes + 1):
        seed = config.orientation.seed + k
        draws = dataclasses.replace(config.orientation, seed=seed)
        planes = extract_planes_orientation(samples, draws, up=up, camera_position=samples.camera_position)
        terrain = build_terrain(planes, config.terrain, floor_known=kept.floor_known, lines=kept.image_lines)
        if not unconvincing(kept.terrain) and not at_most_one_step_fewer(terrain, kept.terrain):
            continue  # in place of steps that disagree
        found = kept_staircase(
            kept,
            planes,
            terrain,
            config,
            found_by=(
                f"found by the redrawn planes (the passes found nothing, a lone step or steps "
                f"that disagree; the {which}'s samples, the plane stage's draws seeded {seed}, "
                "redraw_planes)"
            ),
            plane_choice=f"orientation, the draws seeded {seed} (redraw_planes)",
            timing_ms=kept.timing_ms,
        )
        if found is not None:
            result = found
            break
    result.timing_ms["redraw"] = kept.timing_ms.get("redraw", 0.0) + (time.perf_counter() - t0) * 1000.0
    return result
