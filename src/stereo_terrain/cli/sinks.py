"""The ROS 2 / Rerun outputs shared by ``run``, ``replay`` and ``reconstruct``: ``--mcap``,
``--view`` and ``--view-save``; and the bag inputs of ``replay``.

Options are checked (and the extras they need named) before any work; the outputs are
closed whole at the end (also after Ctrl-C) and dropped when the command fails.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ..errors import InputError
from .outputs import check_output_file, require


def add_output_options(q: argparse.ArgumentParser) -> None:
    q.add_argument("--mcap", type=Path, help="also write ROS 2 messages (cloud, markers, tf, images) here")
    q.add_argument("--view", action="store_true", help="show everything live in a Rerun viewer")
    q.add_argument("--view-save", type=Path, help="save a Rerun recording (.rrd) here instead of a viewer")


def add_bag_options(q: argparse.ArgumentParser) -> None:
    q.add_argument("--left-topic", help="with a bag: left image topic (sensor_msgs Image or CompressedImage)")
    q.add_argument("--right-topic", help="with a bag: right image topic")
    q.add_argument("--odom-topic", help="with a bag: nav_msgs/msg/Odometry topic of the body pose")
    q.add_argument("--left-info-topic", help="with a bag: left CameraInfo (default: beside the image topic)")
    q.add_argument(
        "--right-info-topic", help="with a bag: right CameraInfo (default: beside the image topic)"
    )


def check_outputs(args: argparse.Namespace) -> None:
    """Refuse bad output options and missing extras before any work."""
    check_output_file(args.mcap, "--mcap")
    check_output_file(args.view_save, "--view-save")
    if args.mcap is not None:
        if str(args.mcap) == "-":
            raise InputError("--mcap needs a file name (an MCAP file cannot go to stdout)")
        require_ros("--mcap")
        require("zstandard", "ros", "--mcap (its zstd compression)")  # mcap imports it only to write
    if args.view and args.view_save is not None:
        raise InputError("give --view (a viewer) or --view-save (a recording), not both")
    if args.view or args.view_save is not None:
        require("rerun", "view", "--view" if args.view else "--view-save")
    if args.view:
        check_viewer_possible()


#: Where a Rerun viewer listens (rerun-sdk's default); one already running there is used.
RERUN_PORT = 9876


def check_viewer_possible() -> None:
    """``--view`` starts a Rerun viewer window unless one is already listening: refuse it
    before any work on a Linux machine with no display to open a window on."""
    import os
    import socket
    import sys

    if not sys.platform.startswith("linux"):
        return
    if any(os.environ.get(k) for k in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET")):
        return
    try:
        with socket.create_connection(("127.0.0.1", RERUN_PORT), timeout=0.2):
            return  # a viewer (or its server) is already running: it will be used
    except OSError:
        pass
    raise InputError(
        "--view needs a display for the Rerun viewer (DISPLAY and WAYLAND_DISPLAY are not set); "
        "use --view-save OUT.rrd and open it elsewhere with 'rerun OUT.rrd'"
    )


def require_ros(what: str) -> None:
    for module in ("mcap", "rosbags"):
        require(module, "ros", what)


def is_bag(path: Path) -> bool:
    """An MCAP file or a rosbag2 folder (``metadata.yaml``), not a folder of PNG pairs."""
    return (path.is_file() and path.suffix == ".mcap") or (
        path.is_dir() and (path / "metadata.yaml").is_file()
    )


def check_bag_options(args: argparse.Namespace, bag: bool) -> None:
    names = ("left_topic", "right_topic", "odom_topic", "left_info_topic", "right_info_topic")
    given = [n for n in names if getattr(args, n)]
    if not bag:
        if given:
            raise InputError(f"--{given[0].replace('_', '-')} is for a ROS bag; {args.folder} is not one")
        return
    require_ros(f"replaying the ROS bag {args.folder}")
    if not args.left_topic or not args.right_topic:
        raise InputError(f"{args.folder} is a ROS bag: give --left-topic and --right-topic")


def bag_calibration(args: argparse.Namespace) -> Any:
    """The calibration of a bag replay: ``--calib``, else the bag's CameraInfo topics."""
    if args.calib is not None:
        return args.calib
    from ..ros.bag import info_topic, read_camera_info_calibration

    return read_camera_info_calibration(
        args.folder,
        args.left_info_topic or info_topic(args.left_topic),
        args.right_info_topic or info_topic(args.right_topic),
    )


@contextlib.contextmanager
def stop_on_sigterm() -> Iterator[None]:
    """Inside the block SIGTERM (``kill``, ``systemctl stop``) stops the live loop as Ctrl-C
    does, so its outputs are closed whole (main thread only)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    from ..runtime.loop import request_stop

    def interrupt(signum: int, frame: Any) -> None:
        request_stop()  # also seen when the interrupt below surfaces as another error
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def open_sinks(
    args: argparse.Namespace,
    pipeline: Any,
    epoch_offset_s: float = 0.0,
    pose: Any = None,
    *,
    keep_on_interrupt: bool = True,
) -> Iterator[list[Any]]:
    """The MCAP writer and the Rerun view the options ask for (each with ``publish``,
    ``on_result``, ``close`` and ``abort``): closed whole at the end or after Ctrl-C (a
    stopped loop keeps what it wrote; ``keep_on_interrupt=False``: dropped then too),
    dropped when the command fails."""
    sinks: list[Any] = []

    def body_rpy() -> Any:
        return None if pipeline.rig is None else pipeline.rig.body_rpy

    try:
        if args.mcap is not None:
            from ..ros.mcap_out import McapSink

            sinks.append(
                McapSink(
                    args.mcap,
                    body_rpy=body_rpy,
                    pose=pose,
                    epoch_offset_s=epoch_offset_s,
                )
            )
        if args.view or args.view_save is not None:
            from ..viz.rerun_view import RerunView

            sinks.append(RerunView(args.view_save, body_rpy=body_rpy, epoch_offset_s=epoch_offset_s))
        yield sinks
    except BaseException as exc:
        for sink in sinks:
            if isinstance(exc, KeyboardInterrupt) and keep_on_interrupt:
                sink.close()
            else:
                sink.abort()
        raise
    for sink in sinks:
        sink.close()


def fan_out(first: Callable[[Any], None] | None, sinks: list[Any]) -> Callable[[Any], None]:
    """A publisher that gives each terrain message to ``first`` and every sink."""

    def publish(msg: Any) -> None:
        if first is not None:
            first(msg)
        for sink in sinks:
            sink.publish(msg)

    return publish


def results_to(sinks: list[Any]) -> Callable[[Any, Any], None] | None:
    if not sinks:
        return None

    def on_result(frame: Any, result: Any) -> None:
        for sink in sinks:
            sink.on_result(frame, result)

    return on_result


def wants_sinks(args: argparse.Namespace) -> bool:
    return args.mcap is not None or args.view or args.view_save is not None


@contextlib.contextmanager
def single_sinks(
    args: argparse.Namespace, pipeline: Any, result: Any, left: Any, right: Any, stamp_s: float
) -> Iterator[None]:
    """``reconstruct --mcap/--view``: the messages of one pair, stamped ``stamp_s`` (epoch s),
    with the terrain message a first frame of the live loop would give.

    Written on entering; the files are closed whole (renamed onto their names) when the
    block ends without an error, and dropped when it fails or is interrupted: the command
    writes its other outputs inside, in :func:`~stereo_terrain.cli.outputs.all_or_none`,
    so that one failing output leaves none new."""
    if not wants_sinks(args):
        yield
        return
    from ..runtime.capture import StereoFrame
    from ..runtime.messages import terrain_message, terrain_t
    from ..swing import SwingTrigger

    trigger = SwingTrigger(pipeline.config.swing).update(
        None, result.terrain, camera_z_m=float(result.T_yaw_camera_rect.translation[2])
    )
    quality = terrain_t.QUALITY_POSE_MISSING | (
        terrain_t.QUALITY_GRAVITY_FROM_FLOOR if result.gravity_source != "rig" else 0
    )
    msg = terrain_message(
        result.terrain,
        trigger,
        capture_s=stamp_s,
        publish_s=stamp_s,
        frame_index=0,
        latency_s=result.timing_ms["total"] / 1000.0,
        density=result.disparity.density,
        quality=quality,
        stale=False,
    )
    frame = StereoFrame(left, right, stamp_s, stamp_s, 0, stamp_s=stamp_s)
    with open_sinks(args, pipeline, keep_on_interrupt=False) as sinks:
        for sink in sinks:
            sink.publish(msg)
            sink.on_result(frame, result)
        yield
