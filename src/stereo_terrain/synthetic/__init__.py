"""Synthetic stereo scenes with exact ground truth: stairs, boxes or nothing on a ground plane.

The renderer drives the demo, the tests and the benchmarks. It ray casts an *unrectified*
stereo pair through lens distortion, so that every stage of the real pipeline (rectify ->
SGM -> cloud -> planes -> stairs) has work to do:

* both cameras have OpenCV distortion (``k1, k2, p1, p2, k3``), slightly different
  intrinsics and a small relative rotation; the exact values are in the calibration;
* every (sub)pixel is undistorted to a ray by Newton's method (accurate to ~1e-9 px),
  cast against the ground plane, an optional back wall, optional side walls, the
  obstacle's boxes (slab method) and optional handrails and balusters, textured in
  physical face coordinates (metres, identical in both views, trilinear mip-mapping;
  optional nosing strips at the tread edges), shaded (Lambertian + ambient),
  supersampled and averaged;
* then optics and sensor: blur, vignetting, gain/offset difference of the right
  camera, Gaussian (optionally signal-dependent) noise, 8-bit quantisation, optional
  JPEG compression.

:func:`random_scene_spec` draws scenes of two profiles: ``"default"`` (the scenes of
version 1, unchanged) and ``"realistic"`` (webcam photos of real stairs: a level camera,
side walls, handrails, wood and paint, strong distortion, JPEG).

Scene frame
-----------
Everything is built in the ``yaw`` frame of ``docs/conventions.md``: z up (gravity),
x forward (robot heading), origin on the ground below the left camera's mount (the body
origin). The ground is the plane ``z = 0``. An obstacle has an *axis*
``u = (cos yaw, sin yaw, 0)`` (up the stairs) and a lateral axis
``v = (-sin yaw, cos yaw, 0)``; its first riser (box front) is the plane
``u . p = distance_m * cos(yaw)``, so ``distance_m`` is where the frame's x axis
(``y = 0``) meets that plane, as in the terrain result of CONVENTIONS.md.

Ground truth (``SyntheticScene.truth``) uses the keys and meaning of the terrain result
(version 1), plus the exact ``planes`` (ground, each riser and tread, back wall, side
walls), ``camera_height_m``, ``pitch_down_rad``, ``weak_texture``, ``image_size`` and
``profile``. The rig (``rig.yaml``) is the true mounting: with its ``body_rpy`` it gives
the true gravity direction in the camera frame.

Package layout (data flows one way, each module imports only those before it):
``spec`` (specs and their checks) -> ``camera`` (lens model, projection, rig) ->
``geometry`` (boxes, ray casting) -> ``appearance`` (textures, shading) -> ``sensor``
(optics, noise, 8-bit) -> ``render`` (:func:`render_scene`) -> ``random_scenes``
(:func:`random_scene_spec`; a package: ``draws`` -> ``default_profile``,
``realistic_profile``) -> ``writing`` (:func:`write_scene`, :func:`render_scenes`).

Examples
--------
>>> scene = render_scene(default_scene_spec())
>>> scene.left.shape, scene.left.dtype, scene.truth["obstacle"]
((480, 640), dtype('uint8'), 'stairs')
"""

from __future__ import annotations

from .camera import _undistort as _undistort  # private, imported by the tests
from .random_scenes import oakd_overrides, random_scene_spec
from .render import SyntheticScene, render_scene
from .spec import (
    TEXTURE_KINDS,
    BoxSpec,
    CameraIntrinsics,
    SceneSpec,
    StairSpec,
    SurfaceSpec,
    default_scene_spec,
)
from .writing import render_scenes, write_scene

__all__ = [
    "TEXTURE_KINDS",
    "BoxSpec",
    "CameraIntrinsics",
    "SceneSpec",
    "StairSpec",
    "SurfaceSpec",
    "SyntheticScene",
    "default_scene_spec",
    "oakd_overrides",
    "random_scene_spec",
    "render_scene",
    "render_scenes",
    "write_scene",
]
