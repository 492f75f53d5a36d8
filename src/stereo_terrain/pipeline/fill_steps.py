"""The disparity stage's fills as a frame runs them (:meth:`Pipeline.run`): the planar fill
(:mod:`stereo_terrain.stereo.fill`), then the Manhattan fill
(:mod:`stereo_terrain.stereo.manhattan`) once up and a horizontal direction of the scene
are known; and, without a rig, the Manhattan fill again once the scene has fixed up."""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np

from ..cloud import GridSample, sample_disparity
from ..frames import Transform
from ..gravity import SceneLines, estimate_up, horizontal_direction
from ..gravity.from_lines import level_turn_deg
from ..planes.orientation import VERTICAL, PlaneSet
from ..rectify import RectifiedPair
from ..stereo import DisparityMap
from ..stereo.fill import FlatRegions, fill_planar_regions
from ..stereo.manhattan import fill_manhattan_faces
from .config import PipelineConfig

#: Up in the yaw frame.
_UP = np.array([0.0, 0.0, 1.0])
_UP.setflags(write=False)


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
        unsure (``fill.manhattan_max_up_sigma_deg``). :func:`fill_faces_later` runs it
        once the scene has fixed up.
    waited_for_horizontal : bool
        Up was known but the image's lines gave no horizontal direction of the scene:
        :func:`fill_faces_later` runs the fill with the one the frame's vertical planes
        give.
    """

    disparity: DisparityMap = field(repr=False)
    planar: DisparityMap = field(repr=False)
    regions: FlatRegions = field(repr=False)
    waited_for_up: bool = False
    waited_for_horizontal: bool = False

    @property
    def waited(self) -> bool:
        """The Manhattan fill waited for up or for a horizontal direction."""
        return self.waited_for_up or self.waited_for_horizontal


def known_up(rig_up: np.ndarray | None, lines: SceneLines) -> np.ndarray | None:
    """Up in the rectified camera where the frame knows it before its planes: the rig's
    (``rig_up``), else the image's vertical lines' when they fix it; else None."""
    if rig_up is not None:
        return rig_up
    if lines.up is not None and lines.up.ok:
        up: np.ndarray = lines.up.up
        return up
    return None


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
    up, horizontal = known_up(rig_up, lines), lines.horizontal
    if up is not None:
        horizontal = _without_sloped_lines(horizontal, lines, pair, up, planar, config)
    if up is None:
        coarse = estimate_up(camera_sample(planar, config), config.gravity)
        if coarse.ok and coarse.sigma_deg <= config.fill.manhattan_max_up_sigma_deg:
            up = coarse.up
            found = horizontal_direction(lines.segments, pair.rectification, up, config.vanishing)
            horizontal = _without_sloped_lines(found, lines, pair, up, planar, config)
    if up is None:
        return FilledFaces(planar, planar, regions, waited_for_up=True)
    if horizontal is None:
        return FilledFaces(planar, planar, regions, waited_for_horizontal=True)
    return FilledFaces(_manhattan(disp, planar, regions, pair, up, horizontal, config), planar, regions)


def fill_faces_later(
    disp: DisparityMap,
    faces: FilledFaces,
    pair: RectifiedPair,
    lines: SceneLines,
    planes: PlaneSet,
    T_yaw_camera: Transform,
    config: PipelineConfig,
) -> DisparityMap | None:
    """The Manhattan fill that :func:`fill_faces` left (``faces.waited``), once the frame is
    levelled: up is the yaw frame's (``T_yaw_camera``: the rig's, or the scene's from its
    planes and lines); the horizontal direction the image's lines give for it, else the
    normal of the frame's largest vertical plane (``planes``, in the yaw frame: a riser or
    a wall, either of the scene's two vertical families). ``disp`` is the matcher's
    disparity. None when there is no horizontal direction (nothing to fill)."""
    to_camera = T_yaw_camera.inverse()
    up = to_camera.apply_vectors(_UP)
    found = horizontal_direction(lines.segments, pair.rectification, up, config.vanishing)
    horizontal = _without_sloped_lines(found, lines, pair, up, disp, config)
    if horizontal is None:
        vertical = [s for s in planes.segments if s.kind == VERTICAL]
        if not vertical:
            return None
        n = max(vertical, key=lambda s: s.count).plane.normal * np.array([1.0, 1.0, 0.0])
        horizontal = to_camera.apply_vectors(n / float(np.linalg.norm(n)))
    return _manhattan(disp, faces.planar, faces.regions, pair, up, horizontal, config)


def _without_sloped_lines(
    horizontal: np.ndarray | None,
    lines: SceneLines,
    pair: RectifiedPair,
    up: np.ndarray,
    disp: DisparityMap,
    config: PipelineConfig,
) -> np.ndarray | None:
    """The scene's horizontal direction from the image's lines (``horizontal``, in the
    rectified camera) found again without the segments that ``disp`` shows sloped
    (``vanishing.horizontal_max_slope_deg``, :func:`~stereo_terrain.gravity.from_lines.sloped_segments`):
    ``horizontal`` itself where the two lie within ``vanishing.horizontal_window_deg`` of each
    other (modulo 90 deg; the sloped lines did not move the peak), else the new one (None
    where the level lines are too few for one). None where ``horizontal`` is None."""
    v = config.vanishing
    if horizontal is None or v.horizontal_max_slope_deg <= 0:
        return horizontal
    again = horizontal_direction(lines.segments, pair.rectification, up, v, disparity=disp.disparity)
    if again is None:
        return None
    return horizontal if level_turn_deg(again, horizontal) <= v.horizontal_window_deg else again


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


def camera_sample(disp: DisparityMap, config: PipelineConfig) -> GridSample:
    """The grid sample of ``disp`` in the rectified camera frame that the gravity and plane
    stages read (``config.cloud``, ``orientation.target_points`` samples)."""
    return sample_disparity(
        disp, _identity_camera_rect(), config.cloud, target_points=config.orientation.target_points
    )


@functools.cache
def _identity_camera_rect() -> Transform:
    """The identity of ``camera_rect``, built once (a Transform checks its matrix when
    built: issue 13)."""
    return Transform.identity("camera_rect")
