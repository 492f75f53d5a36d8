"""Test helpers: a tiny rendered recording and ROS 2 bags of it written by other tools
(``rosbags``' rosbag2 writer, ``mcap-ros2-support``'s MCAP writer), and readers of MCAP
files (``mcap`` + ``mcap-ros2-support``)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from stereo_terrain.calibration import write_opencv_yaml
from stereo_terrain.frames import save_rig
from stereo_terrain.runtime.capture import StereoFrame, write_pairs
from stereo_terrain.swing import Odometry
from stereo_terrain.synthetic import SceneSpec, StairSpec, render_scene

#: Epoch seconds of the first pair of the test bags.
T0_S = 1_700_000_000.0
PERIOD_S = 0.1
SIZE = (320, 240)


def render_recording(folder: Path, n: int = 3) -> Any:
    """A PNG recording of ``n`` pairs of one rendered staircase (320x240), with poses,
    ``calib.yaml`` and ``rig.yaml``; returns the scene."""
    stairs = StairSpec(n_steps=3, rise_m=0.17, run_m=0.3, width_m=1.2, distance_m=1.2)
    scene = render_scene(SceneSpec(obstacle=stairs, image_size=SIZE))
    frames = [
        StereoFrame(
            scene.left,
            scene.right,
            k * PERIOD_S,
            k * PERIOD_S + 0.002,
            k,
            Odometry((0.05 * k, 0.0, 0.0), 0.0),
            (0.0, 0.0, 0.0),
        )
        for k in range(n)
    ]
    write_pairs(folder, frames)
    write_opencv_yaml(scene.calibration, folder / "calib.yaml")
    save_rig(scene.rig, folder / "rig.yaml")
    return scene


def _image(ts: Any, img: np.ndarray, t_ns: int, frame_id: str, compressed: bool) -> tuple[str, Any]:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    header = ts.types["std_msgs/msg/Header"](
        stamp=ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame_id
    )
    if compressed:
        ok, buf = cv2.imencode(".png", img)
        assert ok
        msg = ts.types["sensor_msgs/msg/CompressedImage"](header=header, format="png", data=buf.reshape(-1))
        return "sensor_msgs/msg/CompressedImage", msg
    h, w = img.shape[:2]
    enc, step = ("mono8", w) if img.ndim == 2 else ("bgr8", 3 * w)
    msg = ts.types["sensor_msgs/msg/Image"](
        header=header, height=h, width=w, encoding=enc, is_bigendian=0, step=step, data=img.reshape(-1)
    )
    return "sensor_msgs/msg/Image", msg


def camera_info(ts: Any, fields: dict[str, Any], t_ns: int, frame_id: str) -> Any:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    T = ts.types
    header = T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame_id
    )
    roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return T["sensor_msgs/msg/CameraInfo"](
        header=header,
        height=fields["height"],
        width=fields["width"],
        distortion_model=fields["distortion_model"],
        d=np.asarray(fields["d"], dtype=np.float64),
        k=np.asarray(fields["k"], dtype=np.float64),
        r=np.asarray(fields["r"], dtype=np.float64),
        p=np.asarray(fields["p"], dtype=np.float64),
        binning_x=0,
        binning_y=0,
        roi=roi,
    )


def odometry(ts: Any, t_ns: int, x: float) -> Any:
    T = ts.types
    sec, nsec = divmod(t_ns, 1_000_000_000)
    header = T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id="odom"
    )
    pose = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    zero3 = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    return T["nav_msgs/msg/Odometry"](
        header=header,
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=zero3, angular=zero3), covariance=np.zeros(36)
        ),
    )


def bag_messages(
    scene: Any, n: int, *, compressed: bool = False, infos: tuple | None = None, odom: bool = False
):
    """(topic, msgtype, t_ns, message) of a stereo bag of ``scene`` (rosbags type store)."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    out = []
    for k in range(n):
        t = int(round((T0_S + k * PERIOD_S) * 1e9))
        for side, img, dt in (("left", scene.left, 0), ("right", scene.right, 2_000_000)):
            typ, msg = _image(ts, img, t + dt, f"{side}_camera", compressed)
            topic = f"/stereo/{side}/image_raw" + ("/compressed" if compressed else "")
            out.append((topic, typ, t + dt, msg))
            if infos is not None:
                fields = infos[0] if side == "left" else infos[1]
                out.append(
                    (
                        f"/stereo/{side}/camera_info",
                        "sensor_msgs/msg/CameraInfo",
                        t + dt,
                        camera_info(ts, fields, t + dt, f"{side}_camera"),
                    )
                )
        if odom:
            out.append(("/odom", "nav_msgs/msg/Odometry", t, odometry(ts, t, 0.05 * k)))
    out.sort(key=lambda m: m[2])
    return ts, out


def write_rosbag2(path: Path, ts: Any, messages: list, *, sqlite: bool = False) -> None:
    """A rosbag2 folder (MCAP storage, or SQLite as ``ros2 bag record`` on Humble) written by
    ``rosbags``."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    conns: dict[str, Any] = {}
    plugin = StoragePlugin.SQLITE3 if sqlite else StoragePlugin.MCAP
    with Writer(path, version=8, storage_plugin=plugin) as writer:
        for topic, typ, t, msg in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typ, typestore=ts)
            writer.write(conns[topic], t, ts.serialize_cdr(msg, typ))


def write_mcap_ros2(path: Path, ts: Any, messages: list) -> None:
    """A bare MCAP file written by ``mcap-ros2-support``'s writer."""
    from mcap_ros2.writer import Writer

    schemas: dict[str, Any] = {}
    with path.open("wb") as fh:
        writer = Writer(fh)
        for topic, typ, t, msg in messages:
            if typ not in schemas:
                schemas[typ] = writer.register_msgdef(typ, ts.generate_msgdef(typ, ros_version=2)[0])
            writer.write_message(topic, schemas[typ], _as_dict(msg), log_time=t, publish_time=t)
        writer.finish()


def _as_dict(msg: Any) -> Any:
    """A rosbags message as the nested dicts mcap-ros2-support encodes."""
    if hasattr(msg, "__dataclass_fields__"):
        return {k: _as_dict(getattr(msg, k)) for k in msg.__dataclass_fields__ if k != "__msgtype__"}
    if isinstance(msg, np.ndarray):
        return msg.tobytes() if msg.dtype == np.uint8 else msg.tolist()
    if isinstance(msg, list):
        return [_as_dict(v) for v in msg]
    return msg


def read_mcap(path: Path) -> dict[str, list[tuple[Any, Any]]]:
    """Every message of an MCAP file decoded by mcap + mcap-ros2-support: topic ->
    [(schema name, decoded message)]."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out: dict[str, list[tuple[Any, Any]]] = defaultdict(list)
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, _message, decoded in reader.iter_decoded_messages():
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            out[channel.topic].append((schema.name, decoded))
    return out
