"""Gravity from the scene: "up" from its plane families (Manhattan structure).

Without a rig or an IMU the pipeline still needs the gravity-aligned ``yaw`` frame. A
floor alone is a poor guide on stairs (a level camera close to the first riser sees only
a thin strip of floor, or none). Built scenes are made of horizontal surfaces (floor,
treads, landings) and vertical ones (risers, walls), so "up" is the direction that is
*parallel* to the normals of the horizontal family and *orthogonal* to those of every
vertical family: a tread gives it directly, a riser and a side wall together give it as
the cross product of their normals. The only prior is a weak one: the camera is roughly
upright (``prior_cone_deg``).

Two stages, one on each side of the plane stage:

1. :func:`estimate_up` -- coarse, from the local normals of the grid sample
   (camera frame). MSAC over "up" hypotheses: a sample normal near the prior (a
   horizontal surface), or the cross product of two sample normals far from it (two
   vertical surfaces); each sample scores by the truncated squared sine of its angle to
   the nearest family (parallel or orthogonal to up). The winner is refined by weighted
   least squares (smallest eigenvector of ``sum_v n n^T - sum_h n n^T``) and its 1-sigma
   comes from a jackknife over image blocks (neighbouring samples share pixels, so the
   blocks, not the samples, are independent). Accurate to a few degrees: enough for the
   orientation method's 6 deg tolerance.
2. :func:`refine_up_from_planes` -- fine, from the extracted planes, each weighted by how
   well its fit fixes its normal (scatter of its inliers; a riser 0.17 m tall fixes its
   tilt about the horizontal axis poorly, a wall fixes it well), plus a per-plane
   structural floor (real floors slope, real walls lean) of ``structure_sigma_deg``.
   Gauss-Newton on the sphere; the covariance gives the reported uncertainty.

With a rig the same estimate checks the rig: a disagreement above
``rig_tolerance_deg`` is reported in the result (the rig is still used).

The same up is found from the image's lines, independent of the disparity: the vanishing
point of its vertical lines, and the scene's horizontal direction for the Manhattan fill
(:mod:`.from_lines`), and, where the planes leave up unsure, the Manhattan frame of all
the lines with the planes' up as prior (:mod:`.line_frame`).

Files, each a part of the stage:

- ``config.py``: :class:`GravityConfig`, and what an estimate reports
  (:class:`GravityEstimate`, :class:`GravityReport`);
- ``geometry.py``: angles, the tangent plane of a direction, and the transforms that level
  a frame (:func:`levelling`, :func:`yaw_frame_from_up`);
- ``from_normals.py``: stage 1, :func:`estimate_up`, and :func:`floor_up`;
- ``from_planes.py``: stage 2, :func:`refine_up_from_planes`;
- ``from_lines/``: up from the vertical lines (:func:`up_from_vertical_lines`), the
  scene's lines and horizontal direction (:func:`scene_lines`,
  :func:`horizontal_direction`), the two estimates combined (:func:`combine_with_lines`);
- ``line_frame.py``: up from the Manhattan frame of all the lines;
- ``_kernels.py``: the compiled inner loops of stage 1 and of :func:`floor_up`.
"""

from .config import GravityConfig, GravityEstimate, GravityReport
from .from_lines import (
    SceneLines,
    VerticalLinesConfig,
    combine_with_lines,
    horizontal_direction,
    line_segments,
    scene_lines,
    scene_segments,
    up_from_vertical_lines,
)
from .from_normals import estimate_up, floor_up, load_gravity_kernels
from .from_planes import refine_up_from_planes
from .geometry import CAMERA_UP, angle_deg, levelling, rotation_between, yaw_frame_from_up
from .line_frame import up_from_line_frame, up_from_lines_and_planes

__all__ = [
    "CAMERA_UP",
    "GravityConfig",
    "GravityEstimate",
    "GravityReport",
    "SceneLines",
    "VerticalLinesConfig",
    "angle_deg",
    "combine_with_lines",
    "estimate_up",
    "floor_up",
    "horizontal_direction",
    "levelling",
    "line_segments",
    "load_gravity_kernels",
    "refine_up_from_planes",
    "rotation_between",
    "scene_lines",
    "scene_segments",
    "up_from_line_frame",
    "up_from_lines_and_planes",
    "up_from_vertical_lines",
    "yaw_frame_from_up",
]
