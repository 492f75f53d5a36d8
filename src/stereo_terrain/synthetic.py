"""Synthetic stereo scenes with exact ground truth: stairs, boxes or nothing on a ground plane.

The renderer drives the demo, the tests and the benchmarks. It ray casts an *unrectified*
stereo pair through lens distortion, so that every stage of the real pipeline (rectify ->
SGM -> cloud -> planes -> stairs) has work to do:

* both cameras have OpenCV distortion (``k1, k2, p1, p2, k3``), slightly different
  intrinsics and a small relative rotation; the exact values are in the calibration;
* every (sub)pixel is undistorted to a ray by Newton's method (accurate to ~1e-9 px),
  cast against the ground plane, an optional back wall and the obstacle's boxes (slab
  method), textured in physical face coordinates (metres, identical in both views,
  trilinear mip-mapping), shaded (Lambertian + ambient), supersampled and averaged;
* then optics and sensor: mild blur, vignetting, gain/offset difference of the right
  camera, Gaussian noise, 8-bit quantisation.

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
(version 1), plus the exact ``planes`` (ground, each riser and tread, back wall),
``camera_height_m``, ``pitch_down_rad``, ``weak_texture`` and ``image_size``.

Examples
--------
>>> scene = render_scene(default_scene_spec())
>>> scene.left.shape, scene.left.dtype, scene.truth["obstacle"]
((480, 640), dtype('uint8'), 'stairs')
"""

from __future__ import annotations

import dataclasses
import json
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np

from .calibration import StereoCalibration, write_opencv_yaml
from .errors import InputError
from .frames import Rig, Transform, camera_mount, save_rig

__all__ = [
    "TEXTURE_KINDS",
    "BoxSpec",
    "CameraIntrinsics",
    "SceneSpec",
    "StairSpec",
    "SurfaceSpec",
    "SyntheticScene",
    "default_scene_spec",
    "random_scene_spec",
    "render_scene",
    "render_scenes",
    "write_scene",
]

#: Texture kinds a :class:`SurfaceSpec` may name.
TEXTURE_KINDS = ("noise", "wood", "carpet", "tiles", "speckle")

#: Side of a square texture tile in texels (a power of two, so wrapping is a bit mask).
_TILE_PX = 512

#: Face groups: each has its own surface (texture, albedo, contrast).
_GROUPS = ("ground", "tread", "riser", "side", "wall")

# Face ids of the ray caster: 0 nothing (sky), 1 ground, 2 back wall, then 6 per box:
# 3 + 6 i + k, k = 0 front (-u, riser), 1 back (+u), 2 right (-v), 3 left (+v),
# 4 bottom (-z), 5 top (+z, tread).
_FACE_SKY, _FACE_GROUND, _FACE_WALL, _FACE_BOX0 = 0, 1, 2, 3

# Face-coordinate modes: which two coordinates (metres) a texture is laid out on.
_MODE_XY, _MODE_BA, _MODE_BZ, _MODE_AZ = 0, 1, 2, 3

_NEWTON_TOL_PX = 1e-6
_NEWTON_MAX_ITER = 30


# --------------------------------------------------------------------------- checks


def _check_finite(owner: str, name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{owner}.{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{owner}.{name} must be finite, got {value!r}")
    return v


def _check_range(
    owner: str, name: str, value: Any, lo: float, hi: float, unit: str = "", *, lo_open: bool = False
) -> float:
    v = _check_finite(owner, name, value)
    if (v <= lo if lo_open else v < lo) or v > hi:
        bracket = "(" if lo_open else "["
        raise InputError(f"{owner}.{name} must be in {bracket}{lo:g}, {hi:g}]{unit}, got {value!r}")
    return v


def _check_positive(owner: str, name: str, value: Any, hi: float = math.inf, unit: str = " m") -> float:
    v = _check_finite(owner, name, value)
    if not v > 0.0:
        raise InputError(f"{owner}.{name} must be > 0{unit}, got {value!r}")
    if v > hi:
        raise InputError(f"{owner}.{name} must be <= {hi:g}{unit}, got {value!r}")
    return v


def _check_int(owner: str, name: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputError(f"{owner}.{name} must be an integer, got {value!r}")
    if not lo <= int(value) <= hi:
        raise InputError(f"{owner}.{name} must be in [{lo}, {hi}], got {value}")
    return int(value)


def _check_tuple(owner: str, name: str, value: Any, n: int) -> tuple[float, ...]:
    try:
        vals = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise InputError(f"{owner}.{name} must be {n} numbers, got {value!r}") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{owner}.{name} must be {n} finite numbers, got {value!r}")
    return vals


def _check_image_size(value: Any, owner: str = "SceneSpec") -> tuple[int, int]:
    try:
        w, h = value
    except (TypeError, ValueError):
        raise InputError(f"{owner}.image_size must be (width, height), got {value!r}") from None
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, int | np.integer) or not 8 <= v <= 8192:
            raise InputError(
                f"{owner}.image_size must be (width, height) with integers in [8, 8192] px, got {value!r}"
            )
    return int(w), int(h)


def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


# --------------------------------------------------------------------------- specs


@dataclass(frozen=True)
class StairSpec:
    """A straight staircase standing on the ground; its top tread continues as a landing.

    Attributes
    ----------
    n_steps : int
        Number of risers (1..20); tread ``n_steps`` is the landing.
    rise_m : float
        Height of every riser, metres.
    run_m : float
        Depth of treads 1..n-1 along the stair axis, metres.
    width_m : float
        Width across the stair axis, metres.
    distance_m : float
        Where the yaw frame's x axis (``y = 0``) meets the first riser plane, metres.
    yaw_rad : float
        Stair axis w.r.t. the frame's x axis, radians, ``|yaw| < 80 deg``.
    lateral_m : float
        Offset of the centre of the first riser from the point where the x axis meets it,
        along ``v = (-sin yaw, cos yaw, 0)`` (positive: to the left), metres: the centre of
        the first riser's bottom edge is ``(distance_m, 0, 0) + lateral_m * v``.
    landing_m : float
        Depth of the landing (the top tread), metres.
    """

    n_steps: int
    rise_m: float
    run_m: float
    width_m: float
    distance_m: float
    yaw_rad: float = 0.0
    lateral_m: float = 0.0
    landing_m: float = 1.0

    def __post_init__(self) -> None:
        o = "StairSpec"
        _set(self, "n_steps", _check_int(o, "n_steps", self.n_steps, 1, 20))
        _set(self, "rise_m", _check_positive(o, "rise_m", self.rise_m, 1.0))
        _set(self, "run_m", _check_positive(o, "run_m", self.run_m, 2.0))
        _set(self, "width_m", _check_positive(o, "width_m", self.width_m, 20.0))
        _set(self, "distance_m", _check_positive(o, "distance_m", self.distance_m, 50.0))
        _set(self, "yaw_rad", _check_range(o, "yaw_rad", self.yaw_rad, -1.4, 1.4, " rad"))
        _set(self, "lateral_m", _check_range(o, "lateral_m", self.lateral_m, -20.0, 20.0, " m"))
        _set(self, "landing_m", _check_positive(o, "landing_m", self.landing_m, 50.0))


@dataclass(frozen=True)
class BoxSpec:
    """A box standing on the ground (an obstacle of one step).

    Attributes
    ----------
    height_m, depth_m, width_m : float
        Size along z, along the box axis ``u`` and across it, metres.
    distance_m : float
        Where the frame's x axis meets the plane of the front face, metres.
    yaw_rad : float
        Box axis w.r.t. the frame's x axis, radians.
    lateral_m : float
        Offset of the front face's centre from the point where the x axis meets it,
        along ``v``, metres (as for :class:`StairSpec`).
    """

    height_m: float
    depth_m: float
    width_m: float
    distance_m: float
    yaw_rad: float = 0.0
    lateral_m: float = 0.0

    def __post_init__(self) -> None:
        o = "BoxSpec"
        _set(self, "height_m", _check_positive(o, "height_m", self.height_m, 5.0))
        _set(self, "depth_m", _check_positive(o, "depth_m", self.depth_m, 20.0))
        _set(self, "width_m", _check_positive(o, "width_m", self.width_m, 20.0))
        _set(self, "distance_m", _check_positive(o, "distance_m", self.distance_m, 50.0))
        _set(self, "yaw_rad", _check_range(o, "yaw_rad", self.yaw_rad, -1.4, 1.4, " rad"))
        _set(self, "lateral_m", _check_range(o, "lateral_m", self.lateral_m, -20.0, 20.0, " m"))


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole + OpenCV distortion of one camera (pixels of the scene's image size).

    Attributes
    ----------
    fx, fy, cx, cy : float
        Focal lengths and principal point, pixels (pixel centres at integer coordinates).
    distortion : (5,) tuple of float
        OpenCV ``(k1, k2, p1, p2, k3)``; must stay invertible over the image.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        o = "CameraIntrinsics"
        _set(self, "fx", _check_positive(o, "fx", self.fx, unit=" px"))
        _set(self, "fy", _check_positive(o, "fy", self.fy, unit=" px"))
        _set(self, "cx", _check_finite(o, "cx", self.cx))
        _set(self, "cy", _check_finite(o, "cy", self.cy))
        _set(self, "distortion", _check_tuple(o, "distortion", self.distortion, 5))

    @property
    def matrix(self) -> np.ndarray:
        """(3, 3) float64 camera matrix ``K``."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class SurfaceSpec:
    """Appearance of one face group (ground, treads, risers, stair sides, back wall).

    Attributes
    ----------
    texture : str
        One of :data:`TEXTURE_KINDS`.
    tile_m : float
        Physical side of one texture tile (512 texels), metres.
    albedo : float
        Reflectance in (0, 1].
    contrast : float
        Relative standard deviation of the texture (reflectance = albedo * (1 + contrast *
        t), ``t`` of unit std). A weakly textured (painted) face has a contrast of about
        1-3 grey levels divided by its nominal grey level.
    """

    texture: str = "noise"
    tile_m: float = 0.8
    albedo: float = 0.5
    contrast: float = 0.15

    def __post_init__(self) -> None:
        o = "SurfaceSpec"
        if self.texture not in TEXTURE_KINDS:
            raise InputError(f"{o}.texture must be one of {TEXTURE_KINDS}, got {self.texture!r}")
        _set(self, "tile_m", _check_positive(o, "tile_m", self.tile_m, 100.0))
        _set(self, "albedo", _check_range(o, "albedo", self.albedo, 0.0, 1.0, lo_open=True))
        _set(self, "contrast", _check_range(o, "contrast", self.contrast, 0.0, 1.0))


def _default_camera(image_size: tuple[int, int]) -> CameraIntrinsics:
    w, h = image_size
    f = 0.85 * w
    return CameraIntrinsics(f, f, (w - 1) / 2.0, (h - 1) / 2.0)


@dataclass(frozen=True)
class SceneSpec:
    """Everything that defines a synthetic scene; :func:`render_scene` is a pure function of it.

    Attributes
    ----------
    obstacle : StairSpec, BoxSpec or None
    camera_height_m : float
        Height of the left camera above the body origin (on the ground), metres.
    pitch_down_rad : float
        Camera pitch below the body's x axis, radians (``camera_mount``).
    baseline_m : float
        Distance between the camera centres, metres (``|T|`` of the calibration).
    image_size : (width, height), pixels
    body_rpy : (3,) float, radians
        Body roll, pitch (and ignored yaw) w.r.t. gravity; stored in the rig.
    weak_texture : bool
        True when risers/sides (and maybe treads) are painted with very low contrast.
        Informational: the contrast itself is in the surfaces.
    seed : int
        Seeds the texture tiles, per-face texture offsets and albedo jitter, and the
        sensor noise.
    left_camera, right_camera : CameraIntrinsics or None
        None: an ideal camera, ``fx = fy = 0.85 * width``, centred, no distortion (the
        right camera then copies the left one).
    right_rotvec_rad : (3,) float
        Rodrigues vector of ``R`` (right camera from left, ``X_right = R X_left + T``).
    right_offset_m : (2,) float
        y and z of the right camera centre in the left camera frame, metres; its x is
        chosen so that the centres are ``baseline_m`` apart.
    right_disturbance_rotvec_rad : (3,) float
        Rodrigues vector of a rotation of the right camera about its own centre, in its
        own (raw, optical) frame, that happened *after* calibration: the images are
        rendered with it, the calibration written is the undisturbed one. Models a rig
        knocked out of calibration (issue 5); zero by default. At most 0.1 rad.
    back_wall_m : float or None
        A vertical wall facing the camera on the plane ``u . p = back_wall_m`` (obstacle
        axis; frame x when there is no obstacle); must lie beyond the obstacle.
    ground, tread, riser, side, wall : SurfaceSpec
        Appearance of the face groups (a box uses riser = front, tread = top, side).
    light_azimuth_rad, light_elevation_rad : float
        Direction toward the (directional) light in the yaw frame.
    ambient, diffuse : float
        Shade = ambient + diffuse * max(0, n . l).
    exposure : float
        Grey level of a white (albedo 1) surface with shade 1.
    sky_grey : float
        Grey level where a ray hits nothing.
    noise_sigma : (2,) float
        Std of the Gaussian sensor noise of the left and right camera, grey levels.
    right_gain, right_offset_grey : float
        Right image = gain * radiance + offset (the left has gain 1, offset 0).
    vignetting : float
        Relative darkening at the image corners (0 = none).
    blur_sigma_px : float
        Gaussian blur of the optics, pixels (0 = none).
    supersample : int
        Samples per pixel side (1..4); 2 means 2 x 2 samples.
    """

    obstacle: StairSpec | BoxSpec | None
    camera_height_m: float = 0.55
    pitch_down_rad: float = math.radians(15.0)
    baseline_m: float = 0.08
    image_size: tuple[int, int] = (640, 480)
    body_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    weak_texture: bool = False
    seed: int = 0
    left_camera: CameraIntrinsics | None = None
    right_camera: CameraIntrinsics | None = None
    right_rotvec_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    right_offset_m: tuple[float, float] = (0.0, 0.0)
    right_disturbance_rotvec_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    back_wall_m: float | None = None
    ground: SurfaceSpec = field(default_factory=lambda: SurfaceSpec("noise", 1.0, 0.45, 0.2))
    tread: SurfaceSpec = field(default_factory=lambda: SurfaceSpec("wood", 0.8, 0.6, 0.15))
    riser: SurfaceSpec = field(default_factory=lambda: SurfaceSpec("speckle", 0.7, 0.7, 0.15))
    side: SurfaceSpec = field(default_factory=lambda: SurfaceSpec("noise", 0.9, 0.5, 0.15))
    wall: SurfaceSpec = field(default_factory=lambda: SurfaceSpec("noise", 1.2, 0.6, 0.12))
    light_azimuth_rad: float = math.radians(150.0)
    light_elevation_rad: float = math.radians(55.0)
    ambient: float = 0.35
    diffuse: float = 0.6
    exposure: float = 210.0
    sky_grey: float = 200.0
    noise_sigma: tuple[float, float] = (1.5, 1.5)
    right_gain: float = 1.0
    right_offset_grey: float = 0.0
    vignetting: float = 0.0
    blur_sigma_px: float = 0.0
    supersample: int = 2

    def __post_init__(self) -> None:
        o = "SceneSpec"
        if self.obstacle is not None and not isinstance(self.obstacle, StairSpec | BoxSpec):
            raise InputError(
                f"{o}.obstacle must be a StairSpec, a BoxSpec or None, got {type(self.obstacle).__name__}"
            )
        _set(self, "camera_height_m", _check_positive(o, "camera_height_m", self.camera_height_m, 10.0))
        _set(
            self, "pitch_down_rad", _check_range(o, "pitch_down_rad", self.pitch_down_rad, -1.2, 1.2, " rad")
        )
        _set(self, "baseline_m", _check_positive(o, "baseline_m", self.baseline_m, 2.0))
        size = _check_image_size(self.image_size)
        _set(self, "image_size", size)
        rpy = _check_tuple(o, "body_rpy", self.body_rpy, 3)
        if abs(rpy[0]) > 0.5 or abs(rpy[1]) > 0.5:
            raise InputError(f"{o}.body_rpy roll and pitch must be within 0.5 rad, got {rpy}")
        _set(self, "body_rpy", rpy)
        if not isinstance(self.weak_texture, bool | np.bool_):
            raise InputError(f"{o}.weak_texture must be a bool, got {self.weak_texture!r}")
        _set(self, "weak_texture", bool(self.weak_texture))
        _set(self, "seed", _check_int(o, "seed", self.seed, 0, 2**63 - 1))
        left = self.left_camera if self.left_camera is not None else _default_camera(size)
        right = self.right_camera if self.right_camera is not None else left
        for name, cam in (("left_camera", left), ("right_camera", right)):
            if not isinstance(cam, CameraIntrinsics):
                raise InputError(f"{o}.{name} must be CameraIntrinsics or None, got {cam!r}")
            _check_distortion_invertible(cam, size, f"{o}.{name}")
        _set(self, "left_camera", left)
        _set(self, "right_camera", right)
        rv = _check_tuple(o, "right_rotvec_rad", self.right_rotvec_rad, 3)
        if math.hypot(*rv) > 0.2:
            raise InputError(f"{o}.right_rotvec_rad must be a rotation of <= 0.2 rad, got {rv}")
        _set(self, "right_rotvec_rad", rv)
        off = _check_tuple(o, "right_offset_m", self.right_offset_m, 2)
        if math.hypot(*off) > 0.5 * self.baseline_m:
            raise InputError(
                f"{o}.right_offset_m must be smaller than half the baseline "
                f"({0.5 * self.baseline_m:g} m), got {off}"
            )
        _set(self, "right_offset_m", off)
        dv = _check_tuple(o, "right_disturbance_rotvec_rad", self.right_disturbance_rotvec_rad, 3)
        if math.hypot(*dv) > 0.1:
            raise InputError(f"{o}.right_disturbance_rotvec_rad must be a rotation of <= 0.1 rad, got {dv}")
        _set(self, "right_disturbance_rotvec_rad", dv)
        if self.back_wall_m is not None:
            wall = _check_positive(o, "back_wall_m", self.back_wall_m, 200.0)
            end = _obstacle_far_end(self.obstacle)
            if wall <= end:
                raise InputError(
                    f"{o}.back_wall_m must lie beyond the obstacle's far end ({end:.3f} m "
                    f"along its axis), got {wall}"
                )
            _set(self, "back_wall_m", wall)
        for g in _GROUPS:
            if not isinstance(getattr(self, g), SurfaceSpec):
                raise InputError(f"{o}.{g} must be a SurfaceSpec, got {getattr(self, g)!r}")
        _set(self, "light_azimuth_rad", _check_finite(o, "light_azimuth_rad", self.light_azimuth_rad))
        _set(
            self,
            "light_elevation_rad",
            _check_range(o, "light_elevation_rad", self.light_elevation_rad, 0.0, math.pi / 2, " rad"),
        )
        _set(self, "ambient", _check_range(o, "ambient", self.ambient, 0.0, 2.0))
        _set(self, "diffuse", _check_range(o, "diffuse", self.diffuse, 0.0, 2.0))
        _set(self, "exposure", _check_positive(o, "exposure", self.exposure, 2000.0, unit=""))
        _set(self, "sky_grey", _check_range(o, "sky_grey", self.sky_grey, 0.0, 255.0))
        sig = _check_tuple(o, "noise_sigma", self.noise_sigma, 2)
        if min(sig) < 0.0 or max(sig) > 50.0:
            raise InputError(f"{o}.noise_sigma must be in [0, 50] grey levels, got {sig}")
        _set(self, "noise_sigma", sig)
        _set(self, "right_gain", _check_range(o, "right_gain", self.right_gain, 0.2, 5.0))
        _set(
            self,
            "right_offset_grey",
            _check_range(o, "right_offset_grey", self.right_offset_grey, -100.0, 100.0),
        )
        _set(self, "vignetting", _check_range(o, "vignetting", self.vignetting, 0.0, 0.9))
        _set(self, "blur_sigma_px", _check_range(o, "blur_sigma_px", self.blur_sigma_px, 0.0, 5.0, " px"))
        _set(self, "supersample", _check_int(o, "supersample", self.supersample, 1, 4))


def _obstacle_centre_b(obstacle: StairSpec | BoxSpec) -> float:
    """Lateral coordinate ``v . p`` of the obstacle's centre line, metres.

    The centre of the first riser's bottom edge is ``(distance_m, 0, 0) + lateral_m * v``.
    """
    return obstacle.lateral_m - obstacle.distance_m * math.sin(obstacle.yaw_rad)


def _obstacle_far_end(obstacle: StairSpec | BoxSpec | None) -> float:
    """Coordinate along the obstacle axis of its far end (0 without obstacle), metres."""
    if obstacle is None:
        return 0.0
    s0 = obstacle.distance_m * math.cos(obstacle.yaw_rad)
    if isinstance(obstacle, StairSpec):
        return s0 + (obstacle.n_steps - 1) * obstacle.run_m + obstacle.landing_m
    return s0 + obstacle.depth_m


# --------------------------------------------------------------------------- lens model


def _distort(x: np.ndarray, y: np.ndarray, dist: tuple[float, ...]):
    """OpenCV distortion of normalized coordinates and its Jacobian.

    Returns ``(xd, yd, dxd_dx, dxd_dy, dyd_dx, dyd_dy)``.
    """
    k1, k2, p1, p2, k3 = dist
    x2, y2, xy = x * x, y * y, x * y
    r2 = x2 + y2
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    g = 2.0 * k1 + r2 * (4.0 * k2 + 6.0 * k3 * r2)  # d radial / d r2 * 2
    xd = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2)
    yd = y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy
    a = radial + g * x2 + 2.0 * p1 * y + 6.0 * p2 * x
    b = g * xy + 2.0 * p1 * x + 2.0 * p2 * y
    d = radial + g * y2 + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, a, b, b, d


def _check_distortion_invertible(cam: CameraIntrinsics, size: tuple[int, int], name: str) -> None:
    """Raise unless the radial distortion is monotonic out to beyond the image corners."""
    k1, k2, _p1, _p2, k3 = cam.distortion
    w, h = size
    corners_x = np.array([-cam.cx, w - 1 - cam.cx]) / cam.fx
    corners_y = np.array([-cam.cy, h - 1 - cam.cy]) / cam.fy
    rd_max = float(np.sqrt(np.max(corners_x**2) + np.max(corners_y**2)))
    r = np.linspace(0.0, 4.0, 4001)
    r2 = r * r
    rd = r * (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)))
    slope = 1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + 7.0 * k3 * r2))
    bad = np.nonzero(slope < 0.2)[0]
    reach = rd[: bad[0]].max() if bad.size else rd.max()
    if reach < 1.05 * rd_max:
        raise InputError(
            f"{name}.distortion {cam.distortion} is not invertible over the image: the radial "
            f"model folds back at normalized radius {reach:.3f} < corner radius {rd_max:.3f}; "
            "use a smaller |k1| or a larger k2"
        )


def _undistort(u: np.ndarray, v: np.ndarray, cam: CameraIntrinsics):
    """Pixels -> undistorted normalized coordinates by Newton's method (float64).

    Returns ``(x, y, j00, j01, j10, j11)`` where ``j`` is the Jacobian of the undistorted
    coordinates w.r.t. the *distorted normalized* ones at the solution (to place sub-pixel
    samples to first order: an offset of 0.5 px changes them by ~1e-7 px).
    """
    xd = (u - cam.cx) / cam.fx
    yd = (v - cam.cy) / cam.fy
    x, y = xd.copy(), yd.copy()
    f = max(cam.fx, cam.fy)
    for _ in range(_NEWTON_MAX_ITER):
        fx_, fy_, a, b, c, d = _distort(x, y, cam.distortion)
        rx, ry = xd - fx_, yd - fy_
        det = a * d - b * c
        dx = (d * rx - b * ry) / det
        dy = (a * ry - c * rx) / det
        x += dx
        y += dy
        step = float(max(np.abs(dx).max(initial=0.0), np.abs(dy).max(initial=0.0))) * f
        if step < _NEWTON_TOL_PX:
            break
    else:  # pragma: no cover - excluded by _check_distortion_invertible
        raise InputError("undistortion did not converge; the lens distortion is too strong")
    _, _, a, b, c, d = _distort(x, y, cam.distortion)
    det = a * d - b * c
    return x, y, d / det, -b / det, -c / det, a / det


def _project(points_cam: np.ndarray, cam: CameraIntrinsics) -> np.ndarray:
    """(N, 3) camera-frame points -> (N, 2) pixels (NaN behind the camera)."""
    p = np.asarray(points_cam, dtype=np.float64)
    z = p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = p[:, 0] / z, p[:, 1] / z
    xd, yd, *_ = _distort(x, y, cam.distortion)
    uv = np.stack([cam.fx * xd + cam.cx, cam.fy * yd + cam.cy], axis=1)
    uv[~(z > 1e-6)] = np.nan
    return uv


# --------------------------------------------------------------------------- geometry


@dataclass(frozen=True)
class _Geometry:
    """Obstacle and wall in the obstacle's local frame ``(a, b, z) = (u . p, v . p, z)``."""

    cos_yaw: float
    sin_yaw: float
    boxes: np.ndarray  # (K, 6): a_lo, a_hi, b_lo, b_hi, z_lo, z_hi
    wall_a: float | None

    def to_local(self, x, y):
        return self.cos_yaw * x + self.sin_yaw * y, -self.sin_yaw * x + self.cos_yaw * y


def _scene_geometry(spec: SceneSpec) -> _Geometry:
    ob = spec.obstacle
    yaw = 0.0 if ob is None else ob.yaw_rad
    boxes = []
    if ob is not None:
        s0 = ob.distance_m * math.cos(ob.yaw_rad)
        end = _obstacle_far_end(ob)
        b_mid = _obstacle_centre_b(ob)
        b_lo, b_hi = b_mid - ob.width_m / 2, b_mid + ob.width_m / 2
        if isinstance(ob, StairSpec):
            # The staircase is the union of n boxes, box i from riser i to the far end of
            # the landing and up to tread i: the nearest hit of the union is the surface.
            for i in range(ob.n_steps):
                boxes.append([s0 + i * ob.run_m, end, b_lo, b_hi, 0.0, (i + 1) * ob.rise_m])
        else:
            boxes.append([s0, end, b_lo, b_hi, 0.0, ob.height_m])
    return _Geometry(
        math.cos(yaw), math.sin(yaw), np.array(boxes, dtype=np.float64).reshape(-1, 6), spec.back_wall_m
    )


def _cast(
    origin: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, geom: _Geometry
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest hit of rays ``origin + t d`` (yaw frame) with the scene.

    Returns ``t`` (inf where nothing is hit; the camera depth Z when ``d`` is the
    rotated ``(x, y, 1)`` of a camera ray) and the face id (int16).
    """
    n = dx.shape[0]
    t = np.full(n, np.inf, dtype=np.float32)
    face = np.zeros(n, dtype=np.int16)
    ox, oy, oz = (float(v) for v in origin)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        down = dz < 0
        t[down] = (-oz / dz[down]).astype(np.float32)
        face[down] = _FACE_GROUND
        if geom.wall_a is None and geom.boxes.shape[0] == 0:
            return t, face
        da, db = geom.to_local(dx, dy)
        oa, ob = geom.to_local(ox, oy)
        if geom.wall_a is not None:
            tw = (geom.wall_a - oa) / da
            m = (da > 0) & (tw < t)
            t[m] = tw[m]
            face[m] = _FACE_WALL
        if geom.boxes.shape[0] == 0:
            return t, face
        # Slab test (Kay & Kajiya) against the obstacle's bounding box first, then against
        # each box only for the rays that enter it.
        bb = np.array(
            [
                geom.boxes[:, 0].min(),
                geom.boxes[:, 1].max(),
                geom.boxes[:, 2].min(),
                geom.boxes[:, 3].max(),
                0.0,
                geom.boxes[:, 5].max(),
            ]
        )
        tiny = np.float32(1e-12)
        inv_a = 1.0 / np.where(np.abs(da) < tiny, tiny, da)
        inv_b = 1.0 / np.where(np.abs(db) < tiny, tiny, db)
        inv_z = 1.0 / np.where(np.abs(dz) < tiny, tiny, dz)

        def slab(lo, hi, o, inv):
            t1 = (lo - o) * inv
            t2 = (hi - o) * inv
            return np.minimum(t1, t2), np.maximum(t1, t2)

        na, fa = slab(bb[0], bb[1], oa, inv_a)
        nb, fb = slab(bb[2], bb[3], ob, inv_b)
        nz, fz = slab(bb[4], bb[5], oz, inv_z)
        tn = np.maximum(np.maximum(na, nb), nz)
        tf = np.minimum(np.minimum(fa, fb), fz)
        idx = np.nonzero((tn <= tf) & (tf > 0) & (tn < t))[0]
        if idx.size == 0:
            return t, face
        o_sub = (oa, ob, oz)
        inv_sub = (inv_a[idx], inv_b[idx], inv_z[idx])
        # The boxes of a staircase share their lateral slab, far end and floor: cache the
        # slab distances per (axis, bound) so each extra box costs a few operations.
        t_cache: dict[tuple[int, float], np.ndarray] = {}
        slab_cache: dict[tuple[int, float, float], tuple[np.ndarray, np.ndarray]] = {}

        def bound_t(axis: int, value: float) -> np.ndarray:
            key = (axis, float(value))
            if key not in t_cache:
                t_cache[key] = (value - o_sub[axis]) * inv_sub[axis]
            return t_cache[key]

        def box_slab(axis: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
            key = (axis, float(lo), float(hi))
            if key not in slab_cache:
                t1, t2 = bound_t(axis, lo), bound_t(axis, hi)
                slab_cache[key] = (np.minimum(t1, t2), np.maximum(t1, t2))
            return slab_cache[key]

        t_sub = t[idx]
        winner = np.full(idx.size, -1, dtype=np.int16)
        for i, box in enumerate(geom.boxes):
            na, fa = box_slab(0, box[0], box[1])
            nb, fb = box_slab(1, box[2], box[3])
            nz, fz = box_slab(2, box[4], box[5])
            tn = np.maximum(np.maximum(na, nb), nz)
            tf = np.minimum(np.minimum(fa, fb), fz)
            hit = (tn <= tf) & (tn > 0) & (tn < t_sub)
            t_sub = np.where(hit, tn, t_sub)
            winner[hit] = i
            t_cache.pop((0, float(box[0])), None)  # the next riser has its own near bound
            slab_cache.pop((0, float(box[0]), float(box[1])), None)
        # The entry face of the winning box: the axis whose near bound is the hit.
        w = np.nonzero(winner >= 0)[0]
        bi = winner[w]
        near = []
        for axis in range(3):
            inv = inv_sub[axis][w]
            t1 = (geom.boxes[bi, 2 * axis] - o_sub[axis]) * inv
            t2 = (geom.boxes[bi, 2 * axis + 1] - o_sub[axis]) * inv
            near.append((np.minimum(t1, t2), inv > 0))
        (na, pa), (nb, pb), (nz, pz) = near
        k = np.where(
            (na >= nb) & (na >= nz),
            np.where(pa, 0, 1),
            np.where(nb >= nz, np.where(pb, 2, 3), np.where(pz, 4, 5)),
        )
        f_sub = face[idx]
        f_sub[w] = (_FACE_BOX0 + 6 * bi.astype(np.int64) + k).astype(np.int16)
        t[idx] = t_sub
        face[idx] = f_sub
    return t, face


# --------------------------------------------------------------------------- textures


def _fft_filter(img: np.ndarray, amp: np.ndarray) -> np.ndarray:
    return np.fft.irfft2(np.fft.rfft2(img) * amp, s=img.shape)


def _freqs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Spatial frequencies (cycles per tile) along rows (t) and columns (s)."""
    return np.fft.fftfreq(n)[:, None] * n, np.fft.rfftfreq(n)[None, :] * n


def _spectral_noise(
    rng: np.random.Generator, n: int, beta: float, *, stretch: float = 1.0, f_hi: float | None = None
) -> np.ndarray:
    """Periodic noise with amplitude spectrum ``k^-beta`` (multi-scale, like summed octaves
    of value noise). ``stretch > 1`` elongates features along the tile's s axis."""
    ky, kx = _freqs(n)
    k = np.sqrt((kx * stretch) ** 2 + ky**2)
    with np.errstate(divide="ignore"):
        amp = np.where(k > 0, k ** (-beta), 0.0)
    if f_hi is not None:
        amp *= np.exp(-((k / f_hi) ** 2))
    out = _fft_filter(rng.standard_normal((n, n)), amp)
    return (out - out.mean()) / (out.std() + 1e-12)


def _gauss_blur_periodic(img: np.ndarray, sigma_px: float) -> np.ndarray:
    ky, kx = _freqs(img.shape[0])
    n = img.shape[0]
    amp = np.exp(-2.0 * (math.pi * sigma_px / n) ** 2 * (kx**2 + ky**2))
    return _fft_filter(img, amp)


def _make_tile(kind: str, rng: np.random.Generator, n: int = _TILE_PX) -> np.ndarray:
    """A periodic texture tile, zero mean, unit std, float32 (rows: t, columns: s)."""
    if kind == "noise":
        tile = _spectral_noise(rng, n, rng.uniform(0.8, 1.3))
    elif kind == "carpet":
        fibres = _spectral_noise(rng, n, 0.15, f_hi=n / 3.0)
        tile = 0.8 * fibres + 0.5 * _spectral_noise(rng, n, 1.1)
    elif kind == "wood":
        rows = np.arange(n)[:, None] / n
        warp = _spectral_noise(rng, n, 1.6, stretch=4.0)
        rings = np.sin(2 * math.pi * (rng.integers(6, 16) * rows + 0.25 * warp))
        rings = np.sign(rings) * np.abs(rings) ** 0.6
        grain = _spectral_noise(rng, n, 0.7, stretch=12.0)
        n_planks = int(rng.choice([2, 4]))
        plank = (np.arange(n) * n_planks // n)[:, None]
        plank_tone = rng.normal(0.0, 0.6, n_planks)[plank]
        seam = ((np.arange(n) % (n // n_planks)) < 3)[:, None]
        tile = 0.5 * rings + 0.6 * grain + plank_tone - 2.5 * seam
        tile = _gauss_blur_periodic(np.broadcast_to(tile, (n, n)).astype(np.float64), 0.7)
    elif kind == "tiles":
        m = int(rng.choice([2, 4]))
        idx = np.arange(n) * m // n
        tone = rng.normal(0.0, 0.5, (m, m))[idx[:, None], idx[None, :]]
        g = max(2, n // m // 25)
        grout = (np.arange(n) % (n // m)) < g
        tile = tone + 0.5 * _spectral_noise(rng, n, 0.9) - 3.0 * (grout[:, None] | grout[None, :])
        tile = _gauss_blur_periodic(tile, 0.8)
    elif kind == "speckle":
        dots = (rng.random((n, n)) < 0.03) * rng.choice([-1.0, 1.0], (n, n), p=[0.65, 0.35])
        dots = _gauss_blur_periodic(dots, rng.uniform(0.7, 1.5))
        dots /= dots.std() + 1e-12
        tile = dots + 0.4 * _spectral_noise(rng, n, 1.2)
    else:  # pragma: no cover - SurfaceSpec validates the kind
        raise InputError(f"unknown texture kind {kind!r}")
    tile = (tile - tile.mean()) / (tile.std() + 1e-12)
    return np.clip(tile, -3.5, 3.5).astype(np.float32)


@dataclass(frozen=True)
class _Pyramid:
    """A mip-map of a square periodic tile, all levels in one flat array."""

    data: np.ndarray  # float32, concatenated levels
    offsets: np.ndarray  # int32 (L,), start of each level in ``data``
    sizes: np.ndarray  # int32 (L,), side of each level in texels
    scales: np.ndarray  # float32 (L,), 2 ** -level
    n: int

    @classmethod
    def build(cls, tile: np.ndarray) -> _Pyramid:
        levels = [tile]
        while levels[-1].shape[0] > 1:
            t = levels[-1]
            h = t.shape[0] // 2
            levels.append(t.reshape(h, 2, h, 2).mean(axis=(1, 3)))
        counts = np.array([lv.size for lv in levels])
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int32)
        sizes = np.array([lv.shape[0] for lv in levels], dtype=np.int32)
        data = np.concatenate([lv.ravel() for lv in levels]).astype(np.float32)
        scales = (sizes / tile.shape[0]).astype(np.float32)
        return cls(data, offsets, sizes, scales, tile.shape[0])

    def bilinear(self, s: np.ndarray, t: np.ndarray, level: np.ndarray) -> np.ndarray:
        """Bilinear lookup at wrapped level-0 texel coordinates in level ``level`` (int32)."""
        size = self.sizes[level]
        scale = self.scales[level]
        x = s * scale - np.float32(0.5)
        y = t * scale - np.float32(0.5)
        x0 = np.floor(x)
        y0 = np.floor(y)
        wx = x - x0
        wy = y - y0
        mask = size - 1
        ix0 = x0.astype(np.int32) & mask
        iy0 = y0.astype(np.int32) & mask
        ix1 = (ix0 + 1) & mask
        row0 = self.offsets[level] + iy0 * size
        row1 = self.offsets[level] + ((iy0 + 1) & mask) * size
        d = self.data
        a, b = d[row0 + ix0], d[row0 + ix1]
        c, e = d[row1 + ix0], d[row1 + ix1]
        top = a + wx * (b - a)
        bot = c + wx * (e - c)
        return top + wy * (bot - top)

    def sample(self, s: np.ndarray, t: np.ndarray, lod: np.ndarray) -> np.ndarray:
        """Trilinear sample at level-0 texel coordinates ``(s, t)`` and level ``lod``."""
        top = len(self.offsets) - 1
        lod = np.clip(lod, np.float32(0.0), np.float32(top - 1e-3))
        l0 = lod.astype(np.int32)  # floor: lod >= 0
        w = (lod - l0).astype(np.float32)
        # Wrap first: float32 then keeps sub-texel precision far from the origin.
        s = np.mod(s, self.n).astype(np.float32)
        t = np.mod(t, self.n).astype(np.float32)
        v0 = self.bilinear(s, t, l0)
        v1 = self.bilinear(s, t, l0 + 1)
        return v0 + w * (v1 - v0)


# --------------------------------------------------------------------------- rendering


@dataclass(frozen=True)
class SyntheticScene:
    """A rendered scene: raw stereo pair, its calibration and rig, and the ground truth.

    Attributes
    ----------
    spec : SceneSpec
    left, right : (H, W) uint8
        Raw (unrectified, distorted) grey images.
    calibration : StereoCalibration
        Exact intrinsics, distortion and ``R, T`` (``X_right = R X_left + T``, metres).
    rig : Rig
        ``T_body_camera`` of the raw left camera and ``body_rpy``.
    truth : dict
        JSON-serialisable terrain result (CONVENTIONS.md keys), see :func:`render_scene`.
    depth_left : (H, W) float32, metres
        Z of the surface hit by each left pixel centre's ray, raw left camera frame; NaN
        where nothing is hit.
    labels_left : (H, W) int16
        Index into ``truth["planes"]`` of the surface hit by each left pixel centre; -1
        for nothing (sky) and for faces not listed there (stair/box sides and backs).
    """

    spec: SceneSpec
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    calibration: StereoCalibration = field(repr=False)
    rig: Rig = field(repr=False)
    truth: dict = field(repr=False)
    depth_left: np.ndarray = field(repr=False)
    labels_left: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class _Appearance:
    """Per-face lookup tables and per-group texture pyramids."""

    base: np.ndarray  # (F,) float32: exposure * albedo * shade (grey levels)
    contrast: np.ndarray  # (F,) float32
    group: np.ndarray  # (F,) int: index into _GROUPS, -1 for the sky
    mode: np.ndarray  # (F,) int: face-coordinate mode
    offset: np.ndarray  # (F, 2) float32: texture offset, metres
    pyramids: dict  # group index -> _Pyramid
    tile_m: dict  # group index -> metres per tile
    ground_axes: tuple[np.float32, np.float32]  # cos, sin of the ground texture's rotation

    @property
    def key(self) -> np.ndarray:
        """(F,) uint8: 0 for the sky, else 1 + 4 * group + mode."""
        k = 1 + 4 * self.group + self.mode
        k[self.group < 0] = 0
        return k.astype(np.uint8)

    @property
    def n_keys(self) -> int:
        return 1 + 4 * len(_GROUPS)


def _face_table(geom: _Geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, 3) normals (yaw frame), group index and coordinate mode of every face id."""
    c, s = geom.cos_yaw, geom.sin_yaw
    u = np.array([c, s, 0.0])
    v = np.array([-s, c, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    g = {name: i for i, name in enumerate(_GROUPS)}
    normals = [np.zeros(3), up, -u]
    groups = [-1, g["ground"], g["wall"]]
    modes = [_MODE_XY, _MODE_XY, _MODE_BZ]
    for _ in range(geom.boxes.shape[0]):
        normals += [-u, u, -v, v, -up, up]
        groups += [g["riser"], g["side"], g["side"], g["side"], g["side"], g["tread"]]
        modes += [_MODE_BZ, _MODE_BZ, _MODE_AZ, _MODE_AZ, _MODE_BA, _MODE_BA]
    return np.array(normals), np.array(groups), np.array(modes)


def _appearance(spec: SceneSpec, geom: _Geometry) -> _Appearance:
    normals, groups, modes = _face_table(geom)
    el, az = spec.light_elevation_rad, spec.light_azimuth_rad
    light = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    shade = spec.ambient + spec.diffuse * np.maximum(normals @ light, 0.0)
    rng = np.random.default_rng([spec.seed, 1])
    n_faces = len(groups)
    jitter = 1.0 + rng.uniform(-0.04, 0.04, n_faces)  # e.g. each step's paint a little apart
    offset = rng.uniform(0.0, 10.0, (n_faces, 2))
    ground_angle = rng.uniform(math.radians(30.0), math.radians(60.0))
    albedo = np.ones(n_faces)
    contrast = np.zeros(n_faces)
    for gi, name in enumerate(_GROUPS):
        surf: SurfaceSpec = getattr(spec, name)
        albedo[groups == gi] = surf.albedo
        contrast[groups == gi] = surf.contrast
    # Stair sides share one texture layout so that the side of the flight has no seams.
    side = groups == _GROUPS.index("side")
    if side.any():
        offset[side] = offset[np.argmax(side)]
        jitter[side] = 1.0
    base = spec.exposure * np.minimum(albedo * jitter, 1.0) * shade
    base[0] = spec.sky_grey
    present = sorted(set(int(x) for x in groups[1:]))
    pyramids, tile_m = {}, {}
    for gi in present:
        surf = getattr(spec, _GROUPS[gi])
        trng = np.random.default_rng([spec.seed, 2, gi])
        pyramids[gi] = _Pyramid.build(_make_tile(surf.texture, trng))
        tile_m[gi] = surf.tile_m
    return _Appearance(
        base.astype(np.float32),
        contrast.astype(np.float32),
        groups,
        modes,
        offset.astype(np.float32),
        pyramids,
        tile_m,
        (np.float32(math.cos(ground_angle)), np.float32(math.sin(ground_angle))),
    )


#: A second, larger and rotated copy of the texture modulates large surfaces (ground,
#: wall) so that the tile's period does not show in the far field.
_MACRO_SCALE = 1.0 / 6.3
_MACRO_ANGLE = math.radians(37.0)
_MACRO_WEIGHT = 0.6
_MACRO_MIN_LEVEL = 3


def _shade(
    origin: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    t: np.ndarray,
    face: np.ndarray,
    geom: _Geometry,
    app: _Appearance,
    focal_px: float,
    samples_per_side: int,
) -> np.ndarray:
    """Radiance (grey levels, float32) of each sample from its hit."""
    out = app.base[face]
    ox, oy, oz = (float(v) for v in origin)
    # Sort the samples once by (group, coordinate mode): each run is textured at once.
    key = app.key[face]
    order = np.argsort(key, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(key, minlength=app.n_keys))])
    # Angular size of one sample; the footprint on the surface picks the mip level.
    sample_rad = np.float32(1.0 / (focal_px * samples_per_side))
    cm, sm = np.float32(math.cos(_MACRO_ANGLE)), np.float32(math.sin(_MACRO_ANGLE))
    for k in range(1, app.n_keys):
        if bounds[k + 1] == bounds[k]:
            continue
        gi, m = divmod(k - 1, 4)
        pyr = app.pyramids[gi]
        idx = order[bounds[k] : bounds[k + 1]]
        ti = t[idx]
        ddx, ddy, ddz = dx[idx], dy[idx], dz[idx]
        px, py, pz = ox + ti * ddx, oy + ti * ddy, oz + ti * ddz
        if m == _MODE_XY:
            # Ground texture axes at an oblique angle to x: far pixels average long runs
            # along the view direction, which must not follow the tile's rows.
            gc, gs = app.ground_axes
            cs, ct, cos_n = gc * px - gs * py, gs * px + gc * py, np.abs(ddz)
        else:
            pa, pb = geom.to_local(px, py)
            da, db = geom.to_local(ddx, ddy)
            if m == _MODE_BA:
                cs, ct, cos_n = pb, pa, np.abs(ddz)
            elif m == _MODE_BZ:
                cs, ct, cos_n = pb, pz, np.abs(da)
            else:
                cs, ct, cos_n = pa, pz, np.abs(db)
        norm = np.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
        cos_n = np.maximum(cos_n / norm, np.float32(0.05))
        texel_m = np.float32(app.tile_m[gi] / pyr.n)
        footprint = ti * norm * sample_rad / np.sqrt(cos_n)
        lod = np.log2(np.maximum(footprint / texel_m, np.float32(1e-6)))
        fi = face[idx]
        off = app.offset[fi]
        scale = np.float32(pyr.n / app.tile_m[gi])
        u = (cs + off[:, 0]) * scale
        v = (ct + off[:, 1]) * scale
        tex = pyr.sample(u, v, lod)
        if _GROUPS[gi] in ("ground", "wall"):
            mu = (cm * u - sm * v) * np.float32(_MACRO_SCALE)
            mv = (sm * u + cm * v) * np.float32(_MACRO_SCALE)
            # Low-frequency layer: one bilinear lookup at a coarse level is enough.
            level = np.clip(
                np.rint(lod + np.float32(math.log2(_MACRO_SCALE))), _MACRO_MIN_LEVEL, len(pyr.offsets) - 1
            ).astype(np.int32)
            macro = pyr.bilinear(np.mod(mu, pyr.n), np.mod(mv, pyr.n), level)
            tex = (tex + np.float32(_MACRO_WEIGHT) * macro) * np.float32(1.0 / math.hypot(1.0, _MACRO_WEIGHT))
        refl = np.maximum(1.0 + app.contrast[fi] * tex, np.float32(0.05))
        out[idx] *= refl
    return out


def _render_view(
    cam: CameraIntrinsics,
    R_yaw_cam: np.ndarray,
    origin: np.ndarray,
    spec: SceneSpec,
    geom: _Geometry,
    app: _Appearance,
    *,
    want_truth: bool,
):
    """Radiance image (H, W) float32 of one camera, and (t, face) of its pixel centres."""
    w, h = spec.image_size
    ss = spec.supersample
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    x, y, j00, j01, j10, j11 = _undistort(uu.ravel(), vv.ravel(), cam)
    R = R_yaw_cam.astype(np.float64)
    centre = None
    if want_truth:
        dxc = R[0, 0] * x + R[0, 1] * y + R[0, 2]
        dyc = R[1, 0] * x + R[1, 1] * y + R[1, 2]
        dzc = R[2, 0] * x + R[2, 1] * y + R[2, 2]
        centre = _cast(origin, dxc.astype(np.float32), dyc.astype(np.float32), dzc.astype(np.float32), geom)
    # Sub-pixel samples on a regular ss x ss grid inside each pixel, placed through the
    # local inverse of the distortion (second-order error ~1e-7 px).
    offs = (np.arange(ss) + 0.5) / ss - 0.5
    ou, ov = np.meshgrid(offs, offs)
    eu = (ou.ravel() / cam.fx).astype(np.float32)[None, :]
    ev = (ov.ravel() / cam.fy).astype(np.float32)[None, :]
    x32, y32 = x.astype(np.float32)[:, None], y.astype(np.float32)[:, None]
    j00, j01, j10, j11 = (j.astype(np.float32)[:, None] for j in (j00, j01, j10, j11))
    xs = (x32 + j00 * eu + j01 * ev).ravel()
    ys = (y32 + j10 * eu + j11 * ev).ravel()
    Rf = R.astype(np.float32)
    dx = Rf[0, 0] * xs + Rf[0, 1] * ys + Rf[0, 2]
    dy = Rf[1, 0] * xs + Rf[1, 1] * ys + Rf[1, 2]
    dz = Rf[2, 0] * xs + Rf[2, 1] * ys + Rf[2, 2]
    del xs, ys
    t, face = _cast(origin, dx, dy, dz, geom)
    rad = _shade(origin, dx, dy, dz, t, face, geom, app, 0.5 * (cam.fx + cam.fy), ss)
    img = rad.reshape(h * w, ss * ss).mean(axis=1).reshape(h, w)
    return img, centre


def _sensor(
    img: np.ndarray,
    spec: SceneSpec,
    cam: CameraIntrinsics,
    gain: float,
    offset: float,
    sigma: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Optics and sensor: blur, vignetting, gain/offset, Gaussian noise, 8-bit."""
    h, w = img.shape
    out: np.ndarray = img.astype(np.float32)
    if spec.blur_sigma_px > 0:
        out = cv2.GaussianBlur(out, (0, 0), spec.blur_sigma_px, borderType=cv2.BORDER_REFLECT)
    if spec.vignetting > 0:
        vv, uu = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((uu - cam.cx) ** 2 + (vv - cam.cy) ** 2) / (cam.cx**2 + cam.cy**2)
        out *= 1.0 - spec.vignetting * r2
    out = gain * out + offset
    if sigma > 0:
        out += rng.normal(0.0, sigma, out.shape).astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def _rotation(rotvec: tuple[float, float, float]) -> np.ndarray:
    """(3, 3) rotation matrix of a Rodrigues vector (radians)."""
    R, _ = cv2.Rodrigues(np.array(rotvec, dtype=np.float64).reshape(3, 1))
    return R


def _stereo_geometry(spec: SceneSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``R, T`` (``X_right = R X_left + T``) and the right centre in the left frame."""
    R = _rotation(spec.right_rotvec_rad)
    oy, oz = spec.right_offset_m
    b = spec.baseline_m
    centre = np.array([math.sqrt(b * b - oy * oy - oz * oz), oy, oz])
    return R, -R @ centre, centre


def _rig(spec: SceneSpec) -> Rig:
    return Rig(camera_mount(spec.camera_height_m, spec.pitch_down_rad), spec.body_rpy)


def _truth(spec: SceneSpec, T_yaw_camera: Transform) -> dict:
    ob = spec.obstacle
    ground = {"normal": [0.0, 0.0, 1.0], "offset": 0.0, "kind": "horizontal", "name": "ground"}
    planes: list[dict] = [ground]
    steps: list[dict] = []
    yaw = None
    kind = "none"
    if ob is not None:
        yaw = float(ob.yaw_rad)
        c, s = math.cos(ob.yaw_rad), math.sin(ob.yaw_rad)
        s0 = ob.distance_m * c
        toward = [-c, -s, 0.0]  # riser normals point toward the camera (-u)
        if isinstance(ob, StairSpec):
            kind = "stairs"
            n, rise, run = ob.n_steps, ob.rise_m, ob.run_m
        else:
            kind = "box"
            n, rise, run = 1, ob.height_m, ob.depth_m
        for i in range(n):
            a_i = s0 + i * run
            top = n == 1 and kind == "box"
            steps.append(
                {
                    "rise": float(rise),
                    "run": float(run) if (i < n - 1 or top) else None,
                    "distance": float(a_i / c),
                    "width": float(ob.width_m),
                }
            )
            planes.append(
                {
                    "normal": [float(v) for v in toward],
                    "offset": float(a_i),
                    "kind": "vertical",
                    "name": f"riser_{i + 1}",
                }
            )
            planes.append(
                {
                    "normal": [0.0, 0.0, 1.0],
                    "offset": float(-(i + 1) * rise),
                    "kind": "horizontal",
                    "name": f"tread_{i + 1}",
                }
            )
    if spec.back_wall_m is not None:
        yw = 0.0 if ob is None else ob.yaw_rad
        planes.append(
            {
                "normal": [-math.cos(yw), -math.sin(yw), 0.0],
                "offset": float(spec.back_wall_m),
                "kind": "vertical",
                "name": "back_wall",
            }
        )
    return {
        "version": 1,
        "frame": "yaw",
        "obstacle": kind,
        "steps": steps,
        "yaw": yaw,
        "planes": planes,
        "camera_height_m": float(spec.camera_height_m),
        "camera_center_yaw": [float(v) for v in T_yaw_camera.translation],
        "pitch_down_rad": float(spec.pitch_down_rad),
        "body_rpy": [float(v) for v in spec.body_rpy],
        "weak_texture": bool(spec.weak_texture),
        "image_size": [int(v) for v in spec.image_size],
        "seed": int(spec.seed),
        "spec": _spec_to_json(spec),
    }


def _spec_to_json(spec: SceneSpec) -> dict:
    d = dataclasses.asdict(spec)
    ob = spec.obstacle
    d["obstacle"] = None if ob is None else {"type": type(ob).__name__, **dataclasses.asdict(ob)}
    return json.loads(json.dumps(d))  # tuples -> lists


def _labels_table(spec: SceneSpec, n_faces: int) -> np.ndarray:
    """Face id -> index into truth['planes'] (-1 where the face is not listed)."""
    table = np.full(n_faces, -1, dtype=np.int16)
    table[_FACE_GROUND] = 0
    n_boxes = (n_faces - _FACE_BOX0) // 6
    for i in range(n_boxes):
        table[_FACE_BOX0 + 6 * i + 0] = 1 + 2 * i  # riser_{i+1}
        table[_FACE_BOX0 + 6 * i + 5] = 2 + 2 * i  # tread_{i+1}
    if spec.back_wall_m is not None:
        table[_FACE_WALL] = 1 + 2 * n_boxes
    return table


def render_scene(spec: SceneSpec) -> SyntheticScene:
    """Render the raw stereo pair of ``spec`` with its calibration, rig and ground truth.

    Parameters
    ----------
    spec : SceneSpec

    Returns
    -------
    SyntheticScene
        ``truth`` holds ``version`` (1), ``frame`` ("yaw"), ``obstacle``, ``steps``
        (nearest first: ``rise``, ``run`` -- None for a staircase's top step, the landing
        --, ``distance`` on the frame's x axis, ``width``), ``yaw`` (None without
        obstacle), ``planes`` (``n . x + d = 0`` in the yaw frame, ``n`` up or toward the
        camera, named ``ground``, ``riser_i``, ``tread_i``, ``back_wall``), the camera
        parameters, ``weak_texture``, ``image_size``, ``seed`` and the whole ``spec``.

    Raises
    ------
    InputError
        If the camera is inside the obstacle or below the ground.

    Notes
    -----
    The two views are rendered on two threads; the result does not depend on it. About
    0.4-0.8 s for a 640 x 480 pair with 2 x 2 supersampling on two cores.
    """
    if not isinstance(spec, SceneSpec):
        raise InputError(f"render_scene needs a SceneSpec, got {type(spec).__name__}")
    rig = _rig(spec)
    T_yaw_left = rig.T_yaw_camera
    R, T, centre_right = _stereo_geometry(spec)
    origin_l = T_yaw_left.translation.copy()
    origin_r = T_yaw_left.apply(centre_right)
    geom = _scene_geometry(spec)
    for name, o in (("left", origin_l), ("right", origin_r)):
        if o[2] <= 1e-3:
            raise InputError(f"the {name} camera is at or below the ground (z = {o[2]:.3f} m)")
        oa, ob = geom.to_local(o[0], o[1])
        for box in geom.boxes:
            if box[0] <= oa <= box[1] and box[2] <= ob <= box[3] and o[2] <= box[5]:
                raise InputError(f"the {name} camera is inside the obstacle; move it back")
    app = _appearance(spec, geom)
    # SceneSpec resolves None cameras in __post_init__.
    left_cam = cast(CameraIntrinsics, spec.left_camera)
    right_cam = cast(CameraIntrinsics, spec.right_camera)
    # A disturbed rig: the right camera turned about its own centre after calibration.
    # The images see the disturbed camera; the calibration below keeps R, T.
    R_seen = _rotation(spec.right_disturbance_rotvec_rad) @ R
    R_yaw_right = T_yaw_left.rotation @ R_seen.T
    # The two views are independent and numpy releases the GIL on large arrays: render
    # them side by side (deterministic: no shared random state).
    with ThreadPoolExecutor(max_workers=2) as pool:
        job_r = pool.submit(_render_view, right_cam, R_yaw_right, origin_r, spec, geom, app, want_truth=False)
        img_l, centre = _render_view(
            left_cam, T_yaw_left.rotation, origin_l, spec, geom, app, want_truth=True
        )
        img_r, _ = job_r.result()
    noise_rng = np.random.default_rng([spec.seed, 3])
    left = _sensor(img_l, spec, left_cam, 1.0, 0.0, spec.noise_sigma[0], noise_rng)
    right = _sensor(
        img_r, spec, right_cam, spec.right_gain, spec.right_offset_grey, spec.noise_sigma[1], noise_rng
    )
    w, h = spec.image_size
    t_c, face_c = cast(tuple[np.ndarray, np.ndarray], centre)
    depth = np.where(np.isfinite(t_c), t_c, np.nan).astype(np.float32).reshape(h, w)
    labels = _labels_table(spec, len(app.group))[face_c].reshape(h, w)
    calib = StereoCalibration(
        left_cam.matrix,
        np.array(left_cam.distortion),
        right_cam.matrix,
        np.array(right_cam.distortion),
        R,
        T,
        spec.image_size,
        source=f"synthetic scene seed {spec.seed}",
    )
    for a in (left, right, depth, labels):
        a.setflags(write=False)
    return SyntheticScene(spec, left, right, calib, rig, _truth(spec, T_yaw_left), depth, labels)


# --------------------------------------------------------------------------- specs at random


def _surface(
    rng: np.random.Generator, kinds: tuple[str, ...], albedo: tuple[float, float], tile: tuple[float, float]
) -> SurfaceSpec:
    return SurfaceSpec(
        str(rng.choice(kinds)),
        float(rng.uniform(*tile)),
        float(rng.uniform(*albedo)),
        float(rng.uniform(0.1, 0.28)),
    )


def _random_camera(
    rng: np.random.Generator, size: tuple[int, int], like: CameraIntrinsics | None = None
) -> CameraIntrinsics:
    w, h = size
    for _ in range(100):
        if like is None:
            fx = rng.uniform(0.8, 0.9) * w
            fy = fx * (1.0 + rng.uniform(-0.002, 0.002))
            cx = (w - 1) / 2.0 + rng.uniform(-4.0, 4.0)
            cy = (h - 1) / 2.0 + rng.uniform(-4.0, 4.0)
            k1 = rng.uniform(-0.25, 0.05)
            k2 = rng.uniform(-0.02, 0.06)
        else:
            scale = 1.0 + rng.uniform(-0.01, 0.01)
            fx, fy = like.fx * scale, like.fy * scale * (1.0 + rng.uniform(-0.001, 0.001))
            cx = like.cx + rng.uniform(-5.0, 5.0)
            cy = like.cy + rng.uniform(-5.0, 5.0)
            k1 = float(np.clip(like.distortion[0] + rng.uniform(-0.04, 0.04), -0.25, 0.05))
            k2 = float(np.clip(like.distortion[1] + rng.uniform(-0.01, 0.01), -0.02, 0.06))
        p1, p2 = rng.uniform(-5e-4, 5e-4, 2)
        cam = CameraIntrinsics(fx, fy, cx, cy, (k1, k2, float(p1), float(p2), 0.0))
        try:
            _check_distortion_invertible(cam, size, "camera")
        except InputError:
            continue
        return cam
    raise InputError("could not draw an invertible lens distortion")  # pragma: no cover


def _in_view(spec: SceneSpec, margin: float = 0.04) -> bool:
    """True when the first riser's bottom edge and the top tread's front edge (centres)
    project into the left image with a margin."""
    ob = spec.obstacle
    if ob is None:
        return True
    c, s = math.cos(ob.yaw_rad), math.sin(ob.yaw_rad)
    s0 = ob.distance_m * c
    if isinstance(ob, StairSpec):
        a_top, z_top = s0 + (ob.n_steps - 1) * ob.run_m, ob.n_steps * ob.rise_m
    else:
        a_top, z_top = s0, ob.height_m
    b_mid = _obstacle_centre_b(ob)
    pts_local = np.array(
        [
            [s0, b_mid, 0.0],
            [a_top, b_mid, z_top],
            [s0, b_mid - 0.35 * ob.width_m, 0.0],
            [s0, b_mid + 0.35 * ob.width_m, 0.0],
        ]
    )
    pts = np.stack(
        [
            c * pts_local[:, 0] - s * pts_local[:, 1],
            s * pts_local[:, 0] + c * pts_local[:, 1],
            pts_local[:, 2],
        ],
        axis=1,
    )
    T_cam_yaw = _rig(spec).T_yaw_camera.inverse()
    uv = _project(T_cam_yaw.apply(pts), cast(CameraIntrinsics, spec.left_camera))
    w, h = spec.image_size
    mu, mv = margin * w, margin * h
    return bool(
        np.all((uv[:, 0] >= mu) & (uv[:, 0] <= w - 1 - mu) & (uv[:, 1] >= mv) & (uv[:, 1] <= h - 1 - mv))
    )


_KINDS = ("stairs", "box", "none")


def random_scene_spec(
    rng: np.random.Generator,
    *,
    image_size: tuple[int, int] = (640, 480),
    kind: str | None = None,
    weak_texture: bool | None = None,
    **overrides: Any,
) -> SceneSpec:
    """Draw a random scene (geometry, cameras, textures, lighting, sensor).

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness; the same state gives the same spec.
    image_size : (width, height)
        Focal lengths scale with the width (``fx`` in ``[0.8, 0.9] * width``).
    kind : {"stairs", "box", "none"} or None
        None draws stairs (70 %), a box (20 %) or nothing (10 %).
    weak_texture : bool or None
        None: weakly textured with probability 0.3. Weak scenes paint the risers and stair
        (or box) sides, and with probability 0.5 the treads (box top), with a texture of
        0.5-1.5 grey levels std before noise; every other surface has a texture of at
        least 6-10 grey levels std.
    **overrides
        Fields of :class:`SceneSpec` or of the obstacle's spec (e.g. ``rise_m=0.2``,
        ``noise_sigma=(0, 0)``). Geometry not overridden is redrawn until the first
        riser (bottom edge: centre and +-35 % of the width) and the top tread's front
        edge are in view of the left camera.

    Notes
    -----
    Exposure is automatic: the ground's nominal grey level is drawn in [95, 150]; albedos
    are lowered where a lit face would exceed grey 200 (no saturated faces).

    Returns
    -------
    SceneSpec

    Raises
    ------
    InputError
        Unknown kind or override, bad values, or overrides that keep the obstacle out of
        view.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    size = _check_image_size(image_size, "random_scene_spec")
    if kind is None:
        kind = str(rng.choice(_KINDS, p=[0.7, 0.2, 0.1]))
    if kind not in _KINDS:
        raise InputError(f"kind must be one of {_KINDS} or None, got {kind!r}")
    weak = bool(rng.random() < 0.3) if weak_texture is None else bool(weak_texture)
    scene_fields = {f.name for f in dataclasses.fields(SceneSpec)}
    ob_cls = {"stairs": StairSpec, "box": BoxSpec, "none": None}[kind]
    ob_fields = {f.name for f in dataclasses.fields(ob_cls)} if ob_cls else set()
    unknown = set(overrides) - scene_fields - ob_fields
    if unknown:
        raise InputError(
            f"unknown override(s) {sorted(unknown)} for a '{kind}' scene; valid: SceneSpec "
            f"fields {sorted(scene_fields)}" + (f" and {sorted(ob_fields)}" if ob_fields else "")
        )
    if "image_size" in overrides or "weak_texture" in overrides:
        raise InputError("pass image_size and weak_texture as keyword arguments, not overrides")
    ob_over = {k: v for k, v in overrides.items() if k in ob_fields and k not in scene_fields}
    sc_over = {k: v for k, v in overrides.items() if k in scene_fields}

    left = _random_camera(rng, size)
    right = _random_camera(rng, size, like=left)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    rotvec = tuple(float(v) for v in axis * math.radians(rng.uniform(0.3, 2.0)))
    appearance: dict[str, Any] = {
        "seed": int(rng.integers(0, 2**31 - 1)),
        "left_camera": left,
        "right_camera": right,
        "right_rotvec_rad": rotvec,
        "right_offset_m": tuple(float(v) for v in rng.uniform(-1e-3, 1e-3, 2)),
        "ground": _surface(rng, ("noise", "carpet", "tiles", "speckle"), (0.3, 0.7), (0.6, 1.5)),
        "tread": _surface(rng, ("wood", "carpet", "noise", "speckle", "tiles"), (0.35, 0.85), (0.5, 1.2)),
        "riser": _surface(rng, ("noise", "wood", "speckle", "carpet"), (0.35, 0.85), (0.5, 1.2)),
        "side": _surface(rng, ("noise", "speckle"), (0.35, 0.8), (0.6, 1.2)),
        "wall": _surface(rng, ("noise", "speckle", "tiles"), (0.4, 0.85), (0.8, 2.0)),
        "light_azimuth_rad": float(rng.uniform(-math.pi, math.pi)),
        "light_elevation_rad": math.radians(rng.uniform(35.0, 75.0)),
        "ambient": float(rng.uniform(0.4, 0.6)),
        "diffuse": float(rng.uniform(0.35, 0.55)),
        "exposure": float(rng.uniform(95.0, 150.0)),  # target ground grey, see below
        "sky_grey": float(rng.uniform(150.0, 235.0)),
        "noise_sigma": tuple(float(v) for v in rng.uniform(1.0, 3.0, 2)),
        "right_gain": float(rng.uniform(0.85, 1.15)),
        "right_offset_grey": float(rng.uniform(-10.0, 10.0)),
        "vignetting": float(rng.uniform(0.05, 0.25)) if rng.random() < 0.6 else 0.0,
        "blur_sigma_px": float(rng.uniform(0.0, 0.6)),
    }
    # Auto exposure: the ground's nominal grey level is the drawn target.
    ground_shade = appearance["ambient"] + appearance["diffuse"] * math.sin(appearance["light_elevation_rad"])
    appearance["exposure"] = min(appearance["exposure"] / (appearance["ground"].albedo * ground_shade), 600.0)
    weak_tread = bool(rng.random() < 0.5)
    weak_levels = rng.uniform(0.5, 1.5, len(_GROUPS))
    floor_levels = rng.uniform(6.0, 10.0, len(_GROUPS))
    wall_draw = (bool(rng.random() < 0.5), float(rng.uniform(0.0, 1.0)))

    spec = None
    for _ in range(200):
        ob: StairSpec | BoxSpec | None
        yaw = math.radians(rng.uniform(-25.0, 25.0))
        lateral = float(rng.uniform(-0.2, 0.2))
        distance = float(rng.uniform(0.9, 2.0))
        if kind == "stairs":
            params = {
                "n_steps": int(rng.integers(2, 6)),
                "rise_m": float(rng.uniform(0.10, 0.22)),
                "run_m": float(rng.uniform(0.25, 0.35)),
                "width_m": float(rng.uniform(0.8, 1.6)),
                "distance_m": distance,
                "yaw_rad": yaw,
                "lateral_m": lateral,
                "landing_m": float(rng.uniform(0.6, 1.5)),
            }
            ob = StairSpec(**{**params, **ob_over})
        elif kind == "box":
            params = {
                "height_m": float(rng.uniform(0.10, 0.30)),
                "depth_m": float(rng.uniform(0.3, 0.8)),
                "width_m": float(rng.uniform(0.4, 1.2)),
                "distance_m": distance,
                "yaw_rad": yaw,
                "lateral_m": lateral,
            }
            ob = BoxSpec(**{**params, **ob_over})
        else:
            ob = None
        geometry: dict[str, Any] = {
            "obstacle": ob,
            "camera_height_m": float(rng.uniform(0.4, 0.8)),
            "pitch_down_rad": math.radians(rng.uniform(0.0, 30.0)),
            "baseline_m": float(rng.uniform(0.075, 0.085)),
            "body_rpy": (math.radians(rng.uniform(-3.0, 3.0)), math.radians(rng.uniform(-3.0, 3.0)), 0.0),
        }
        values: dict[str, Any] = {**appearance, **geometry, "image_size": size, "weak_texture": weak}
        values.update(sc_over)
        if "back_wall_m" not in sc_over:
            end = _obstacle_far_end(values["obstacle"])
            gap = {"stairs": 2.5, "box": 4.0, "none": 5.0}[kind] * wall_draw[1]
            lead = {"stairs": 0.0, "box": 1.5, "none": 3.0}[kind]
            values["back_wall_m"] = end + lead + gap + 1e-3 if wall_draw[0] else None
        candidate = SceneSpec(**values)
        if _in_view(candidate):
            spec = candidate
            break
    if spec is None:
        raise InputError(
            "could not place the obstacle in view of the left camera with these overrides "
            f"({sorted(overrides)}); relax them"
        )
    weak_groups = ("riser", "side") + (("tread",) if weak_tread else ()) if weak else ()
    return _paint(spec, weak_groups, weak_levels, floor_levels, sc_over)


def _nominal_grey(spec: SceneSpec, surf: SurfaceSpec, normal: np.ndarray) -> float:
    el, az = spec.light_elevation_rad, spec.light_azimuth_rad
    light = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    shade = spec.ambient + spec.diffuse * max(float(normal @ light), 0.0)
    return spec.exposure * surf.albedo * shade


#: Brightest nominal grey level (before texture) of any surface of a random scene.
_MAX_NOMINAL_GREY = 200.0


def _paint(
    spec: SceneSpec,
    weak_groups: tuple[str, ...],
    weak_levels: np.ndarray,
    floor_levels: np.ndarray,
    sc_over: dict,
) -> SceneSpec:
    """Set the texture contrast of every surface in grey levels (std, before noise).

    Albedos are lowered where a face would be brighter than ``_MAX_NOMINAL_GREY``.

    Surfaces in ``weak_groups`` get ``weak_levels`` (0.5-1.5 grey levels: painted); the
    others at least ``floor_levels`` (6-10), so that "textured" holds for dark faces too.
    """
    yaw = 0.0 if spec.obstacle is None else spec.obstacle.yaw_rad
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    up = np.array([0.0, 0.0, 1.0])
    normals = {"ground": [up], "tread": [up], "riser": [-u], "side": [v, -v], "wall": [-u]}
    changes: dict[str, Any] = {}
    for gi, name in enumerate(_GROUPS):
        if name in sc_over:
            continue
        surf: SurfaceSpec = getattr(spec, name)
        brightest = max(_nominal_grey(spec, surf, n) for n in normals[name])
        if brightest > _MAX_NOMINAL_GREY:  # keep lit faces out of saturation
            surf = dataclasses.replace(surf, albedo=surf.albedo * _MAX_NOMINAL_GREY / brightest)
        grey = max(float(np.mean([_nominal_grey(spec, surf, n) for n in normals[name]])), 20.0)
        if name in weak_groups:
            contrast = weak_levels[gi] / grey
        else:
            contrast = max(surf.contrast, floor_levels[gi] / grey)
        changes[name] = dataclasses.replace(surf, contrast=float(min(contrast, 0.6)))
    return dataclasses.replace(spec, **changes)


def default_scene_spec() -> SceneSpec:
    """The built-in demo staircase.

    Three steps (rise 0.17 m, run 0.29 m, width 1.2 m), first riser 1.3 m ahead on the
    x axis, stair axis yawed by 10 deg, a 1.0 m landing and a back wall; the left camera
    0.55 m high pitched down 15 deg, 8 cm baseline, 640 x 480, well textured, with mild
    distortion, a 0.85 deg relative rotation and a gain difference between the cameras.
    """
    size = (640, 480)
    left = CameraIntrinsics(550.0, 550.4, 321.3, 238.2, (-0.12, 0.03, 2e-4, -1e-4, 0.0))
    right = CameraIntrinsics(553.1, 553.3, 317.9, 241.0, (-0.10, 0.02, -1e-4, 3e-4, 0.0))
    stairs = StairSpec(
        n_steps=3,
        rise_m=0.17,
        run_m=0.29,
        width_m=1.2,
        distance_m=1.3,
        yaw_rad=math.radians(10.0),
        lateral_m=0.05,
        landing_m=1.0,
    )
    return SceneSpec(
        obstacle=stairs,
        camera_height_m=0.55,
        pitch_down_rad=math.radians(15.0),
        baseline_m=0.08,
        image_size=size,
        body_rpy=(math.radians(0.5), math.radians(-1.0), 0.0),
        weak_texture=False,
        seed=2024,
        left_camera=left,
        right_camera=right,
        right_rotvec_rad=(-0.009, -0.011, 0.004),
        right_offset_m=(0.0004, -0.0003),
        back_wall_m=_obstacle_far_end(stairs) + 1.0,
        ground=SurfaceSpec("tiles", 1.2, 0.45, 0.22),
        tread=SurfaceSpec("wood", 0.9, 0.62, 0.2),
        riser=SurfaceSpec("speckle", 0.7, 0.75, 0.18),
        side=SurfaceSpec("noise", 0.9, 0.5, 0.18),
        wall=SurfaceSpec("noise", 1.5, 0.65, 0.15),
        light_azimuth_rad=math.radians(150.0),
        light_elevation_rad=math.radians(55.0),
        ambient=0.35,
        diffuse=0.6,
        exposure=210.0,
        sky_grey=200.0,
        noise_sigma=(1.5, 1.8),
        right_gain=1.06,
        right_offset_grey=-4.0,
        vignetting=0.12,
        blur_sigma_px=0.4,
        supersample=2,
    )


# --------------------------------------------------------------------------- files


def write_scene(scene: SyntheticScene, out_dir: str | Path) -> Path:
    """Write a scene as files readable by the rest of the package.

    ``left.png``, ``right.png`` (raw grey), ``calib.yaml`` (OpenCV FileStorage, see
    :func:`~stereo_terrain.calibration.write_opencv_yaml`), ``rig.yaml``
    (:func:`~stereo_terrain.frames.save_rig`), ``truth.json`` (the truth dict) and
    ``depth_left.npy`` ((H, W) float32 metres, NaN where nothing is hit).

    Returns
    -------
    Path
        ``out_dir`` (created if missing).
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create scene directory {out}: {exc.strerror}") from None
    for name, img in (("left.png", scene.left), ("right.png", scene.right)):
        if not cv2.imwrite(str(out / name), np.ascontiguousarray(img)):
            raise InputError(f"cannot write {out / name}")
    write_opencv_yaml(scene.calibration, out / "calib.yaml")
    save_rig(scene.rig, out / "rig.yaml")
    (out / "truth.json").write_text(json.dumps(scene.truth, indent=2) + "\n")
    np.save(out / "depth_left.npy", np.asarray(scene.depth_left, dtype=np.float32))
    return out


def render_scenes(out_dir: str | Path, count: int, seed: int, **kw: Any) -> list[Path]:
    """Render ``count`` random scenes into ``out_dir/scene_000``, ``scene_001``, ...

    Deterministic: the same ``seed`` (and ``kw``, passed to :func:`random_scene_spec`)
    writes the same files.
    """
    count = _check_int("render_scenes", "count", count, 0, 100_000)
    seed = _check_int("render_scenes", "seed", seed, 0, 2**63 - 1)
    rng = np.random.default_rng(seed)
    paths = []
    for i in range(count):
        spec = random_scene_spec(rng, **kw)
        paths.append(write_scene(render_scene(spec), Path(out_dir) / f"scene_{i:03d}"))
    return paths
