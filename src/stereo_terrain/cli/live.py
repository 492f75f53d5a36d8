"""The live side (``runtime/``): ``record``, ``run``, ``replay`` and ``simulate``."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Any

from ..errors import EXIT_OK, InputError
from .options import nonneg_float, positive_float, positive_int, seed_arg, size_arg
from .outputs import (
    check_output_dir,
    check_output_file,
    check_output_files,
    is_terminal,
    make_dir,
    progress,
    replace_from_temp,
    require_lcm,
    require_viz,
    write_json,
)
from .sinks import add_bag_options, add_output_options, check_bag_options, check_outputs, is_bag


def add_parsers(sub: Any) -> None:
    """The parsers of record, run, replay and simulate."""

    def loop_options(q: argparse.ArgumentParser) -> None:
        q.add_argument("--config", type=Path, help="pipeline config YAML")
        q.add_argument(
            "--lcm-url", default=None, help="LCM provider URL (default udpm://239.255.76.67:7667?ttl=0)"
        )
        q.add_argument("--channel", default="STEREO_TERRAIN", help="LCM channel of the terrain messages")
        q.add_argument("--no-lcm", action="store_true", help="do not publish (no LCM needed)")
        q.add_argument("--max-skew-ms", type=nonneg_float, default=15.0, help="drop pairs skewed more (ms)")
        q.add_argument(
            "--stall-timeout", type=nonneg_float, default=0.5, help="seconds without a pair = stall"
        )
        q.add_argument(
            "--denoised-every",
            type=positive_int,
            metavar="N",
            help="while the second opinions keep nothing, the denoised ones run on every Nth pair"
            " that runs them (default 2; 1: each such pair)",
        )
        q.add_argument("--frames", type=positive_int, help="stop after this many processed pairs")
        q.add_argument("--duration", type=nonneg_float, help="stop after this many seconds")
        q.add_argument("--quiet", action="store_true", help="no live status line")
        q.add_argument("--summary-json", type=Path, help="write the exit summary as JSON here")
        add_output_options(q)
        q.add_argument(
            "--jsonl", type=Path, help="also write every published message here, one JSON object per line"
        )

    rec = sub.add_parser("record", help="save synchronized stereo pairs with timestamps for replay")
    rec.add_argument("--left", required=True, help="camera index, /dev/videoN or a video file")
    rec.add_argument("--right", required=True, help="camera index, /dev/videoN or a video file")
    rec.add_argument("--out", type=Path, required=True, help="new folder for pairs.csv and the images")
    rec.add_argument("--frames", type=positive_int, help="stop after this many pairs")
    rec.add_argument("--duration", type=nonneg_float, help="stop after this many seconds")
    rec.add_argument("--max-skew-ms", type=nonneg_float, default=15.0, help="drop pairs skewed more (ms)")

    run = sub.add_parser("run", help="live loop on two cameras: terrain messages over LCM")
    run.add_argument("--left", required=True, help="camera index, /dev/videoN or a video file")
    run.add_argument("--right", required=True, help="camera index, /dev/videoN or a video file")
    run.add_argument("--calib", type=Path, required=True)
    run.add_argument("--rig", type=Path, help="rig YAML; body attitude from here unless --state-channel")
    run.add_argument("--state-channel", help="LCM channel of body_state_t (body pose and odometry)")
    run.add_argument(
        "--as-fast",
        action="store_true",
        help="video files: every pair, as fast as it goes (default: played in real time, the"
        " newest pair each time)",
    )
    loop_options(run)

    rp = sub.add_parser("replay", help="live loop on a recorded folder of pairs")
    rp.add_argument(
        "folder",
        type=Path,
        help="folder with pairs.csv (record, simulate --record), or a ROS 2 bag / MCAP file",
    )
    rp.add_argument("--calib", type=Path, help="default: FOLDER/calib.yaml, or a bag's CameraInfo topics")
    rp.add_argument("--rig", type=Path, help="default: FOLDER/rig.yaml if present")
    rp.add_argument("--as-fast", action="store_true", help="every pair, as fast as it goes (no pacing)")
    rp.add_argument("--speed", type=positive_float, default=1.0, help="playback speed (real time = 1)")
    rp.add_argument("--loop", action="store_true", help="repeat the recording until stopped")
    add_bag_options(rp)
    loop_options(rp)

    si = sub.add_parser(
        "simulate", help="a trotting robot approaches a staircase: trigger and foot clearance"
    )
    si.add_argument("--out", type=Path, required=True, help="folder for the plot and summary.json")
    si.add_argument("--rise", type=nonneg_float, default=0.21, help="step rise, m (default 0.21)")
    si.add_argument("--run", dest="run_m", type=nonneg_float, default=0.28, help="step run, m")
    si.add_argument("--start", type=nonneg_float, default=2.2, help="first riser distance at the start, m")
    si.add_argument("--speed", type=nonneg_float, default=0.5, help="walking speed, m/s")
    si.add_argument("--fps", type=nonneg_float, default=30.0, help="camera frame rate")
    si.add_argument("--size", type=size_arg, default=(640, 480), help="WIDTHxHEIGHT (default 640x480)")
    si.add_argument(
        "--profile", choices=("default", "realistic"), default="default",
        help="the scene's look: the textured default, or the realistic profile's walls, materials, "
        "lens and sensor drawn from --seed (issue 11)",
    )  # fmt: skip
    si.add_argument("--seed", type=seed_arg, default=7, help="seeds the textures and noise (default 7)")
    si.add_argument("--record", type=Path, help="also write the rendered frames here for 'replay'")
    si.add_argument("--lcm-url", default=None, help="also publish the messages on this LCM URL")
    si.add_argument("--channel", default="STEREO_TERRAIN")
    si.add_argument("--no-plot", action="store_true")


def cmd_record(args: argparse.Namespace) -> int:
    from ..runtime.capture import PAIRS_FILE, Capture, open_devices, record_pairs

    source = open_devices(args.left, args.right)
    try:
        check_output_dir(args.out, "--out")
        if (args.out / PAIRS_FILE).exists():
            raise InputError(f"--out {args.out} already holds a recording ({PAIRS_FILE}); use a new folder")
    except InputError:
        source.close()
        raise
    capture = Capture(source, args.max_skew_ms / 1000.0)
    try:
        n = record_pairs(capture, args.out, max_pairs=args.frames or 0, max_duration_s=args.duration or 0.0)
    finally:
        capture.close()
    st = capture.stats
    if n == 0:
        why = (
            f"every pair was dropped ({st.unreadable} unreadable, {st.skew_dropped} for skew; the first: "
            f"{st.first_problem}); check the sources (same size, --max-skew-ms)"
            if st.first_problem
            else "no pair arrived before the recording stopped (empty or unreadable videos, cameras that "
            "deliver nothing, or a stop before the first frame)"
        )
        raise InputError(f"recorded no pairs in {args.out}: {why}")
    print(
        f"recorded {n} pairs in {args.out}; dropped for skew {st.skew_dropped}, unreadable {st.unreadable}, "
        f"superseded {st.skipped}"
    )
    return EXIT_OK


def _pipeline(calib_path: Any, rig_path: Path | None, config_path: Path | None):
    from ..calibration import read_calibration
    from ..frames import load_rig
    from ..pipeline import Pipeline, PipelineConfig

    calib = read_calibration(calib_path) if isinstance(calib_path, Path) else calib_path
    rig = load_rig(rig_path) if rig_path else None
    config = PipelineConfig.from_yaml(config_path) if config_path else PipelineConfig()
    return Pipeline(calib, rig, config)


def _run_loop(args: argparse.Namespace, source, pipeline, pose=None) -> int:
    from ..runtime.capture import Capture
    from ..runtime.loop import LiveLoop, LoopConfig
    from .sinks import fan_out, open_sinks, results_to, stop_on_sigterm

    publish: Any = lambda msg: None  # noqa: E731
    check_output_file(args.summary_json, "--summary-json")
    _check_jsonl(args)
    if not args.no_lcm:
        from ..runtime.lcm_io import DEFAULT_URL, LcmPublisher

        publish = LcmPublisher(args.lcm_url or DEFAULT_URL, args.channel)
    jsonl = None
    if args.jsonl is not None:  # created before the loop starts, flushed per line
        from ..runtime.messages import JsonlWriter

        jsonl = JsonlWriter(args.jsonl)
        lcm_publish = publish

        def publish(msg) -> None:
            lcm_publish(msg)
            jsonl(msg)

    config = LoopConfig(
        max_skew_s=args.max_skew_ms / 1000.0,
        stall_timeout_s=args.stall_timeout,
        max_frames=args.frames or 0,
        max_duration_s=args.duration or 0.0,
    )
    if args.denoised_every is not None:
        config = dataclasses.replace(config, denoised_every=args.denoised_every)
    try:
        with stop_on_sigterm(), open_sinks(args, pipeline, pose=pose) as sinks:
            loop = LiveLoop(
                Capture(source),
                pipeline,
                fan_out(publish, sinks),
                pose=pose,
                config=config,
                status=None if args.quiet or not is_terminal(sys.stderr) else sys.stderr,
                on_result=results_to(sinks),
            )
            for sink in sinks:
                sink.epoch_offset_s = loop.epoch_offset_s
            loop.warm_up()
            summary = loop.run()
    finally:
        if jsonl is not None:
            jsonl.close()
    print(summary.format())
    if args.summary_json is not None:
        data = {k: v for k, v in dataclasses.asdict(summary).items() if k not in ("latencies_s", "periods_s")}
        data.update(
            fps=summary.fps, latency_median_ms=summary.latency_ms(50), latency_p99_ms=summary.latency_ms(99)
        )
        write_json(data, args.summary_json)
    return EXIT_OK


def _check_jsonl(args: argparse.Namespace) -> None:
    """``--jsonl``: a file that can be written (checked before any work)."""
    if args.jsonl is not None and str(args.jsonl) == "-":
        raise InputError("--jsonl needs a file name (the summary goes to stdout)")
    check_output_file(args.jsonl, "--jsonl")


def cmd_run(args: argparse.Namespace) -> int:
    from ..runtime.capture import open_devices
    from ..runtime.loop import rig_pose

    check_output_file(args.summary_json, "--summary-json")
    check_outputs(args)
    _check_jsonl(args)
    if not args.no_lcm or args.state_channel:
        require_lcm("publishing terrain messages" if not args.no_lcm else "--state-channel", "--no-lcm")
    pipeline = _pipeline(args.calib, args.rig, args.config)
    pose = rig_pose(pipeline.rig)
    listener = None
    if args.state_channel:
        from ..runtime.lcm_io import DEFAULT_URL, LcmStateListener

        listener = LcmStateListener(args.lcm_url or DEFAULT_URL, args.state_channel)

        def pose(frame):  # the latest body state; the rig's attitude until one arrives
            got = listener.latest()
            return (None, pipeline.rig.body_rpy if pipeline.rig else None) if got is None else got[:2]

    try:
        source = open_devices(args.left, args.right, realtime=not args.as_fast)
        return _run_loop(args, source, pipeline, pose)
    finally:
        if listener is not None:
            listener.close()


def cmd_replay(args: argparse.Namespace) -> int:
    from ..runtime.capture import FolderPairs, Paced

    folder: Path = args.folder
    if not folder.exists():
        raise InputError(f"recorded pairs folder not found: {folder}")
    bag = is_bag(folder)
    if not folder.is_dir() and not bag:
        raise InputError(
            f"{folder} is not a folder of recorded pairs (pairs.csv and the images), a rosbag2 folder "
            "or an MCAP file"
        )
    # The index first: a folder without one is no recording, whatever else (calib.yaml,
    # rig.yaml) it lacks.
    recorded = None if bag else FolderPairs(folder, loop=args.loop)
    check_output_file(args.summary_json, "--summary-json")
    check_outputs(args)
    check_bag_options(args, bag)
    _check_jsonl(args)
    if not args.no_lcm:
        require_lcm("publishing terrain messages", "--no-lcm")
    if bag:
        from ..ros.bag import BagPairs
        from .sinks import bag_calibration

        pairs = BagPairs(
            folder, args.left_topic, args.right_topic, odom_topic=args.odom_topic, loop=args.loop
        )
        try:
            pipeline = _pipeline(bag_calibration(args), args.rig, args.config)
        except BaseException:
            pairs.close()
            raise
        return _run_loop(args, Paced(pairs, realtime=not args.as_fast, speed=args.speed), pipeline)
    calib = args.calib or folder / "calib.yaml"
    if args.calib is None and not calib.is_file():
        raise InputError(
            f"no --calib given and {calib} does not exist; pass --calib with the cameras' calibration"
        )
    rig = args.rig or (folder / "rig.yaml" if (folder / "rig.yaml").is_file() else None)
    pipeline = _pipeline(calib, rig, args.config)
    assert recorded is not None
    return _run_loop(args, Paced(recorded, realtime=not args.as_fast, speed=args.speed), pipeline)


# The simulate options behind the configuration fields that check them, so that an error
# names the option the user typed.
_SIMULATE_OPTIONS = {
    "ApproachConfig.rise_m": "--rise",
    "StairSpec.rise_m": "--rise",
    "ApproachConfig.run_m": "--run",
    "StairSpec.run_m": "--run",
    "ApproachConfig.start_distance_m": "--start",
    "ApproachConfig.speed_mps": "--speed",
    "ApproachConfig.fps": "--fps",
}


def _in_option_names(exc: InputError) -> InputError:
    message = str(exc)
    for field_name, option in _SIMULATE_OPTIONS.items():
        message = message.replace(field_name, option)
    return type(exc)(message)


def cmd_simulate(args: argparse.Namespace) -> int:
    from ..runtime.simulate import ApproachConfig, approach_spec, simulate_approach

    try:
        cfg = ApproachConfig(
            rise_m=args.rise, run_m=args.run_m, start_distance_m=args.start, speed_mps=args.speed,
            fps=args.fps, image_size=args.size, profile=args.profile, seed=args.seed,
        )  # fmt: skip
        approach_spec(cfg, 0.0, 0.0)  # the stairs' own checks, before any work
    except InputError as exc:
        raise _in_option_names(exc) from None
    from ..runtime.capture import PAIRS_FILE

    check_output_dir(args.out, "--out")
    if args.record is not None:
        check_output_dir(args.record, "--record")
        if (args.record / PAIRS_FILE).exists():
            raise InputError(f"--record {args.record} already holds a recording ({PAIRS_FILE})")
    if not args.no_plot:
        require_viz("the approach figure", "--no-plot")
    publish = None
    if args.lcm_url:
        require_lcm("--lcm-url")
        from ..runtime.lcm_io import LcmPublisher

        publish = LcmPublisher(args.lcm_url, args.channel)
    make_dir(args.out, "--out")
    check_output_files(args.out, ("summary.json",) + (() if args.no_plot else ("approach.png",)), "--out")

    def frame_done(k: int, n: int) -> None:
        progress(k, n, "rendering and processing frames")

    result = simulate_approach(cfg, publish=publish, record_to=args.record, progress=frame_done)
    summary = result.summary()
    write_json(summary, args.out / "summary.json")
    err = summary["trigger_error_m"]
    raised = (
        "swing never raised"
        if err is None
        else f"swing raised at {summary['trigger_at_m']:.3f} m ({100 * err:+.1f} cm from d - d_buffer), "
        f"height {summary['swing_height_m']:.3f} m"
    )
    print(
        f"{summary['frames']} frames, riser at {cfg.riser_x_m:.3f} m, "
        f"d_buffer {result.swing.buffer_m:.2f} m: {raised}"
    )
    if summary["not_traversable_reported"]:
        print("stairs reported NOT traversable (a step above the leg's reach): the swing stays nominal")
    for name, key in (("perceived", "edge_clearance_sensed_m"), ("blind", "edge_clearance_blind_m")):
        legs = ", ".join(f"{k} {100 * v:+.1f} cm" for k, v in sorted(summary[key].items()))
        print(f"first riser edge clearance, {name} swing: {legs}")
    if not args.no_plot:
        try:
            from ..viz.approach import save_approach_figure
        except ImportError as exc:
            raise InputError(
                f"the plot needs matplotlib ({exc}); pip install 'stereo-terrain[viz]'"
            ) from None
        replace_from_temp(args.out / "approach.png", lambda tmp: save_approach_figure(result, tmp))
        print(f"wrote {args.out / 'approach.png'}")
    print(f"wrote {args.out / 'summary.json'}" + (f" and the frames in {args.record}" if args.record else ""))
    return EXIT_OK


COMMANDS = {"record": cmd_record, "run": cmd_run, "replay": cmd_replay, "simulate": cmd_simulate}
