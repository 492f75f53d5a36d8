"""The second opinions of a frame (issue 11): what decides that a pass's terrain wants
another, and the opinions that need no new matching.

:class:`~.core.Pipeline` runs a frame's passes (the first matcher; the rematch, the coarse
and focus rematches where :func:`wants_rematch` asks for them; last, the rematch and the
coarse rematch again on the pair denoised, ``PipelineConfig.rematch_denoised``) and hands
their results here:

- :func:`far_planes`: the passes' samples with the plane stage's normal tests widened by
  the far samples' noise, where no pass found an obstacle;
- :func:`corroborated_up`: without a rig, the up that most passes agree on, where all of
  them found nothing;
- :func:`agreed_lone_step`: the lone step (a box, a one-step staircase) that two
  second opinions find alike, where no pass found more;
- :func:`whole_box`: else, a box that one second opinion sees whole (its front, its top
  and the ground beyond it);
- :func:`redrawn_planes`: the last pass's samples with other seeds of the plane stage's
  random draws;
- :func:`corroborated_frame`: without a rig, an obstacle found again in the frame of the
  up the passes corroborate, where they do not corroborate the up of the pass that found
  it;
- :func:`staircase_of_lines`: last, where nothing was found and the floor is known, the
  staircase whose first riser the image's lines show (no riser formed a plane);
- :func:`staircase_of_finer_lines`: then, with a rig (whose frame's lines are found at
  half size), the same with the lines of the full-size image;
- :func:`staircase_of_ends`: last of all, the staircase its risers' ends show;
- :func:`staircase_at_floor_edge`: where even those found nothing, the staircase whose
  first riser stands where the floor the matcher holds ends;
- :func:`floor_a_step_below`: without a rig, where those found no more steps, the
  staircase found again with the floor a rise lower, where the "floor" it stands on is
  its first tread (the ends then asked again, in that frame);
- :func:`kept_staircase`: what every one of them asks of a staircase before it is kept.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..cloud import GridSample, transform_sample
from ..frames import Transform
from ..gravity import SceneLines, angle_deg, scene_segments
from ..planes.orientation import (
    OrientationConfig,
    PlaneSet,
    extract_planes_orientation,
    noise_widened,
    transform_planes,
)
from ..swing import plan_swing
from ..terrain import (
    ImageLines,
    StairModel,
    build_terrain,
    estimate_step_sigmas,
    floor_to_view_bottom,
    samples_below_floor,
    staircase_from_ends,
    staircase_from_lines,
)
from ..terrain.model import BOX, NONE, STAIRS, TerrainConfig
from .config import AGREEING_RISE_RATIO, PipelineConfig
from .gravity_steps import origin_on_floor
from .result import TerrainResult

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
    better = steps_agree(terrain, config.terrain) and _at_most_one_step_fewer(terrain, kept)
    rises = ", ".join(f"{100.0 * s.own_rise_m:.1f}" for s in kept.steps if not s.rise_inferred)
    return better, f"the steps found before it disagree: rises {rises} cm"


def _at_most_one_step_fewer(terrain: StairModel, kept: StairModel) -> bool:
    """Whether ``terrain`` may replace ``kept``, a staircase whose steps disagree, by its
    length: at most one step fewer (the rematch's rule, :func:`rematch_kept`, and the
    redraw's, :func:`redrawn_planes`)."""
    return len(terrain.steps) >= len(kept.steps) - 1


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
    for wide, option in _far_widenings(config):
        found = _far_planes_with(tried, kept, wide, option, config)
        if found is not None:
            result = found
            break
    took = (time.perf_counter() - t0) * 1000.0
    result.timing_ms["far_planes"] = kept.timing_ms.get("far_planes", 0.0) + took  # the focus pass's too
    return result


#: How a far planes' result's ``plane_choice`` begins (:func:`_far_planes_with`).
_FAR_PLANES_CHOICE = "orientation, normal tests widened"


def _far_widenings(config: PipelineConfig) -> list[tuple[OrientationConfig, str]]:
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
            plane_choice=f"{_FAR_PLANES_CHOICE}{further} ({option})",
            timing_ms=kept.timing_ms,
        )
        if found is not None:
            return found
    return None


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
            return _pass_kept(done, found_by, kept)
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
        return _pass_kept(done, f"found by the {name} (a box seen whole; before it nothing: whole_box)", kept)
    return kept


def staircase_of_lines(kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept`` (every pass and second opinion found nothing), or the staircase whose first
    riser the image's lines show in its planes' frame, where its floor is known
    (:func:`~stereo_terrain.terrain.staircase_from_lines`, ``TerrainConfig.lines_first_riser``).

    Last and only on nothing: the lines' staircase is placed by the lines alone (its
    risers' samples are anywhere along their rays), and where a riser plane was found the
    chain from it is the better measure. ``timing_ms["lines_staircase"]``: the time it
    took, where it ran."""
    lines = _lines_asked(kept, config)
    if lines is None:
        return kept
    t0 = time.perf_counter()
    found = staircase_from_lines(kept.planes, config.terrain, lines)
    return _with_staircase(kept, found, config, "lines_staircase", t0)


def _lines_asked(kept: TerrainResult, config: PipelineConfig) -> ImageLines | None:
    """The image's lines where the lines' staircase is asked of ``kept`` (nothing found,
    the floor known, ``TerrainConfig.lines_first_riser``), else None."""
    asked = kept.terrain.obstacle == NONE and config.terrain.lines_first_riser and kept.floor_known
    return kept.image_lines if asked else None


def staircase_at_floor_edge(kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept`` (nothing found, the lines' staircase and the risers' ends included), or the
    staircase whose first riser's foot is where the floor the matcher holds ends in front
    of the lines on the floor, the nosings over it as the lines' staircase takes them
    (``TerrainConfig.floor_edge_foot``; :func:`~stereo_terrain.terrain.from_lines.floor_edge_feet`).

    After the risers' ends: a foot placed by the floor's samples is off by a grid row or
    so, and the pitch fitted from it by as much; where the ends found the staircase (on
    realistic 57 scene 19 without a rig, five steps with runs 0.1 cm off), they are the
    better measure. ``timing_ms["floor_edge_staircase"]``: the time it took, where it
    ran."""
    lines = _lines_asked(kept, config) if config.terrain.floor_edge_foot else None
    if lines is None:
        return kept
    t0 = time.perf_counter()
    found = staircase_from_lines(kept.planes, config.terrain, lines, at_floor_edge=True)
    return _with_staircase(kept, found, config, "floor_edge_staircase", t0)


def staircase_of_finer_lines(
    kept: TerrainResult, image: np.ndarray, lines: SceneLines | None, config: PipelineConfig
) -> TerrainResult:
    """``kept`` (every pass and second opinion found nothing, the lines' staircase too), or
    :func:`staircase_of_lines` of the segments of a pass at ``vanishing.finer_scale``,
    where the frame's own ``lines`` ran at another scale (with a rig, ``horizontal_scale``:
    half size). ``image``: the rectified left image the frame's lines were found on. The
    result carries those finer image lines, for the risers' ends asked next
    (:func:`staircase_of_ends`). ``timing_ms["finer_lines"]``: the time it took, where it
    ran.

    A staircase 2-4 m ahead has nosings 1-3 px thick and risers' ends 15-50 px tall: at
    half size LSD misses most of them. Asked only where nothing was found: on nearer
    staircases the full-size segments break a faint nosing into pieces and add the
    floor's lines, and the first riser's foot the lines' staircase takes is the nearest
    line (docs/benchmarks.md, "Forty-seventh session")."""
    scale = config.vanishing.finer_scale
    if (
        kept.terrain.obstacle != NONE
        or lines is None
        or lines.scale is None
        or lines.scale == scale
        or kept.image_lines is None
    ):
        return kept
    t0 = time.perf_counter()
    rect = kept.rectified.rectification
    finer = scene_segments(image, rect, config.vanishing, scale)
    image_lines = dataclasses.replace(
        kept.image_lines, segments=finer.segments, at_border=finer.at_border, short=finer.short
    )
    found = staircase_of_lines(dataclasses.replace(kept, image_lines=image_lines), config)
    result = finer_lines_noted(found, lines, config) if found.terrain.obstacle != NONE else kept
    result.timing_ms["finer_lines"] = (time.perf_counter() - t0) * 1000.0
    return result


def finer_lines_noted(result: TerrainResult, lines: SceneLines, config: PipelineConfig) -> TerrainResult:
    """``result`` (found in the lines of :func:`staircase_of_finer_lines`, or the risers'
    ends of those lines asked next), its note saying so once."""
    how = (
        f"in the lines of the image at {_size(config.vanishing.finer_scale)} "
        f"(the frame's at {_size(lines.scale)}: finer_scale)"
    )
    if how in result.terrain.note:
        return result
    terrain = dataclasses.replace(result.terrain, note=f"{result.terrain.note}; {how}")
    return dataclasses.replace(result, terrain=terrain)


def _size(scale: float | None) -> str:
    """An image scale in words."""
    return "full size" if scale == 1.0 else f"{scale:g} of full size"


def staircase_of_ends(kept: TerrainResult, config: PipelineConfig) -> TerrainResult:
    """``kept``, or the staircase its risers' ends show where that holds one of ``kept``'s
    measured risers and has more steps, or holds none and outweighs ``kept``'s staircase
    (:func:`~stereo_terrain.terrain.staircase_from_ends`, ``TerrainConfig.ends_staircase``,
    ``ends_over_planes``): asked last, of a result with a staircase or a step
    whose floor is known. ``timing_ms["ends_staircase"]``: the time it took, where it ran
    (the sum, where it ran twice: :func:`floor_a_step_below`)."""
    if (
        kept.terrain.obstacle == NONE
        or not config.terrain.ends_staircase
        or not kept.floor_known
        or kept.image_lines is None
    ):
        return kept
    t0 = time.perf_counter()
    found = staircase_from_ends(kept.terrain, kept.planes, config.terrain, kept.image_lines)
    return _with_staircase(kept, found, config, "ends_staircase", t0)


def _with_staircase(
    kept: TerrainResult, found: StairModel | None, config: PipelineConfig, timing_key: str, t0: float
) -> TerrainResult:
    """``kept``, with ``found`` where there is one as its terrain (its steps' sigmas from
    ``kept``'s planes, its swing plan); ``timing_ms[timing_key]``: the time since ``t0``."""
    result = kept
    if found is not None:
        terrain = _with_step_sigmas(found, kept.planes, kept, config)
        result = dataclasses.replace(kept, terrain=terrain, swing=plan_swing(terrain, config.swing))
    result.timing_ms[timing_key] = result.timing_ms.get(timing_key, 0.0) + (time.perf_counter() - t0) * 1000.0
    return result


def _pass_kept(done: TerrainResult, found_by: str, kept: TerrainResult) -> TerrainResult:
    """A second opinion's own result ``done`` as the frame's, ``found_by`` added to its
    note, with the frame's timings (``kept``'s)."""
    terrain = dataclasses.replace(done.terrain, note=f"{done.terrain.note}; {found_by}")
    return dataclasses.replace(done, terrain=terrain, timing_ms={**kept.timing_ms}, rematched=True)


def _whole_lone_step(terrain: StairModel, config: TerrainConfig) -> bool:
    """Whether ``terrain`` is one step (a box, a one-step staircase) measured whole: its
    top seen and its rise measured, no taller than a stair's (:func:`agreed_lone_step`)."""
    if terrain.obstacle == NONE or len(terrain.steps) != 1:
        return False
    step = terrain.steps[0]
    return step.tread is not None and not step.rise_inferred and step.own_rise_m <= config.max_rise_m


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
        if not unconvincing(kept.terrain) and not _at_most_one_step_fewer(terrain, kept.terrain):
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
    terrain = _with_step_sigmas(terrain, planes, base, config)
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


def _with_step_sigmas(
    terrain: StairModel, planes: PlaneSet, base: TerrainResult, config: PipelineConfig
) -> StairModel:
    """``terrain`` (found on ``planes``) with each step's sigmas from ``base``'s matcher
    (:func:`~stereo_terrain.terrain.estimate_step_sigmas`)."""
    rect = base.rectified.rectification
    return estimate_step_sigmas(
        terrain, planes, focal_px=rect.focal_px, baseline_m=rect.baseline_m, config=config.terrain
    )


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


#: Two passes' ups corroborate each other within this many of their combined sigmas (the
#: gravity stage's rule for two estimates that agree, :func:`combine_with_lines`).
_AGREE_SIGMAS = 3.0


def _ups_agree(a: tuple[np.ndarray, float] | None, b: tuple[np.ndarray, float] | None) -> bool:
    """Whether two passes' ups from the scene (:func:`scene_up`) corroborate each other:
    within ``_AGREE_SIGMAS`` of their combined sigmas (False where either is None)."""
    if a is None or b is None:
        return False
    return angle_deg(a[0], b[0]) <= _AGREE_SIGMAS * math.hypot(a[1], b[1])


def corroborated_up(tried: Passes, kept: TerrainResult) -> TerrainResult:
    """Where every pass of a frame without a rig found nothing and the first's result is
    kept: the result of the pass (of those that found nothing) whose up from the scene the
    most other passes corroborate (within ``_AGREE_SIGMAS`` combined sigmas), the first on
    a tie. The passes level their frames from their own disparities; a first matcher's
    junk plane can tilt its up by several degrees where the two rematches agree (realistic
    renders: 6.7 -> 0.1 deg on an empty view, 7.5 -> 2.9 deg on a lab-like staircase not
    found; docs/benchmarks.md, "Nineteenth session"). Its timings are the frame's.
    :class:`~.core.Pipeline` asks it twice: before the redrawn planes (which keep the
    frame it chooses), over the passes run so far, and, where the denoised passes ran and
    still nothing is found, over all of them (realistic renders: 5.7 -> 1.0 and 5.8 ->
    2.7 deg in two of 120 views, none worse; "Thirty-seventh session")."""
    if len(tried) < 2 or kept.gravity_source == "rig":
        return kept
    # Each pass's up (rectified camera) and its sigma, where the scene fixed it.
    ups = [scene_up(r) for _, r in tried]
    n = len(tried)
    support = [sum(_ups_agree(ups[i], ups[j]) for j in range(n) if j != i) for i in range(n)]
    nothing = [i for i in range(n) if tried[i][1].terrain.obstacle == NONE]
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
    ups = [scene_up(r) for _, r in tried]
    n = len(tried)
    support = [sum(_ups_agree(ups[i], ups[j]) for j in range(n) if j != i) for i in range(n)]
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
    if kept.plane_choice.startswith(_FAR_PLANES_CHOICE):
        plane_configs += [wide for wide, _ in _far_widenings(config)]
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
    on the floor again (:func:`~.gravity_steps.origin_on_floor`); None where the terrain
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
    terrain = _with_step_sigmas(terrain, planes, kept, config)
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
    (:func:`~.gravity_steps.origin_on_floor`); where the floor before the stairs formed
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
    so. ``timing_ms["floor_below"]``: the time it took, where it ran."""
    terrain = kept.terrain
    if (
        not config.floor_a_step_below
        or kept.gravity_source == "rig"
        or not kept.floor_known
        or terrain.obstacle != STAIRS
        or terrain.steps[0].rise_inferred
    ):
        return kept
    t0 = time.perf_counter()
    result = kept
    tc = config.terrain
    under, position = samples_below_floor(kept.planes, terrain, tc)
    ahead_of_chain = terrain.steps[0].axis_position_m - position >= tc.min_run_m
    if under >= tc.min_riser_points and ahead_of_chain and not floor_to_view_bottom(kept.planes, tc):
        rise = terrain.steps[0].rise_m
        shift = Transform.from_rt(np.eye(3), [0.0, 0.0, rise], "yaw", "yaw")
        planes = transform_planes(kept.planes, shift)
        T = shift @ kept.T_yaw_camera_rect
        lines = _lines_in_frame(kept.image_lines, T)
        lowered = build_terrain(planes, config.terrain, floor_known=True, lines=lines)
        more = lowered.obstacle == STAIRS and len(lowered.steps) > len(terrain.steps)
        if more and (
            tc.merge_distance_m
            <= terrain.steps[0].axis_position_m - lowered.steps[0].axis_position_m
            <= tc.continue_max_run_m
        ):
            why = (
                f"the floor put {100.0 * rise:.1f} cm lower (the first rise): the lowest horizontal "
                f"plane is the first tread, {under} samples of the first riser under it (floor_a_step_below)"
            )
            lowered = dataclasses.replace(lowered, note=f"{lowered.note}; {why}")
            lowered = _with_step_sigmas(lowered, planes, kept, config)
            swing = plan_swing(lowered, config.swing)
            result = dataclasses.replace(
                kept, terrain=lowered, swing=swing, planes=planes, T_yaw_camera_rect=T, image_lines=lines
            )
    result.timing_ms["floor_below"] = (time.perf_counter() - t0) * 1000.0
    return result


def scene_up(result: TerrainResult) -> tuple[np.ndarray, float] | None:
    """The up (rectified camera) that a pass without a rig found from the scene and its
    sigma, where the scene fixed it (a finite sigma); None otherwise (a rig's frame, an
    assumed level camera, a floor alone)."""
    g = result.gravity
    if g is None or result.gravity_source != "scene" or g.sigma_deg is None or not math.isfinite(g.sigma_deg):
        return None
    return g.up_camera, g.sigma_deg


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
