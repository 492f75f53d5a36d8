"""The disparity stage's fills as a frame runs them (:meth:`Pipeline.run`): the planar fill
(:mod:`stereo_terrain.stereo.fill`), then the Manhattan fill
(:mod:`stereo_terrain.stereo.manhattan`) once up and a horizontal direction of the scene
are known; and, without a rig, the Manhattan fill again once the scene has fixed up."""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np

from ..cloud import sample_disparity
from ..frames import Transform
from ..gravity import SceneLines, estimate_up, horizontal_direction
from ..rectify import RectifiedPair
from ..stereo import DisparityMap
from ..stereo.fill import FlatRegions, fill_planar_regions
from ..stereo.manhattan import fill_manhattan_faces
from .config import PipelineConfig


@dataclass(frozen=True)
class FilledFaces:
    """What the fills made of one frame's disparity.

    Attributes
    ----------
    disparity : DisparityMap
        The matcher's disparity with the texture-poor faces filled.
    planar : DisparityMap
        After the planar fill alone (what a later Manhattan fill starts from).
    regions : FlatRegions
        The regions the Manhattan fill may take (less those refused as an occluder's).
    waited_for_up : bool
        The Manhattan fill did not run for want of up: no rig, the image's vertical lines
        did not fix it, and the first estimate from the planar-filled disparity was too
        unsure (``fill.manhattan_max_up_sigma_deg``). :func:`fill_faces_with_up` runs it
        once the scene has fixed up.
    """

    disparity: DisparityMap = field(repr=False)
    planar: DisparityMap = field(repr=False)
    regions: FlatRegions = field(repr=False)
    waited_for_up: bool = False


def fill_faces(
    disp: DisparityMap,
    pair: RectifiedPair,
    flat: FlatRegions,
    lines: SceneLines | None,
    rig_up: np.ndarray | None,
    manhattan: bool,
    config: PipelineConfig,
) -> FilledFaces:
    """Texture-poor faces of ``disp``: the planar fill (disparity from their outline), then
    the Manhattan fill (faces with one end in view: planes of the scene's three
    directions) when ``manhattan`` and up and a horizontal direction are known: up from
    the rig (``rig_up``, in the rectified camera), else from the image's vertical lines
    (``lines``), else (they do not fix it) a first estimate from the planar-filled
    disparity's planes."""
    occluded: list[int] = []
    values, filled = fill_planar_regions(
        disp.disparity,
        pair.left,
        config.fill,
        max_disparity_px=disp.max_disparity_px,
        valid=pair.rectification.valid_left,
        regions=flat,
        occluded=occluded,
    )
    planar = dataclasses.replace(disp, disparity=values, filled=filled)
    regions = flat.without(occluded) if occluded else flat  # an occluder's edge holds them
    if not manhattan or lines is None:
        return FilledFaces(planar, planar, regions)
    up, horizontal = rig_up, lines.horizontal
    if up is None and lines.up is not None and lines.up.ok:
        up = lines.up.up
    elif up is None:
        first = sample_disparity(
            planar, identity_camera_rect(), config.cloud, target_points=config.orientation.target_points
        )
        coarse = estimate_up(first, config.gravity)
        if coarse.ok and coarse.sigma_deg <= config.fill.manhattan_max_up_sigma_deg:
            up = coarse.up
            horizontal = horizontal_direction(lines.segments, pair.rectification, up, config.vanishing)
    if up is None:
        return FilledFaces(planar, planar, regions, waited_for_up=True)
    if horizontal is None:
        return FilledFaces(planar, planar, regions)
    return FilledFaces(_manhattan(disp, planar, regions, pair, up, horizontal, config), planar, regions)


def fill_faces_with_up(
    disp: DisparityMap,
    faces: FilledFaces,
    pair: RectifiedPair,
    lines: SceneLines,
    up: np.ndarray,
    config: PipelineConfig,
) -> DisparityMap | None:
    """The Manhattan fill that :func:`fill_faces` left for want of up (``faces.waited_for_up``),
    with ``up`` (in the rectified camera) now fixed by the scene: the frame's planes and
    lines. ``disp`` is the matcher's disparity. None when the image's lines give no
    horizontal direction for this up (nothing to fill)."""
    horizontal = horizontal_direction(lines.segments, pair.rectification, up, config.vanishing)
    if horizontal is None:
        return None
    return _manhattan(disp, faces.planar, faces.regions, pair, up, horizontal, config)


def _manhattan(
    disp: DisparityMap,
    planar: DisparityMap,
    regions: FlatRegions,
    pair: RectifiedPair,
    up: np.ndarray,
    horizontal: np.ndarray,
    config: PipelineConfig,
) -> DisparityMap:
    """:func:`fill_manhattan_faces` on the planar fill's output ``planar``, its support read
    from the matcher's ``disp``."""
    assert planar.filled is not None
    values, filled = fill_manhattan_faces(
        disp.disparity,
        planar.disparity,
        planar.filled,
        regions,
        pair.left,
        pair.rectification,
        up,
        horizontal,
        config.fill,
        max_disparity_px=disp.max_disparity_px,
    )
    return dataclasses.replace(disp, disparity=values, filled=filled)


@functools.cache
def identity_camera_rect() -> Transform:
    """The identity of ``camera_rect``, built once (a Transform checks its matrix when
    built: issue 13)."""
    return Transform.identity("camera_rect")
