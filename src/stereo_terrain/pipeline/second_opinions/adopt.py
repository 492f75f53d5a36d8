"""How a second opinion's find becomes the frame's result: its note, its steps' sigmas
from the frame's matcher, its swing plan (:func:`kept_staircase`, :func:`pass_kept`,
:func:`with_staircase`)."""

from __future__ import annotations

import dataclasses
import time

from ...planes.orientation import PlaneSet
from ...swing import plan_swing
from ...terrain import StairModel, estimate_step_sigmas
from ..config import PipelineConfig
from ..result import TerrainResult
from .verdicts import steps_agree


def with_staircase(
    kept: TerrainResult, found: StairModel | None, config: PipelineConfig, timing_key: str, t0: float
) -> TerrainResult:
    """``kept``, with ``found`` where there is one as its terrain (its steps' sigmas from
    ``kept``'s planes, its swing plan); ``timing_ms[timing_key]``: the time since ``t0``."""
    result = kept
    if found is not None:
        terrain = with_step_sigmas(found, kept.planes, kept, config)
        result = dataclasses.replace(kept, terrain=terrain, swing=plan_swing(terrain, config.swing))
    result.timing_ms[timing_key] = result.timing_ms.get(timing_key, 0.0) + (time.perf_counter() - t0) * 1000.0
    return result


def pass_kept(done: TerrainResult, found_by: str, kept: TerrainResult) -> TerrainResult:
    """A second opinion's own result ``done`` as the frame's, ``found_by`` added to its
    note, with the frame's timings (``kept``'s)."""
    terrain = dataclasses.replace(done.terrain, note=f"{done.terrain.note}; {found_by}")
    return dataclasses.replace(done, terrain=terrain, timing_ms={**kept.timing_ms}, rematched=True)


def kept_staircase(
    base: TerrainResult,
    planes: PlaneSet,
    terrain: StairModel,
    config: PipelineConfig,
    *,
    found_by: str,
    plane_choice: str,
    timing_ms: dict[str, float],
) -> TerrainResult | None:
    """``base`` with ``terrain``, found on ``planes`` by a last opinion of the frame (the far
    planes, the redrawn planes), or None where it is not kept: its steps must agree
    (:func:`steps_agree`) and its first riser's foot must be seen (its rise measured from
    the ground: the weakest evidence of the pipeline's, it must not stand on an inferred
    step; a real room's chair did). ``found_by`` is added to its note; its step sigmas
    are ``base``'s matcher's."""
    if not steps_agree(terrain, config.terrain) or terrain.steps[0].rise_inferred:
        return None
    terrain = with_step_sigmas(terrain, planes, base, config)
    terrain = dataclasses.replace(terrain, note=f"{terrain.note}; {found_by}")
    return dataclasses.replace(
        base,
        terrain=terrain,
        swing=plan_swing(terrain, config.swing),
        planes=planes,
        plane_choice=plane_choice,
        timing_ms={**timing_ms},
        rematched=True,
    )


def with_step_sigmas(
    terrain: StairModel, planes: PlaneSet, base: TerrainResult, config: PipelineConfig
) -> StairModel:
    """``terrain`` (found on ``planes``) with each step's sigmas from ``base``'s matcher
    (:func:`~stereo_terrain.terrain.estimate_step_sigmas`)."""
    rect = base.rectified.rectification
    return estimate_step_sigmas(
        terrain, planes, focal_px=rect.focal_px, baseline_m=rect.baseline_m, config=config.terrain
    )
