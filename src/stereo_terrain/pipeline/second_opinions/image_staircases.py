"""The staircases the image shows where the planes showed none: from its lines
(:func:`staircase_of_lines`, at the full size too: :func:`staircase_of_finer_lines`), from
the floor's edge and the lines (:func:`staircase_at_floor_edge`), and from its risers'
ends (:func:`staircase_of_ends`)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ...gravity import SceneLines, scene_segments
from ...terrain import ImageLines, staircase_from_ends, staircase_from_lines
from ...terrain.model import NONE
from ..config import PipelineConfig
from ..result import TerrainResult
from .adopt import with_staircase


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
    return with_staircase(kept, found, config, "lines_staircase", t0)


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
    return with_staircase(kept, found, config, "floor_edge_staircase", t0)


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
    return with_staircase(kept, found, config, "ends_staircase", t0)
