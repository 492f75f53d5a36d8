"""Write the terrain of every processed pair as ROS 2 messages into an MCAP file.

:class:`McapSink` is what ``run``/``replay``/``reconstruct --mcap`` use. The file is a
ROS 2 MCAP (``profile="ros2"``, ``ros2msg`` schemas, CDR messages, zstd chunks) as
rosbag2's MCAP storage writes it, so ``ros2 bag play OUT.mcap``, Foxglove and Rerun open
it. It is written to a temporary file beside the target and renamed onto it by
:meth:`McapSink.close`: an existing file is replaced only by a whole new one, a failed
command leaves nothing, and a loop stopped with Ctrl-C closes a complete file (a Ctrl-C
that comes while a pair's messages are being written is taken after them).

Per processed pair, all stamped with the pair's capture time (the bag's header stamps on
``replay BAG``, else the loop's clock moved to the epoch):

- ``/tf`` (``tf2_msgs/msg/TFMessage``): ``world -> yaw`` (with odometry), ``yaw -> body``,
  ``body -> camera``, ``camera -> camera_rect``;
- ``/stereo_terrain/cloud`` (``sensor_msgs/msg/PointCloud2``, frame ``yaw``);
- ``/stereo_terrain/stairs`` (``visualization_msgs/msg/MarkerArray``, ``yaw``);
- ``/stereo_terrain/terrain`` (``stereo_terrain_msgs/msg/Terrain``, ``yaw``);
- ``/stereo_terrain/left/image_rect`` (``sensor_msgs/msg/Image``, mono8, ``camera_rect``) and
  ``/stereo_terrain/left/camera_info`` (``sensor_msgs/msg/CameraInfo`` of that image);
- ``/stereo_terrain/disparity`` (``sensor_msgs/msg/Image``, 32FC1 pixels, NaN = none).

A stale heartbeat of the live loop (no fresh pair) adds a ``Terrain`` message only.
"""

from __future__ import annotations

import contextlib
import os
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..runtime.capture import StereoFrame
from ..runtime.messages import terrain_t
from . import (
    DEFAULT_DISTRO,
    TERRAIN_TYPE,
    TOPIC_CAMERA_INFO,
    TOPIC_CLOUD,
    TOPIC_DISPARITY,
    TOPIC_IMAGE,
    TOPIC_STAIRS,
    TOPIC_TERRAIN,
    TOPIC_TF,
)
from . import messages as m

#: The message type of each topic.
TOPIC_TYPES = {
    TOPIC_TF: "tf2_msgs/msg/TFMessage",
    TOPIC_CLOUD: "sensor_msgs/msg/PointCloud2",
    TOPIC_STAIRS: "visualization_msgs/msg/MarkerArray",
    TOPIC_TERRAIN: TERRAIN_TYPE,
    TOPIC_IMAGE: "sensor_msgs/msg/Image",
    TOPIC_CAMERA_INFO: "sensor_msgs/msg/CameraInfo",
    TOPIC_DISPARITY: "sensor_msgs/msg/Image",
}


@contextlib.contextmanager
def _ctrl_c_after() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT) that arrives inside the block until the block is done, so a
    file is never left with half a record (main thread only; elsewhere a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    try:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: got.append(signum))
    except (ValueError, OSError):  # no signals here (an embedded interpreter)
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if got:
        raise KeyboardInterrupt


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


class McapSink:
    """ROS 2 MCAP writer of the live loop's results (and of single ``reconstruct`` pairs).

    Parameters
    ----------
    path : path-like
        The MCAP file to write (replaced whole when :meth:`close` is called).
    distro : str
        Whose standard message definitions to write (:data:`~stereo_terrain.ros.DISTROS`).
    body_rpy : callable() -> (3,) or None, optional
        The body attitude the pipeline used for a pair (the rig's, updated by the loop);
        None without a rig. Gives the ``yaw -> body`` transform.
    pose : callable(StereoFrame) -> (Odometry or None, rpy or None), optional
        The body pose of a pair (the loop's pose provider); its odometry gives
        ``world -> yaw``. By default the pair's own odometry (a recording or bag with poses).
    epoch_offset_s : float
        Added to the loop's clock to give epoch seconds (``LiveLoop.epoch_offset_s``) for
        pairs whose source has no stamp of its own.

    Use :meth:`publish` as (part of) the loop's publisher and :meth:`on_result` as its
    per-result callback; then :meth:`close` (or :meth:`abort` after a failure), or use it
    as a context manager (an exception other than Ctrl-C aborts).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        distro: str = DEFAULT_DISTRO,
        body_rpy: Callable[[], tuple[float, float, float] | None] | None = None,
        pose: Callable[[StereoFrame], tuple[Any, Any]] | None = None,
        epoch_offset_s: float = 0.0,
    ) -> None:
        from mcap.writer import CompressionType, Writer

        self.target = Path(path)
        self.store = m.typestore(distro)
        self.body_rpy = body_rpy or (lambda: None)
        self.pose = pose
        self.epoch_offset_s = float(epoch_offset_s)
        fd, tmp = tempfile.mkstemp(
            prefix=f".{self.target.name}.", suffix=".part", dir=self.target.parent or Path(".")
        )
        self._tmp = Path(tmp)
        self._fh = os.fdopen(fd, "wb")
        self._writer = Writer(self._fh, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="stereo-terrain")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self._pending: terrain_t | None = None
        self._last_stamp_ns: int | None = None
        self._closed = False
        self.pairs = 0
        self.messages = 0

    # ----------------------------------------------------------------- records

    def _channel(self, topic: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            typename = TOPIC_TYPES[topic]
            sid = self._schemas.get(typename)
            if sid is None:
                text = m.schema_text(self.store, typename).encode()
                sid = self._schemas[typename] = self._writer.register_schema(typename, "ros2msg", text)
            cid = self._channels[topic] = self._writer.register_channel(
                topic, "cdr", sid, metadata={"offered_qos_profiles": ""}
            )
        return cid

    def _write(self, topic: str, message: Any, log_ns: int) -> None:
        data = self.store.serialize_cdr(message, TOPIC_TYPES[topic])
        self._writer.add_message(self._channel(topic), log_ns, bytes(data), log_ns, self._sequence)
        self._sequence += 1
        self.messages += 1

    def _stamp_ns(self, frame: StereoFrame) -> int:
        if frame.stamp_s is not None:
            return int(round(frame.stamp_s * 1e9))
        return int(round((frame.t_capture_s + self.epoch_offset_s) * 1e9))

    # ----------------------------------------------------------------- the loop's hooks

    def publish(self, msg: terrain_t) -> None:
        """Every terrain message the loop publishes. A message that no result follows (a
        stale heartbeat) is written on its own when the next one comes, or at close."""
        if self._pending is not None:
            self._write_heartbeat(self._pending)
        self._pending = msg

    def _write_heartbeat(self, msg: terrain_t) -> None:
        if self._last_stamp_ns is None:
            return  # nothing processed yet: nothing to be stale about in the file
        age_ns = max(0, int(msg.publish_utime - msg.utime) * 1000)
        with _ctrl_c_after():
            self._write(
                TOPIC_TERRAIN,
                m.terrain_ros_message(self.store, msg, self._last_stamp_ns),
                self._last_stamp_ns + age_ns,
            )

    def on_result(self, frame: StereoFrame, result: Any) -> None:
        """The messages of one processed pair (``result`` a ``TerrainResult``)."""
        msg = (
            self._pending if self._pending is not None and self._pending.frame_index == frame.index else None
        )
        self._pending = None
        odometry = frame.odometry
        if self.pose is not None:
            odometry = self.pose(frame)[0]
        self.write_result(result, self._stamp_ns(frame), terrain=msg, odometry=odometry)

    def write_result(
        self, result: Any, stamp_ns: int, *, terrain: terrain_t | None = None, odometry: Any = None
    ) -> None:
        """Write the messages of ``result`` stamped ``stamp_ns`` (epoch nanoseconds);
        ``terrain``: its LCM terrain message (None: none on the terrain topic)."""
        if self._closed:
            raise RuntimeError("McapSink is closed")
        s = self.store
        transforms = m.frame_transforms(result, self.body_rpy())
        if odometry is not None:
            transforms.insert(0, m.world_transform(odometry.position_m, odometry.yaw_rad))
        rect = result.rectified.rectification
        built = [
            (TOPIC_TF, m.tf_message(s, transforms, stamp_ns)),
            (TOPIC_CLOUD, m.cloud_message(s, result.planes, stamp_ns)),
            (TOPIC_STAIRS, m.stairs_message(s, result.terrain, result.swing, stamp_ns)),
            (TOPIC_IMAGE, m.image_message(s, result.rectified.left, stamp_ns, "camera_rect")),
            (TOPIC_CAMERA_INFO, m.rectified_camera_info(s, rect, stamp_ns)),
            (TOPIC_DISPARITY, m.image_message(s, result.disparity.disparity, stamp_ns, "camera_rect")),
        ]
        if terrain is not None:
            built.append((TOPIC_TERRAIN, m.terrain_ros_message(s, terrain, stamp_ns)))
        with _ctrl_c_after():
            for topic, message in built:
                self._write(topic, message, stamp_ns)
        self._last_stamp_ns = stamp_ns
        self.pairs += 1

    # ----------------------------------------------------------------- end

    def close(self) -> None:
        """Finish the file and rename it onto the target."""
        if self._closed:
            return
        with _ctrl_c_after():
            if self._pending is not None:
                self._write_heartbeat(self._pending)
                self._pending = None
            self._closed = True
            try:
                self._writer.finish()
                self._fh.close()
                os.chmod(self._tmp, 0o666 & ~_umask())  # mkstemp's 0600 -> what open() would give
                os.replace(self._tmp, self.target)
            except OSError as exc:
                self._remove_tmp()
                raise InputError(f"cannot write {self.target}: {exc.strerror}") from None

    def abort(self) -> None:
        """Drop the file being written (the target is left as it was)."""
        self._closed = True
        with contextlib.suppress(OSError):
            self._fh.close()
        self._remove_tmp()

    def _remove_tmp(self) -> None:
        with contextlib.suppress(OSError):
            self._tmp.unlink()

    def __enter__(self) -> McapSink:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None or issubclass(exc_type, KeyboardInterrupt):
            self.close()
        else:
            self.abort()
