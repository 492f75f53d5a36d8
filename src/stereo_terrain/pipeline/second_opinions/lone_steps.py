"""The second opinions of a lone step: the one two rematches find alike
(:func:`agreed_lone_step`), and a box one of them sees whole (:func:`whole_box`)."""

from __future__ import annotations

from ...terrain import StairModel
from ...terrain.model import BOX, NONE, TerrainConfig
from ..config import PipelineConfig
from ..result import TerrainResult
from .adopt import pass_kept
from .verdicts import Passes


def agreed_lone_step(tried: Passes, kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept`` (no pass found an obstacle, nor did the far planes), or the lone step that
    two second opinions of ``tried`` (the rematch, the coarse rematch) each found alike:
    the earlier pass's result, its note saying so (``PipelineConfig.agreed_lone_step``).

    A second opinion's lone step is not kept on its own (:func:`rematch_kept`: the
    rematch's harder smoothing can make the front of a room's object a "step"), but the
    band fill is what finds a box's painted or grained front, and the first pass goes
    without it (realistic renders: 19 of 25 boxes missed; the rematch and the coarse
    rematch found 8 of them alike, at 20.5 and 20.6 cm for 21.1). Each step must be one
    the terrain stage measured whole: its top seen (a tread or a box's top, not a riser
    whose top edge is all there is), its rise measured and no taller than a stair's
    (``terrain.max_rise_m``: taller, two steps merged). The two are alike where their
    risers are one (``terrain.merge_distance_m`` apart at most, along the stair axis)
    and their rises agree as a staircase's do (``terrain.common_rise_tolerance_m``)."""
    t = config.terrain
    lone = [(name, done) for name, done in tried[1:] if _whole_lone_step(done.terrain, t)]
    for k, (name, done) in enumerate(lone):
        a = done.terrain.steps[0]
        for other, seen in lone[k + 1 :]:
            b = seen.terrain.steps[0]
            if abs(a.distance_m - b.distance_m) > t.merge_distance_m:
                continue
            if abs(a.own_rise_m - b.own_rise_m) > t.common_rise_tolerance_m:
                continue
            found_by = (
                f"found by the {name}, and the {other} found the same lone step (rises "
                f"{100.0 * a.own_rise_m:.1f} and {100.0 * b.own_rise_m:.1f} cm, "
                f"{a.distance_m:.2f} and {b.distance_m:.2f} m ahead; before them nothing: "
                "agreed_lone_step)"
            )
            return pass_kept(done, found_by, kept)
    return kept


def whole_box(tried: Passes, kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept`` (no pass found an obstacle, nor did the far planes or two second opinions
    alike), or the first box that a second opinion of ``tried`` sees whole: the terrain
    stage called it a box (its front, its top, and the ground beyond the top), its rise
    measured and no taller than ``terrain.max_rise_m`` (``PipelineConfig.whole_box``).

    A box is three faces at right angles standing on the ground, a much narrower shape
    than a lone riser plane: on the realistic renders, the empty ones and the 13 real
    scenes, no second opinion made one where there was none, where lone "steps" without
    a top seen did (a real room's motorbike, its pipes). The rematch and the coarse
    rematch see a box's front where the first matcher does not (the band fill runs in
    them), but only one of them often does (docs/benchmarks.md, "Twenty-fifth session")."""
    for name, done in tried[1:]:
        if done.terrain.obstacle != BOX or not _whole_lone_step(done.terrain, config.terrain):
            continue
        return pass_kept(done, f"found by the {name} (a box seen whole; before it nothing: whole_box)", kept)
    return kept


def _whole_lone_step(terrain: StairModel, config: TerrainConfig) -> bool:
    """Whether ``terrain`` is one step (a box, a one-step staircase) measured whole: its
    top seen and its rise measured, no taller than a stair's (:func:`agreed_lone_step`)."""
    if terrain.obstacle == NONE or len(terrain.steps) != 1:
        return False
    step = terrain.steps[0]
    return step.tread is not None and not step.rise_inferred and step.own_rise_m <= config.max_rise_m
