"""A simulated approach: a trotting robot with the stereo rig walks toward a staircase.

Frames are rendered along the robot's path (:mod:`stereo_terrain.synthetic`, the robot
moving is the staircase coming closer in the body's yaw frame, with the trot's pitch
oscillation in the body attitude), run through the live loop (pipeline + swing trigger
+ terrain messages), and a kinematic foot model walks the four feet over the true step
profile with the swing heights the messages command. The same walk with the blind
nominal swing shows what the perception buys: with the paper's numbers a 0.15 m swing
hits the edge of a 0.21 m step, the raised one clears it.

Two looks (``ApproachConfig.profile``): ``"default"``, the textured staircase of the
default profile before a back wall, and ``"realistic"``, the same stairs and rig dressed
as the realistic profile's scenes (issue 11): side walls, handrails, wood or paint, a
webcam's lens, noise and JPEG, drawn from ``seed``. The walls move with the stairs; the
floor's texture stays with the camera (it is drawn in the frame's coordinates), which
does not change what a single pair shows.

Foot model (sagittal plane, point feet, body at constant speed ``v``): trot, diagonal
pairs half a period apart; a swing lasts ``T/2``, lifts off where the foot stood and
touches down ``v T / 4`` ahead of its hip (Raibert's heuristic, as on the Cheetah). Along
the swing the foot first lifts (the first ``lift_fraction`` of the swing) then moves
forward on a quintic; its height follows ``z_lo + (apex - z_lo) sin(pi s)`` up to the apex
(``apex = z_lo + swing height``) and ``z_td + (apex - z_td) sin(pi s)`` down to the
touchdown height. The swing height is chosen at lift-off, as a controller does.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import check_fields
from ..errors import ConfigError
from ..odometry import Odometry
from ..swing import SwingConfig
from ..synthetic import SceneSpec, StairSpec, SurfaceSpec, SyntheticScene, random_scene_spec, render_scene
from .capture import END, FRAME, CaptureEvent, StereoFrame
from .messages import terrain_t

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


def approach_spec(cfg: ApproachConfig, x_m: float, pitch_rad: float) -> SceneSpec:
    """The scene seen from body position ``x_m`` (world) with body pitch ``pitch_rad``."""
    if cfg.profile == "realistic":
        return _moved(_realistic_start(cfg), x_m, pitch_rad)
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


def _moved(start: SceneSpec, x_m: float, pitch_rad: float) -> SceneSpec:
    """``start`` seen from ``x_m`` further along the frame's x axis, with body pitch
    ``pitch_rad``: the stairs ``x_m`` closer along x (the first riser still meets the
    path at ``distance_m``), the back wall ``x_m cos(yaw)`` closer along the stair axis,
    the side walls ``x_m sin(yaw)`` over along the lateral axis ``v = (-sin, cos, 0)``."""
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
        scene = render_scene(approach_spec(cfg, x, pitch))
        odo = Odometry(((1.0 + cfg.odometry_drift) * x, 0.0, 0.0), 0.0, t)
        frame = StereoFrame(scene.left, scene.right, t, t, k, odo, (0.0, pitch, 0.0))
        yield frame, scene


def true_x(cfg: ApproachConfig, t_s: float) -> float:
    """True body x (world) at time ``t_s`` of the approach."""
    return cfg.speed_mps * t_s


class FrameSource:
    """A source over given frames (in memory), in order; events may be injected as is.

    Used by ``simulate`` and by tests to inject faults (``CaptureEvent`` items are given
    out unchanged: ``none`` for a camera that has nothing, ``unreadable`` ...).
    """

    def __init__(self, items: Iterable[StereoFrame | CaptureEvent]) -> None:
        self._items = iter(items)
        self.closed = False

    def read(self) -> CaptureEvent:
        item = next(self._items, None)
        if item is None:
            return CaptureEvent(END)
        if isinstance(item, CaptureEvent):
            return item
        return CaptureEvent(FRAME, item)

    def close(self) -> None:
        self.closed = True


# --------------------------------------------------------------------------- swing commands


@dataclass(frozen=True)
class SwingCommand:
    """What the controller knows from one terrain message (the fields of ``terrain_t`` it uses).

    Attributes
    ----------
    x_m : float
        Body x (world) when the message was published (its frame's odometry).
    p0_x_m : float
        World x the trigger distance is counted from.
    trigger_distance_m : float
        ``d - d_buffer`` (NaN: nothing to trigger on).
    height_m : float
    raised : bool
        The state machine's decision when published.
    approach : bool
        The state machine is tracking stairs (not idle, not blocked).
    """

    x_m: float
    p0_x_m: float
    trigger_distance_m: float
    height_m: float
    raised: bool
    approach: bool

    @classmethod
    def from_message(cls, msg: terrain_t, x_m: float) -> SwingCommand:
        return cls(
            x_m=float(x_m),
            p0_x_m=float(msg.p0_m[0]),
            trigger_distance_m=float(msg.trigger_distance_m),
            height_m=float(msg.swing_height_m),
            raised=bool(msg.raise_swing),
            approach=msg.trigger_phase == terrain_t.PHASE_APPROACH,
        )


def commanded_swing(commands: Sequence[SwingCommand], x_m: float, nominal_m: float) -> tuple[bool, float]:
    """(raised, swing height) for a controller at body x ``x_m`` (world, heading +x).

    Uses the latest message published before the body got there and applies eq. 2 at the
    controller's own rate: raised once ``x - p0_x >= d - d_buffer``.
    """
    cmd = None
    for c in commands:
        if c.x_m <= x_m + 1e-9:
            cmd = c
        else:
            break
    if cmd is None:
        return False, nominal_m
    raised = cmd.raised or (
        cmd.approach and math.isfinite(cmd.trigger_distance_m) and x_m - cmd.p0_x_m >= cmd.trigger_distance_m
    )
    return raised, (cmd.height_m if raised else nominal_m)


def trigger_position(
    commands: Sequence[SwingCommand], x_end_m: float, nominal_m: float, step_m: float = 0.001
) -> float | None:
    """First body x (world) at which the controller raises the swing, sampled every ``step_m``."""
    if not commands:
        return None
    for x in np.arange(commands[0].x_m, x_end_m, step_m):
        if commanded_swing(commands, float(x), nominal_m)[0]:
            return float(x)
    return None


# --------------------------------------------------------------------------- foot model


def step_profile(cfg: ApproachConfig, x: np.ndarray | float) -> np.ndarray:
    """True terrain height (m) at world x (m): ground, then the steps, then the landing."""
    x = np.asarray(x, dtype=np.float64)
    k = np.floor((x - cfg.riser_x_m) / cfg.run_m) + 1
    return np.clip(k, 0, cfg.n_steps) * cfg.rise_m


@dataclass(frozen=True)
class FootSwing:
    """One swing of one foot: its path and its clearance of the first riser's edge.

    Attributes
    ----------
    leg : str
    t_lo_s : float
    height_m : float
        Commanded swing height.
    x_m, z_m : (S,) float
        Foot path (world x, height), metres.
    edge_clearance_m : float or None
        Foot height minus the first riser's top where the swing passes over the riser
        plane (negative: the foot hits the edge); None if this swing does not cross it.
    min_clearance_m : float
        Lowest foot height above the true profile along the swing's moving part.
    """

    leg: str
    t_lo_s: float
    height_m: float
    x_m: np.ndarray = field(repr=False)
    z_m: np.ndarray = field(repr=False)
    edge_clearance_m: float | None
    min_clearance_m: float


def _quintic(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def simulate_feet(
    cfg: ApproachConfig, swing_height: Any, *, samples: int = 200, legs_past_m: float = 0.5
) -> list[FootSwing]:
    """Walk the four feet over the step profile; ``swing_height(x_body) -> height`` at lift-off.

    Runs until the rear feet are ``legs_past_m`` past the first riser.
    """
    v, period = cfg.speed_mps, cfg.gait_period_s
    t_sw = 0.5 * period
    legs = {"FL": (cfg.front_hip_m, 0.0), "RR": (cfg.rear_hip_m, 0.0),
            "FR": (cfg.front_hip_m, 0.5), "RL": (cfg.rear_hip_m, 0.5)}  # fmt: skip
    t_end = (cfg.riser_x_m - cfg.rear_hip_m + legs_past_m) / v
    s = np.linspace(0.0, 1.0, samples)
    a = cfg.lift_fraction
    out: list[FootSwing] = []
    for leg, (hip, phase) in legs.items():
        x_foot = hip  # standing under the hip at t = 0
        t_lo = phase * period
        while t_lo < t_end:
            body_lo = v * t_lo
            t_td = t_lo + t_sw
            x_lo = x_foot
            x_td = hip + v * t_td + v * (period - t_sw) / 2.0
            z_lo, z_td = float(step_profile(cfg, x_lo)), float(step_profile(cfg, x_td))
            h = float(swing_height(body_lo))
            apex = z_lo + h
            xs = x_lo + (x_td - x_lo) * _quintic((s - a) / (1.0 - 2.0 * a))
            zs = np.where(
                s <= 0.5, z_lo + (apex - z_lo) * np.sin(np.pi * s), z_td + (apex - z_td) * np.sin(np.pi * s)
            )
            moving = (s > a) & (s < 1.0 - a)
            ground = step_profile(cfg, xs)
            min_clear = float(np.min((zs - ground)[moving])) if moving.any() else 0.0
            edge = None
            xr = cfg.riser_x_m
            if x_lo < xr <= x_td:
                i = int(np.searchsorted(xs, xr))
                i = min(max(i, 1), len(xs) - 1)
                w = (xr - xs[i - 1]) / max(xs[i] - xs[i - 1], 1e-12)
                edge = float(zs[i - 1] + w * (zs[i] - zs[i - 1]) - cfg.rise_m)
            out.append(FootSwing(leg, t_lo, h, xs, zs, edge, min_clear))
            x_foot = x_td
            t_lo += period
    out.sort(key=lambda f: f.t_lo_s)
    return out


@dataclass(frozen=True)
class ApproachResult:
    """Outcome of :func:`simulate_approach`.

    Attributes
    ----------
    config : ApproachConfig
    swing : SwingConfig
    commands : list of SwingCommand
        One per terrain message (in publish order).
    messages : list of terrain_t
    sensed, blind : list of FootSwing
        The feet with the commanded swings and with the nominal swing only.
    trigger_x_m : float or None
        Body x (world) where the controller raised the swing.
    first_distances_m : (F,) float
        First riser distance reported by each frame (NaN when none).
    """

    config: ApproachConfig
    swing: SwingConfig
    commands: list[SwingCommand] = field(repr=False)
    messages: list[terrain_t] = field(repr=False)
    sensed: list[FootSwing] = field(repr=False)
    blind: list[FootSwing] = field(repr=False)
    trigger_x_m: float | None
    first_distances_m: np.ndarray = field(repr=False)

    @property
    def trigger_error_m(self) -> float | None:
        """(true riser - trigger position) - d_buffer: 0 means eq. 2 fired exactly on time."""
        if self.trigger_x_m is None:
            return None
        return (self.config.riser_x_m - self.trigger_x_m) - self.swing.buffer_m

    @staticmethod
    def edge_clearances(feet: list[FootSwing]) -> dict[str, float]:
        """Per leg, the clearance of its first crossing of the first riser's edge."""
        out: dict[str, float] = {}
        for f in feet:
            if f.edge_clearance_m is not None and f.leg not in out:
                out[f.leg] = f.edge_clearance_m
        return out

    def summary(self) -> dict[str, Any]:
        err = self.trigger_error_m
        return {
            "frames": len(self.first_distances_m),
            "messages": len(self.messages),
            "true_first_riser_m": self.config.riser_x_m,
            "d_buffer_m": self.swing.buffer_m,
            "trigger_at_m": self.trigger_x_m,
            "trigger_error_m": err,
            "swing_height_m": max((f.height_m for f in self.sensed), default=None),
            "edge_clearance_sensed_m": self.edge_clearances(self.sensed),
            "edge_clearance_blind_m": self.edge_clearances(self.blind),
            "not_traversable_reported": any(not m.traversable for m in self.messages),
            "feet_clear_sensed": all(v > 0 for v in self.edge_clearances(self.sensed).values()),
            "feet_hit_blind": sorted(k for k, v in self.edge_clearances(self.blind).items() if v <= 0),
        }


def evaluate_approach(
    cfg: ApproachConfig,
    swing: SwingConfig,
    messages: Sequence[terrain_t],
    x_of_frame: dict[int, float],
) -> ApproachResult:
    """Controller side of the approach: commands from the messages, trigger, both foot walks.

    ``x_of_frame`` maps a message's ``frame_index`` to the body x (world) of that frame.
    """
    msgs = [m for m in messages if m.frame_index in x_of_frame]
    commands = [SwingCommand.from_message(m, x_of_frame[m.frame_index]) for m in msgs]
    nominal = swing.nominal_height_m
    feet_end = cfg.riser_x_m - cfg.rear_hip_m + 0.5
    trig = trigger_position(commands, feet_end, nominal)
    sensed = simulate_feet(cfg, lambda x: commanded_swing(commands, x, nominal)[1])
    blind = simulate_feet(cfg, lambda x: nominal)
    firsts = np.array([m.distance_m[0] if m.num_steps else math.nan for m in msgs], dtype=np.float64)
    return ApproachResult(cfg, swing, commands, list(messages), sensed, blind, trig, firsts)


def simulate_approach(
    cfg: ApproachConfig,
    *,
    swing: SwingConfig | None = None,
    publish: Any = None,
    record_to: str | Path | None = None,
    progress: Any = None,
) -> ApproachResult:
    """Render the approach, run the live loop on it, and walk the feet.

    Parameters
    ----------
    cfg : ApproachConfig
    swing : SwingConfig, optional
    publish : callable(terrain_t), optional
        Also publish every message here (e.g. an LCM publisher).
    record_to : path, optional
        Write the rendered frames as a recorded-pairs folder (with poses, calib.yaml,
        rig.yaml, truth.json) that ``stereo-terrain replay`` takes.
    progress : callable(int, int), optional
        Called with (frames done, frame count).
    """
    from ..calibration import write_opencv_yaml
    from ..frames import save_rig
    from ..pipeline import Pipeline, PipelineConfig
    from .capture import Capture, Paced, PairWriter
    from .loop import LiveLoop, LoopConfig

    swing = swing or SwingConfig()
    first = render_scene(approach_spec(cfg, 0.0, 0.0))
    rig = dataclasses.replace(first.rig, body_rpy=(0.0, 0.0, 0.0))
    pipeline = Pipeline(first.calibration, rig, PipelineConfig(swing=swing))
    writer = None
    if record_to is not None:
        writer = PairWriter(record_to)
        write_opencv_yaml(first.calibration, Path(record_to) / "calib.yaml")
        save_rig(rig, Path(record_to) / "rig.yaml")
        (Path(record_to) / "approach.json").write_text(_approach_json(cfg, swing))
    x_of_frame: dict[int, float] = {}
    n = cfg.frame_count

    def frames() -> Iterator[StereoFrame]:
        for frame, _scene in render_approach(cfg):
            x_of_frame[frame.index] = true_x(cfg, frame.t_capture_s)
            if writer is not None:
                writer.write(frame)
            if progress is not None:
                progress(frame.index + 1, n)
            yield frame

    messages: list[terrain_t] = []

    def collect(msg: terrain_t) -> None:
        messages.append(msg)
        if publish is not None:
            publish(msg)

    loop = LiveLoop(
        Capture(Paced(FrameSource(frames()), realtime=False)),  # type: ignore[arg-type]
        pipeline,
        collect,
        config=LoopConfig(max_skew_s=1.0, stall_timeout_s=1e9),
    )
    try:
        loop.run()
    finally:
        if writer is not None:
            writer.close()
    return evaluate_approach(cfg, swing, messages, x_of_frame)


def _approach_json(cfg: ApproachConfig, swing: SwingConfig) -> str:
    import json

    data = {"approach": dataclasses.asdict(cfg), "swing": dataclasses.asdict(swing)}
    return json.dumps(data, indent=2) + "\n"


def load_approach(folder: str | Path) -> tuple[ApproachConfig, SwingConfig]:
    """The :class:`ApproachConfig` and :class:`SwingConfig` saved with a simulated recording."""
    from ..checks import load_json_file
    from ..errors import InputError

    path = Path(folder) / "approach.json"
    if not path.is_file():
        raise InputError(f"{path} not found: not a recording written by 'stereo-terrain simulate'")
    data = load_json_file(path, "approach file")
    try:
        a = dict(data["approach"])
        a["image_size"] = tuple(a["image_size"])
        return ApproachConfig(**a), SwingConfig(**data["swing"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{path} is not a valid approach description: {exc}") from None
