"""The simulated approach run end to end: frames through the live loop, the messages
to the controller, both foot walks; and the approach's description saved with a
recording."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...swing import SwingConfig
from ...synthetic import render_scene
from ..capture import END, FRAME, CaptureEvent, StereoFrame
from ..messages import terrain_t
from .approach import ApproachConfig, approach_spec, render_approach, true_x
from .controller import SwingCommand, commanded_swing, trigger_position
from .feet import FootSwing, simulate_feet


class _FrameClock:
    """Simulated time for the live loop: the capture time of the newest frame read, as if
    each frame were processed in no time. The tracker's time-based rules
    (``TrackingConfig.drop_after_s``) then see the walk at the approach's frame rate
    whatever the machine's speed, and an approach gives the same messages on any machine
    (on the machine's own clock a loaded machine stretched the time between frames, and a
    track was dropped after fewer frames)."""

    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


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

    The loop runs on the approach's own time: each frame's capture time, as if the
    machine kept up with ``cfg.fps`` (:class:`_FrameClock`), so that the results do not
    depend on the machine's speed or load.

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
    from ...calibration import write_opencv_yaml
    from ...frames import save_rig
    from ...pipeline import Pipeline, PipelineConfig
    from ..capture import Capture, PairWriter
    from ..loop import LiveLoop, LoopConfig

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
    clock = _FrameClock()

    def frames() -> Iterator[StereoFrame]:
        for frame, _scene in render_approach(cfg):
            x_of_frame[frame.index] = true_x(cfg, frame.t_capture_s)
            if writer is not None:
                writer.write(frame)
            if progress is not None:
                progress(frame.index + 1, n)
            clock.now_s = max(frame.t_left_s, frame.t_right_s)
            yield frame

    messages: list[terrain_t] = []

    def collect(msg: terrain_t) -> None:
        messages.append(msg)
        if publish is not None:
            publish(msg)

    loop = LiveLoop(
        Capture(FrameSource(frames())),  # type: ignore[arg-type]
        pipeline,
        collect,
        config=LoopConfig(max_skew_s=1.0, stall_timeout_s=1e9),
        clock=clock,
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
    from ...checks import load_json_file
    from ...errors import InputError

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
