"""Scene specifications and their checks: stairs, boxes, cameras, surfaces, the scene.

Every spec is a frozen dataclass validated when built (:class:`~stereo_terrain.errors.InputError`
naming the field, what was expected and what came); :func:`render_scene` is a pure
function of a :class:`SceneSpec`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError

#: Texture kinds a :class:`SurfaceSpec` may name.
TEXTURE_KINDS = ("noise", "wood", "carpet", "tiles", "speckle", "planks", "paint")

#: Profiles of :func:`random_scene_spec` (recorded in :attr:`SceneSpec.profile`).
PROFILES = ("default", "realistic")

#: Sides a handrail may run along, looking up the stairs.
RAIL_SIDES = ("left", "right")

#: Face groups: each has its own surface (texture, albedo, contrast).
_GROUPS = ("ground", "tread", "riser", "side", "wall", "rail")


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
    """Appearance of one face group (ground, treads, risers, stair sides, walls, rails).

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
    left_wall_m, right_wall_m : float or None
        Side walls parallel to the obstacle axis (frame x without obstacle): the inner
        face of the left wall is the plane ``v . p = left_wall_m``, of the right wall
        ``v . p = right_wall_m`` (``v`` the lateral axis, positive to the left). They must
        lie beside the obstacle (left of its left side, right of its right side) and on
        either side of both cameras' lateral position where they reach past them. None:
        no wall (default). Listed in the truth planes as ``left_wall`` / ``right_wall``.
    side_wall_height_m : float
        Height of the side walls above the ground, metres.
    side_wall_start_m : float or None
        Coordinate along the axis (``u . p``) where the side walls begin, metres; they end
        at the back wall, or 5 m beyond the obstacle's far end. None: at the first riser
        (box front); -5 m without obstacle.
    handrails : tuple of str
        Sides (:data:`RAIL_SIDES`) of a staircase with a handrail: a sloped bar
        ``handrail_height_m`` above the nosing line, beside the wall on a side with a
        wall, else over the stair's edge. Stairs only; empty by default.
    balusters : bool
        Vertical bars under the handrails of sides without a wall (one per tread, and
        one more per tread when the run exceeds 0.28 m), plus a newel post.
    handrail_height_m : float
        Height of the handrail's top above the nosing line, metres.
    rail : SurfaceSpec
        Appearance of handrails and balusters.
    nosing_m : float
        Depth of a strip of other (darker or lighter) reflectance at the front edge of
        every tread (and its 2-3 cm along the top of the riser below), metres; 0 = none.
    nosing_reflectance : float
        Factor on the reflectance of the nosing strip (< 1: darker).
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
    right_blur_sigma_px : float or None
        Blur of the right camera's optics when it differs from the left one's, pixels;
        None: ``blur_sigma_px``.
    supersample : int
        Samples per pixel side (1..4); 2 means 2 x 2 samples.
    shot_noise : float
        Signal-dependent noise: variance ``noise_sigma**2 + shot_noise * grey``, grey
        levels (0 = none).
    jpeg_quality : (2,) int or None
        JPEG quality (1..100) of the left and right image, encoded and decoded with
        OpenCV after quantisation (webcams send MJPEG); None: no JPEG.
    texture_origin_m : (2,) float
        Frame (x, y) of the point the textures' coordinates count from, metres: (0, 0),
        the frame's origin, by default. A simulated approach moves it with the stairs
        (``-x`` for a camera ``x`` further on), so that textures stay on the surfaces as
        the camera walks instead of sliding with it.
    noise_seed : int or None
        Seeds the sensor noise apart from ``seed`` (None: ``seed`` alone, as before): an
        approach's frames each get their own noise over the same textures.
    profile : str
        Which :func:`random_scene_spec` profile drew this spec (:data:`PROFILES`);
        informational, copied to the truth.
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
    left_wall_m: float | None = None
    right_wall_m: float | None = None
    side_wall_height_m: float = 2.2
    side_wall_start_m: float | None = None
    handrails: tuple[str, ...] = ()
    balusters: bool = False
    handrail_height_m: float = 0.9
    rail: SurfaceSpec = field(default_factory=lambda: SurfaceSpec("paint", 0.5, 0.7, 0.02))
    right_blur_sigma_px: float | None = None
    nosing_m: float = 0.0
    nosing_reflectance: float = 0.4
    shot_noise: float = 0.0
    jpeg_quality: tuple[int, int] | None = None
    texture_origin_m: tuple[float, float] = (0.0, 0.0)
    noise_seed: int | None = None
    profile: str = "default"

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
        if self.right_blur_sigma_px is not None:
            _set(
                self,
                "right_blur_sigma_px",
                _check_range(o, "right_blur_sigma_px", self.right_blur_sigma_px, 0.0, 5.0, " px"),
            )
        self._check_walls_and_rails()
        _set(self, "nosing_m", _check_range(o, "nosing_m", self.nosing_m, 0.0, 0.2, " m"))
        _set(
            self,
            "nosing_reflectance",
            _check_range(o, "nosing_reflectance", self.nosing_reflectance, 0.05, 3.0),
        )
        _set(self, "shot_noise", _check_range(o, "shot_noise", self.shot_noise, 0.0, 2.0))
        if self.jpeg_quality is not None:
            try:
                q = tuple(self.jpeg_quality)
            except TypeError:
                q = ()
            if len(q) != 2:
                raise InputError(f"{o}.jpeg_quality must be None or (left, right), got {self.jpeg_quality!r}")
            _set(self, "jpeg_quality", tuple(_check_int(o, "jpeg_quality", v, 1, 100) for v in q))
        _set(self, "texture_origin_m", _check_tuple(o, "texture_origin_m", self.texture_origin_m, 2))
        if self.noise_seed is not None:
            _set(self, "noise_seed", _check_int(o, "noise_seed", self.noise_seed, 0, 2**63 - 1))
        if self.profile not in PROFILES:
            raise InputError(f"{o}.profile must be one of {PROFILES}, got {self.profile!r}")

    def _check_walls_and_rails(self) -> None:
        o = "SceneSpec"
        ob = self.obstacle
        b_lo, b_hi = _obstacle_lateral_span(ob)
        for name, side in (("left_wall_m", 1.0), ("right_wall_m", -1.0)):
            value = getattr(self, name)
            if value is None:
                continue
            wall = _check_range(o, name, value, -50.0, 50.0, " m")
            if ob is not None and (wall < b_hi if side > 0 else wall > b_lo):
                where = f">= {b_hi:.3f}" if side > 0 else f"<= {b_lo:.3f}"
                raise InputError(f"{o}.{name} must lie beside the obstacle ({where} m), got {value}")
            _set(self, name, wall)
        if self.left_wall_m is not None and self.right_wall_m is not None:
            if not self.left_wall_m - self.right_wall_m > 0.2:
                raise InputError(
                    f"{o}.left_wall_m must exceed right_wall_m by more than 0.2 m, got "
                    f"{self.left_wall_m} and {self.right_wall_m}"
                )
        _set(
            self,
            "side_wall_height_m",
            _check_positive(o, "side_wall_height_m", self.side_wall_height_m, 20.0),
        )
        if self.side_wall_start_m is not None:
            start = _check_range(o, "side_wall_start_m", self.side_wall_start_m, -50.0, 50.0, " m")
            if start >= _side_wall_end(self.obstacle, self.back_wall_m, start):
                raise InputError(f"{o}.side_wall_start_m must lie before the back wall, got {start}")
            _set(self, "side_wall_start_m", start)
        rails: tuple = (self.handrails,) if isinstance(self.handrails, str) else ()
        if not rails:
            try:
                rails = tuple(self.handrails)
            except TypeError:
                rails = (self.handrails,)
        if any(r not in RAIL_SIDES for r in rails) or len(set(rails)) != len(rails):
            raise InputError(f"{o}.handrails must be distinct sides of {RAIL_SIDES}, got {self.handrails!r}")
        if rails and not isinstance(ob, StairSpec):
            raise InputError(f"{o}.handrails need a StairSpec obstacle, got {type(ob).__name__}")
        _set(self, "handrails", rails)
        if not isinstance(self.balusters, bool | np.bool_):
            raise InputError(f"{o}.balusters must be a bool, got {self.balusters!r}")
        _set(self, "balusters", bool(self.balusters))
        _set(
            self,
            "handrail_height_m",
            _check_range(o, "handrail_height_m", self.handrail_height_m, 0.3, 1.5, " m"),
        )


def _obstacle_centre_b(obstacle: StairSpec | BoxSpec) -> float:
    """Lateral coordinate ``v . p`` of the obstacle's centre line, metres.

    The centre of the first riser's bottom edge is ``(distance_m, 0, 0) + lateral_m * v``.
    """
    return obstacle.lateral_m - obstacle.distance_m * math.sin(obstacle.yaw_rad)


def _obstacle_lateral_span(obstacle: StairSpec | BoxSpec | None) -> tuple[float, float]:
    """``(b_lo, b_hi)``: lateral coordinates ``v . p`` of the obstacle's sides (0, 0 without)."""
    if obstacle is None:
        return 0.0, 0.0
    b_mid = _obstacle_centre_b(obstacle)
    return b_mid - obstacle.width_m / 2, b_mid + obstacle.width_m / 2


def _side_wall_span(spec: SceneSpec) -> tuple[float, float]:
    """``(a_start, a_end)`` of the side walls along the axis, metres."""
    ob = spec.obstacle
    if spec.side_wall_start_m is not None:
        start = spec.side_wall_start_m
    else:
        start = -5.0 if ob is None else ob.distance_m * math.cos(ob.yaw_rad)
    return start, _side_wall_end(ob, spec.back_wall_m, start)


def _side_wall_end(obstacle: StairSpec | BoxSpec | None, back_wall_m: float | None, start: float) -> float:
    if back_wall_m is not None:
        return back_wall_m
    return max(_obstacle_far_end(obstacle), start) + 5.0


def _obstacle_far_end(obstacle: StairSpec | BoxSpec | None) -> float:
    """Coordinate along the obstacle axis of its far end (0 without obstacle), metres."""
    if obstacle is None:
        return 0.0
    s0 = obstacle.distance_m * math.cos(obstacle.yaw_rad)
    if isinstance(obstacle, StairSpec):
        return s0 + (obstacle.n_steps - 1) * obstacle.run_m + obstacle.landing_m
    return s0 + obstacle.depth_m


# --------------------------------------------------------------------------- lens check


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
