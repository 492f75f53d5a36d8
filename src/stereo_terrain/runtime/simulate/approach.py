"""The approach: its configuration, the scene seen from each point of the walk, and the
rendered frames (the body at constant speed, the trot's pitch in its attitude)."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ...checks import check_fields
from ...errors import ConfigError
from ...odometry import Odometry
from ...synthetic import SceneSpec, StairSpec, SurfaceSpec, SyntheticScene, random_scene_spec, render_scene
from ..capture import StereoFrame

MAX_FRAMES = 20_000  # about 11 minutes of a 30 fps camera

#: The looks of an approach (:attr:`ApproachConfig.profile`).
APPROACH_PROFILES = ("default", "realistic")

# Plausible ranges of the approach's values (a number outside is a typo or a unit mistake,
# and 1e308 would overflow the frame count).
_RANGES = {
    "rise_m": (0.01, 1.0, "m"),
    "run_m": (0.05, 2.0, "m"),
    "width_m": (0.1, 20.0, "m"),
    "start_distance_m": (0.0, 50.0, "m"),
    "speed_mps": (0.01, 5.0, "m/s"),
    "gait_period_s": (0.05, 10.0, "s"),
}


@dataclass(frozen=True)
class ApproachConfig:
    """The staircase, the walk and the rendering of a simulated approach (SI units).

    Attributes
    ----------
    rise_m, run_m, width_m : float
        Steps of the staircase.
    n_steps : int
    start_distance_m : float
        First riser's distance from the body origin at the first frame.
    end_distance_m : float
        Last rendered frame: the first riser this far ahead (closer, the camera sees
        little of the stairs; the walk goes on with odometry).
    speed_mps : float
        Walking speed.
    fps : float
        Camera frame rate.
    gait_period_s : float
        Trot period (a swing is half of it).
    pitch_amplitude_rad : float
        Body pitch oscillation of the trot (twice per gait period).
    front_hip_m, rear_hip_m : float
        Hip positions along body x (the camera sits at the body origin).
    camera_height_m, pitch_down_rad : float
        The stereo rig's mounting.
    image_size : (width, height)
    supersample : int
        Renderer samples per pixel side.
    seed : int
    stair_yaw_rad : float
        Stair axis w.r.t. the walking direction (the first riser still meets the body's
        path ``start_distance_m`` ahead), ``|yaw| <= 45 deg``.
    odometry_drift : float
        Scale error of the odometry the robot reports (the frames' ``odometry``):
        ``x_reported = (1 + drift) x``; 0.02 is 2 % drift (issue 14). The foot model and
        the truth use the true position.
    profile : {"default", "realistic"}
        The look of the scene (:data:`APPROACH_PROFILES`). ``"realistic"`` keeps the
        stairs and the rig above and draws the rest from ``seed`` as
        ``random_scene_spec(profile="realistic")`` does: walls (beginning at the first
        riser), handrails, materials, lens distortion, sensor noise, JPEG.
    """

    rise_m: float = 0.21
    run_m: float = 0.28
    width_m: float = 1.2
    n_steps: int = 3
    start_distance_m: float = 2.2
    end_distance_m: float = 0.45
    speed_mps: float = 0.5
    fps: float = 30.0
    gait_period_s: float = 0.5
    pitch_amplitude_rad: float = math.radians(1.0)
    front_hip_m: float = -0.15
    rear_hip_m: float = -0.75
    camera_height_m: float = 0.55
    pitch_down_rad: float = math.radians(15.0)
    image_size: tuple[int, int] = (640, 480)
    supersample: int = 2
    seed: int = 7
    lift_fraction: float = 0.1
    stair_yaw_rad: float = 0.0
    odometry_drift: float = 0.0
    profile: str = "default"

    def __post_init__(self) -> None:
        if self.profile not in APPROACH_PROFILES:
            raise ConfigError(
                f"ApproachConfig.profile must be one of {', '.join(APPROACH_PROFILES)}, got {self.profile!r}"
            )
        check_fields(self)
        if not 0 < self.end_distance_m < self.start_distance_m:
            raise ConfigError(
                f"the approach must start further than {self.end_distance_m} m from the stairs "
                f"(--start), got {self.start_distance_m} m"
            )
        for name in ("speed_mps", "fps", "gait_period_s", "rise_m", "run_m", "width_m"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"ApproachConfig.{name} must be > 0, got {getattr(self, name)}")
        for name, (lo, hi, unit) in _RANGES.items():
            v = getattr(self, name)
            if v < lo:
                raise ConfigError(f"ApproachConfig.{name} must be >= {lo:g} {unit}, got {v:g}")
            if v > hi:
                raise ConfigError(f"ApproachConfig.{name} must be <= {hi:g} {unit}, got {v:g}")
        if not 1 <= self.n_steps <= 50 or not 1 <= self.supersample <= 8:
            raise ConfigError("ApproachConfig.n_steps must be in [1, 50] and supersample in [1, 8]")
        try:
            w, h = (int(v) for v in self.image_size)
        except (TypeError, ValueError):
            raise ConfigError(
                f"ApproachConfig.image_size must be (width, height), got {self.image_size!r}"
            ) from None
        if not (32 <= w <= 4096 and 32 <= h <= 4096):
            raise ConfigError(f"ApproachConfig.image_size must be within 32x32 .. 4096x4096, got {w}x{h}")
        object.__setattr__(self, "image_size", (w, h))  # a tuple: the config is hashed (cached scenes)
        if not self.rear_hip_m < self.front_hip_m:
            raise ConfigError("ApproachConfig.rear_hip_m must lie behind front_hip_m")
        if not 0 <= self.lift_fraction < 0.5:
            raise ConfigError("ApproachConfig.lift_fraction must be in [0, 0.5)")
        if not abs(self.stair_yaw_rad) <= math.radians(45.0):
            raise ConfigError(
                f"ApproachConfig.stair_yaw_rad must be within +-45 deg, got {self.stair_yaw_rad}"
            )
        if not abs(self.odometry_drift) <= 0.2:
            raise ConfigError(
                f"ApproachConfig.odometry_drift must be within +-0.2, got {self.odometry_drift}"
            )
        frames = (self.start_distance_m - self.end_distance_m) * self.fps / self.speed_mps
        if not frames < MAX_FRAMES:  # also inf and NaN
            raise ConfigError(
                f"the approach would render {frames:.3g} frames (more than {MAX_FRAMES}); "
                "lower --fps or raise --speed"
            )
        if self.fps < 1.0:
            raise ConfigError(f"ApproachConfig.fps must be >= 1 frames/s, got {self.fps:g}")

    @property
    def frame_count(self) -> int:
        """Frames rendered from ``start_distance_m`` to ``end_distance_m``."""
        step = self.speed_mps / self.fps
        return int(math.floor((self.start_distance_m - self.end_distance_m) / step)) + 1

    @property
    def riser_x_m(self) -> float:
        """World x of the first riser (the body starts at x = 0)."""
        return self.start_distance_m


def approach_spec(cfg: ApproachConfig, x_m: float, pitch_rad: float, frame: int | None = None) -> SceneSpec:
    """The scene seen from body position ``x_m`` (world) with body pitch ``pitch_rad``.

    The textures stay on the surfaces as the body walks (``SceneSpec.texture_origin_m``
    at the world's origin); ``frame`` (the frame's index) draws the frame's own sensor
    noise (None: the scene's seed alone)."""
    if cfg.profile == "realistic":
        return _moved(_realistic_start(cfg), x_m, pitch_rad, frame)
    d = cfg.start_distance_m - x_m
    stairs = StairSpec(
        n_steps=cfg.n_steps,
        rise_m=cfg.rise_m,
        run_m=cfg.run_m,
        width_m=cfg.width_m,
        distance_m=d,
        yaw_rad=cfg.stair_yaw_rad,
        landing_m=1.0,
    )
    return SceneSpec(
        obstacle=stairs,
        camera_height_m=cfg.camera_height_m,
        pitch_down_rad=cfg.pitch_down_rad,
        image_size=cfg.image_size,
        body_rpy=(0.0, pitch_rad, 0.0),
        seed=cfg.seed,
        back_wall_m=d + cfg.n_steps * cfg.run_m + 2.0,
        tread=SurfaceSpec("wood", 0.9, 0.62, 0.2),
        riser=SurfaceSpec("speckle", 0.7, 0.75, 0.18),
        supersample=cfg.supersample,
        texture_origin_m=(-x_m, 0.0),
        noise_seed=frame,
    )


@functools.lru_cache(maxsize=4)
def _realistic_start(cfg: ApproachConfig) -> SceneSpec:
    """The realistic scene at the first frame: ``cfg``'s stairs and rig, the rest drawn
    from ``cfg.seed``; the side walls begin at the first riser (walls reaching back past
    the cameras would have to stay on either side of them all along the walk)."""
    spec = random_scene_spec(
        np.random.default_rng(cfg.seed), image_size=cfg.image_size, kind="stairs", profile="realistic",
        n_steps=cfg.n_steps, rise_m=cfg.rise_m, run_m=cfg.run_m, width_m=cfg.width_m,
        distance_m=cfg.start_distance_m, yaw_rad=cfg.stair_yaw_rad, lateral_m=0.0,
        camera_height_m=cfg.camera_height_m, pitch_down_rad=cfg.pitch_down_rad,
        body_rpy=(0.0, 0.0, 0.0), supersample=cfg.supersample,
    )  # fmt: skip
    return dataclasses.replace(spec, side_wall_start_m=None)


def _moved(start: SceneSpec, x_m: float, pitch_rad: float, frame: int | None) -> SceneSpec:
    """``start`` seen from ``x_m`` further along the frame's x axis, with body pitch
    ``pitch_rad``: the stairs ``x_m`` closer along x (the first riser still meets the
    path at ``distance_m``), the back wall ``x_m cos(yaw)`` closer along the stair axis,
    the side walls ``x_m sin(yaw)`` over along the lateral axis ``v = (-sin, cos, 0)``,
    the textures' origin ``x_m`` back; ``frame`` seeds the frame's sensor noise."""
    ob = start.obstacle
    assert isinstance(ob, StairSpec)
    c, s = math.cos(ob.yaw_rad), math.sin(ob.yaw_rad)

    def shifted(b: float | None, by: float) -> float | None:
        return None if b is None else b + by

    return dataclasses.replace(
        start,
        obstacle=dataclasses.replace(ob, distance_m=ob.distance_m - x_m),
        back_wall_m=shifted(start.back_wall_m, -x_m * c),
        left_wall_m=shifted(start.left_wall_m, x_m * s),
        right_wall_m=shifted(start.right_wall_m, x_m * s),
        body_rpy=(0.0, pitch_rad, 0.0),
        texture_origin_m=(-x_m, 0.0),
        noise_seed=frame,
    )


def body_pitch(cfg: ApproachConfig, t_s: float) -> float:
    """Body pitch of the trot at time ``t_s`` (two oscillations per gait period)."""
    return cfg.pitch_amplitude_rad * math.sin(4.0 * math.pi * t_s / cfg.gait_period_s)


def render_approach(cfg: ApproachConfig) -> Iterator[tuple[StereoFrame, SyntheticScene]]:
    """Render the approach frame by frame: raw pair, capture time, odometry and attitude.

    Frame ``k`` is taken at ``t = k / fps`` with the body at ``x = speed * t``
    (:func:`true_x`); its odometry reports ``(1 + odometry_drift) x``.
    """
    for k in range(cfg.frame_count):
        t = k / cfg.fps
        x = true_x(cfg, t)
        pitch = body_pitch(cfg, t)
        scene = render_scene(approach_spec(cfg, x, pitch, k))
        odo = Odometry(((1.0 + cfg.odometry_drift) * x, 0.0, 0.0), 0.0, t)
        frame = StereoFrame(scene.left, scene.right, t, t, k, odo, (0.0, pitch, 0.0))
        yield frame, scene


def true_x(cfg: ApproachConfig, t_s: float) -> float:
    """True body x (world) at time ``t_s`` of the approach."""
    return cfg.speed_mps * t_s
