"""Gravity from the image: "up" as the vanishing point of the scene's vertical lines.

Gravity from the scene's plane families (:mod:`stereo_terrain.gravity`) needs planes, and
planes need disparities: on the texture-poor faces of real staircases (paint, wood grain
seen head-on) the matcher's errors can make a junk plane look like a floor or a wall, and
the estimate is then off by 5-30 deg with a sigma that does not say so. The image itself
holds an independent witness: built scenes are full of vertical edges (wall corners, the
ends of the steps, door frames, newel posts, balusters), and the images of vertical 3D
lines all pass through one point, the vertical vanishing point ``v``, whose direction
``K^-1 v`` in the camera is "up" (Hartley & Zisserman, *Multiple View Geometry*, 8.6).
Their positions are exact to a fraction of a pixel whatever the disparity.

:func:`up_from_vertical_lines`:

1. line segments of the rectified left image (OpenCV's LSD, von Gioi et al. 2012), kept
   when long enough, inside the valid image and within ``max_tilt_deg`` of the image's
   vertical (the weak prior: the camera is roughly upright);
2. MSAC over pairs of segments: the hypothesis is their intersection, a segment scores by
   the truncated squared angle between it and the line from its midpoint to the point;
3. the winner refined by length-weighted least squares on its inliers (the null vector of
   their stacked homogeneous lines), its 1-sigma from a bootstrap over the inliers, with
   a floor for the structure (real walls and door frames lean by a few tenths of a degree).

An estimate with fewer than ``min_inliers`` segments or a sigma above ``max_sigma_deg`` is
returned with ``ok=False``: two segments always meet somewhere.

The package's files:

- ``config.py``: :class:`VerticalLinesConfig`;
- ``segments.py``: the LSD segments clipped to the valid region (:func:`line_segments`)
  and their rays in the camera (:func:`normalised_ends`);
- ``vanishing.py``: :func:`up_from_vertical_lines`, and :func:`combine_with_lines`;
- ``horizontal.py``: :func:`horizontal_direction`, :func:`sloped_segments`,
  :func:`level_turn_deg`;
- ``scene.py``: one LSD pass's segments sorted for gravity, the fills and the terrain
  (:func:`scene_lines`, :func:`scene_segments`, :class:`SceneLines`).
"""

from .config import VerticalLinesConfig
from .horizontal import horizontal_direction, level_turn_deg, sloped_segments
from .scene import SceneLines, scene_lines, scene_segments
from .segments import line_segments, normalised_ends, unit_rows
from .vanishing import combine_with_lines, up_from_vertical_lines

__all__ = [
    "SceneLines",
    "VerticalLinesConfig",
    "combine_with_lines",
    "horizontal_direction",
    "level_turn_deg",
    "line_segments",
    "normalised_ends",
    "scene_lines",
    "scene_segments",
    "sloped_segments",
    "unit_rows",
    "up_from_vertical_lines",
]
