"""The orchestrator: config + stages -> :class:`TerrainResult` (the JSON contract).

::

    raw pair --rectify--> RectifiedPair --stereo--> DisparityMap --cloud--> PointCloud
      --(T_yaw_camera)--> PointCloud(yaw) --planes--> PlaneSet --terrain--> StairModel
      --swing--> SwingPlan

The gravity-aligned frame comes from the rig (``T_body_camera`` and body roll/pitch, the
paper's eq. 1). Without a rig "up" is found in the scene's plane families
(``gravity_source == "scene"``, :mod:`stereo_terrain.gravity`): the direction parallel to
the normals of its horizontal surfaces and orthogonal to those of its vertical ones. With
a rig the same estimate checks the rig.

Package layout (each module imports, when loaded, only those before it): ``config``
(:class:`PipelineConfig`, from a mapping or YAML) -> ``result`` (:class:`TerrainResult`
and its JSON) -> ``gravity_steps`` (the levelling of the yaw frame without a rig, the
origin on the floor, the rig check, the gravity report) -> ``fill_steps`` (the fills as
a frame runs them) -> ``second_opinions`` (when a pass's terrain wants another opinion;
the far planes, the corroborated up, the redrawn planes) -> ``threads`` (BLAS held to
one thread, the worker thread) -> ``warm_up`` (:func:`warm_up_kernels`; it builds a
:class:`Pipeline` when called) -> ``core`` (:class:`Pipeline`, the stage sequence and its
passes).
"""

from __future__ import annotations

from .config import PLANE_METHODS, PipelineConfig
from .core import Pipeline
from .result import RESULT_VERSION, TerrainResult
from .warm_up import _warm_up_scene as _warm_up_scene  # private, imported by the tests
from .warm_up import warm_up_kernels

__all__ = [
    "PLANE_METHODS",
    "RESULT_VERSION",
    "Pipeline",
    "PipelineConfig",
    "TerrainResult",
    "warm_up_kernels",
]
