"""What a frame's passes and second opinions are judged by (issue 11): whether a pass's
terrain wants another opinion (:func:`wants_rematch`), whether a rematch replaces what
was kept (:func:`rematch_kept`), and what a staircase must be for a second opinion to
offer it (:func:`steps_agree`, :func:`stair_rises`)."""

from __future__ import annotations

from ...terrain import StairModel
from ...terrain.model import NONE, STAIRS, TerrainConfig
from ..config import AGREEING_RISE_RATIO, PipelineConfig
from ..result import TerrainResult

#: The passes a frame ran, in order: each one's name and own result (the first matcher's,
#: the rematch's, the coarse rematch's, then the focus and denoised rematches'), for the
#: far planes.
Passes = list[tuple[str, TerrainResult]]


def wants_rematch(terrain: StairModel, config: PipelineConfig) -> bool:
    """Whether a pass's terrain leaves room for another opinion: nothing convincing
    (:func:`unconvincing`), or (``rematch_disagreeing``) a staircase whose measured
    rises disagree (:func:`steps_agree`)."""
    if unconvincing(terrain):
        return True
    return config.rematch_disagreeing and steps_disagree(terrain, config.terrain)


def rematch_kept(
    name: str, terrain: StairModel, kept: StairModel, config: PipelineConfig
) -> tuple[bool, str]:
    """Whether a rematch pass named ``name`` that found ``terrain`` replaces ``kept`` (the
    terrain kept so far), and why it was run, for the note (:meth:`Pipeline._rematched`):

    - nothing or a lone step: with two steps or more, none taller than a stair's (the
      rematch; its harder smoothing can make an object's front a lone "step", as a real
      room's motorbike did; :func:`stair_rises`), with steps that agree (the coarse and
      focus rematches; the coarse one's smoothness reaches further across a room's
      furniture too: :func:`steps_agree`);
    - steps whose rises disagree: with steps that agree, no fewer than one less."""
    if unconvincing(kept):
        better = (
            terrain.obstacle == STAIRS and len(terrain.steps) >= 2 and stair_rises(terrain, config.terrain)
            if name == REMATCH_NOTE[0]
            else steps_agree(terrain, config.terrain)
        )
        return better, "before it nothing, or a lone step"
    better = steps_agree(terrain, config.terrain) and at_most_one_step_fewer(terrain, kept)
    rises = ", ".join(f"{100.0 * s.own_rise_m:.1f}" for s in kept.steps if not s.rise_inferred)
    return better, f"the steps found before it disagree: rises {rises} cm"


def at_most_one_step_fewer(terrain: StairModel, kept: StairModel) -> bool:
    """Whether ``terrain`` may replace ``kept``, a staircase whose steps disagree, by its
    length: at most one step fewer (the rematch's rule, :func:`rematch_kept`, and the
    redraw's, :func:`redrawn_planes`)."""
    return len(terrain.steps) >= len(kept.steps) - 1


#: What the terrain note says of the second opinions (:meth:`Pipeline._rematched`).
REMATCH_NOTE = (
    "rematch",
    "the right image's exposure matched to the left's and harder smoothness penalties, "
    "PipelineConfig.rematch_sgbm",
)
COARSE_NOTE = ("coarse rematch", "the pair matched at half size with the rematch's settings")
FOCUS_NOTE = ("focus rematch", "matched with the rematch's settings")
DENOISED_NOTE = (
    "denoised rematch",
    "the pair denoised, matched with the rematch's settings: rematch_denoised",
)
DENOISED_COARSE_NOTE = (
    "denoised coarse rematch",
    "the pair denoised, matched at half size: rematch_denoised",
)


def steps_disagree(terrain: StairModel, config: TerrainConfig) -> bool:
    """Whether ``terrain`` is a staircase whose steps disagree: its largest measured rise
    more than :data:`AGREEING_RISE_RATIO` times its smallest (inferred rises do not count;
    a stair's rises are equal), or a measured run longer than ``continue_max_run_m``."""
    if terrain.obstacle != STAIRS:
        return False
    rises = [s.own_rise_m for s in terrain.steps if not s.rise_inferred]
    runs = [s.own_run_m for s in terrain.steps if s.own_run_m is not None]
    if rises and max(rises) > AGREEING_RISE_RATIO * min(rises):
        return True
    return any(r > config.continue_max_run_m for r in runs)


def steps_agree(terrain: StairModel, config: TerrainConfig) -> bool:
    """Whether ``terrain`` is a staircase whose steps agree, as a second opinion must find
    one: two steps or more, one measured rise or more, none taller than a stair's
    (:func:`stair_rises`), and nothing :func:`steps_disagree` refuses. (A measured riser
    continued by steps inferred at its rise counts: on the realistic renders 26 such
    coarse staircases were all true ones, 12 counted right; asking for two measured rises
    lost 3-7 points of detection. docs/benchmarks.md, "Thirteenth session".)"""
    if terrain.obstacle != STAIRS or len(terrain.steps) < 2:
        return False
    if all(s.rise_inferred for s in terrain.steps):
        return False
    return stair_rises(terrain, config) and not steps_disagree(terrain, config)


def stair_rises(terrain: StairModel, config: TerrainConfig) -> bool:
    """Whether every measured rise of ``terrain`` is one a stair can have: no taller than
    ``max_rise_m`` (the terrain stage notes a taller one as "a step taller than a stair
    rise"). A second opinion's staircase with a taller step is two steps taken for one, or
    no staircase; the first pass's is kept as it is (a real bench in front of a step is
    such a step), but a second opinion, the weaker evidence, must not replace what the
    frame has with it. On the realistic, lab-like and far renders, the 16 second-opinion
    staircases with such a step all measured stairs of 14-21 cm; refused, 7 of them came
    out nearer the truth from a later opinion (redrawn or far planes), 5 as a lone step,
    and 4 found nothing (docs/benchmarks.md, "Twenty-ninth session")."""
    return all(s.own_rise_m <= config.max_rise_m for s in terrain.steps if not s.rise_inferred)


def unconvincing(terrain: StairModel) -> bool:
    """Whether a first pass's terrain leaves room for the rematch: no obstacle, or a
    staircase of a single step (on webcam photos often the one riser the first matcher
    held of several)."""
    return terrain.obstacle == NONE or (terrain.obstacle == STAIRS and len(terrain.steps) == 1)
