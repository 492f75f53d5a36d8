"""Stereo pairs from a ROS 2 bag: a rosbag2 folder (MCAP or SQLite storage) or an MCAP file.

:class:`BagPairs` is a recorded pair source for :class:`~stereo_terrain.runtime.capture.Paced`
and the live loop (``replay BAG --left-topic T --right-topic T``). The images are
``sensor_msgs/msg/Image`` (``mono8``, ``mono16``, ``bgr8``, ``rgb8``, ``bgra8``, ``rgba8``,
their ``8UC1``/``8UC3``/``16UC1`` names, and the packed 4:2:2 ``yuv422``/``yuv422_yuy2``)
or ``sensor_msgs/msg/CompressedImage`` (whatever OpenCV decodes: JPEG, PNG). Pairs are formed
from the header stamps
(:func:`~stereo_terrain.runtime.capture.match_stamps`: each image with its nearest partner),
and the live cameras' skew rule then drops pairs further apart than ``--max-skew-ms``. A
stream whose header stamps are all zero is timed by the bag's receive times instead.

With ``--odom-topic`` (``nav_msgs/msg/Odometry``) each pair gets the body pose of the
odometry message nearest its stamp (within :data:`MAX_ODOMETRY_GAP_S`): the position and
heading for the swing trigger, the roll and pitch for the yaw frame.

:func:`read_camera_info_calibration` gives the :class:`~stereo_terrain.calibration.StereoCalibration`
of the two cameras from their ``sensor_msgs/msg/CameraInfo`` topics (``K D R P``; see
:func:`calibration_from_camera_info`).

Everything wrong with the bag (not a bag, a missing topic, a wrong type, a malformed
message) is one :class:`~stereo_terrain.errors.InputError` line; an image that does not
decode is an ``unreadable`` pair, counted by the loop.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..calibration import StereoCalibration
from ..errors import InputError
from ..odometry import Odometry
from ..runtime.capture import (
    END,
    FRAME,
    MAX_REPLAY_GAP_S,
    UNREADABLE,
    CaptureEvent,
    StereoFrame,
    match_stamps,
    replay_step_s,
)

log = logging.getLogger(__name__)

IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
CAMERA_INFO_TYPE = "sensor_msgs/msg/CameraInfo"

#: An odometry message further than this from a pair's stamp is not used for it (seconds).
MAX_ODOMETRY_GAP_S = 0.1

_CHANNELS = {"mono8": 1, "8UC1": 1, "mono16": 1, "16UC1": 1, "bgr8": 3, "rgb8": 3, "8UC3": 3}
_CHANNELS.update({"bgra8": 4, "rgba8": 4, "8UC4": 4})
# Packed 4:2:2 (2 bytes a pixel): ROS's "yuv422" is UYVY, "yuv422_yuy2" is YUYV.
_YUV422 = {"yuv422": cv2.COLOR_YUV2BGR_UYVY, "uyvy": cv2.COLOR_YUV2BGR_UYVY}
_YUV422.update({"yuv422_yuy2": cv2.COLOR_YUV2BGR_YUYV, "yuyv": cv2.COLOR_YUV2BGR_YUYV})
_CHANNELS.update(dict.fromkeys(_YUV422, 2))


def _bag_error(path: Path, exc: BaseException) -> InputError:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return InputError(f"cannot read the ROS bag {path}: {text[:300]}")


def open_bag(path: str | Path) -> Any:
    """An open ``rosbags`` reader of a rosbag2 folder or an MCAP file; :class:`InputError`
    when it is neither or cannot be read."""
    from rosbags.highlevel import AnyReader

    path = Path(path)
    if not path.exists():
        raise InputError(f"ROS bag not found: {path}")
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise InputError(f"{path} is a folder without metadata.yaml: not a rosbag2 folder")
    if path.is_file() and path.suffix != ".mcap":
        raise InputError(f"{path} is not an MCAP file (.mcap) or a rosbag2 folder")
    try:
        reader = AnyReader([path])
        reader.open()
    except Exception as exc:  # rosbags raises many kinds for a damaged file; all are the user's
        raise _bag_error(path, exc) from None
    return reader


def _connections(reader: Any, topic: str, types: tuple[str, ...], option: str, path: Path) -> list[Any]:
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        have = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
        raise InputError(
            f"{option} {topic}: no such topic in {path}; it has: {', '.join(have) or 'no topics'}"
        )
    bad = sorted({c.msgtype for c in conns if c.msgtype not in types})
    if bad:
        raise InputError(f"{option} {topic} in {path} is {bad[0]}, expected {' or '.join(types)}")
    return conns


def _messages(
    reader: Any, conns: list[Any], path: Path, *, decode: bool = True
) -> Iterator[tuple[Any, int, Any]]:
    """(connection, receive time ns, decoded message, or its raw CDR bytes when not
    ``decode``) in the bag's order."""
    try:
        for conn, t_ns, raw in reader.messages(connections=conns):
            yield conn, int(t_ns), reader.deserialize(raw, conn.msgtype) if decode else raw
    except InputError:
        raise
    except Exception as exc:
        raise _bag_error(path, exc) from None


def _raw_stamp(raw: bytes | memoryview) -> float | None:
    """The header stamp of a CDR message whose first field is a ``std_msgs/Header``, read
    from its first bytes (encapsulation, ``int32 sec``, ``uint32 nanosec``) without decoding
    the image behind it; None when the encapsulation is not plain CDR."""
    b = bytes(raw[:12])
    if len(b) < 12 or b[0] != 0 or b[1] not in (0, 1):
        return None
    sec, nanosec = struct.unpack_from("<iI" if b[1] == 1 else ">iI", b, 4)
    return float(sec) + 1e-9 * float(nanosec)


def _header_s(msg: Any) -> float:
    st = msg.header.stamp
    return float(st.sec) + 1e-9 * float(st.nanosec)


def decode_image(msg: Any, msgtype: str) -> np.ndarray:
    """An image message -> (H, W) or (H, W, 3) uint8 (BGR); :class:`InputError` when it
    cannot be decoded."""
    data = np.asarray(msg.data, dtype=np.uint8).reshape(-1)
    if msgtype.endswith("CompressedImage"):
        img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
        if img is None:
            raise InputError(f"compressed image ({msg.format!r}, {data.size} bytes) does not decode")
        if img.dtype == np.uint16:
            img = (np.asarray(img, dtype=np.uint16) // 256).astype(np.uint8)
        if img.ndim == 3 and img.shape[2] == 4:
            img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
        return img
    enc = str(msg.encoding)
    if enc not in _CHANNELS:
        raise InputError(f"image encoding {enc!r} is not supported (mono8, mono16, bgr8, rgb8, ...)")
    ch = _CHANNELS[enc]
    depth = 2 if "16" in enc else 1
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    if h <= 0 or w <= 0 or step < w * ch * depth or data.size < step * (h - 1) + w * ch * depth:
        raise InputError(f"image {w}x{h} {enc} with step {step} does not fit its {data.size} data bytes")
    rows = np.lib.stride_tricks.as_strided(data, (h, w * ch * depth), (step, 1))
    if depth == 2:
        order = ">" if msg.is_bigendian else "<"
        img16 = np.ascontiguousarray(rows).view(f"{order}u2").reshape(h, w)
        return (img16 >> 8).astype(np.uint8)
    img = np.ascontiguousarray(rows).reshape(h, w, ch) if ch > 1 else np.ascontiguousarray(rows)
    if enc in _YUV422:
        if w % 2:
            raise InputError(f"image {w}x{h} {enc}: a 4:2:2 image needs an even width")
        return cv2.cvtColor(img, _YUV422[enc])
    if enc == "rgb8":
        img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
    elif enc == "rgba8":
        img = cv2.cvtColor(img, cv2.COLOR_RGBA2BGR)
    elif ch == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    return img


def _rpy_from_quaternion(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Roll, pitch, yaw (ZYX: ``R = Rz(yaw) Ry(pitch) Rx(roll)``), radians."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0 or not math.isfinite(n):
        raise InputError("odometry orientation is not a quaternion (zero or not finite)")
    x, y, z, w = x / n, y / n, z / n, w / n
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


@dataclass(frozen=True)
class _Pose:
    t_s: float
    odometry: Odometry
    rpy: tuple[float, float, float]


def _stamps(items: list[tuple[int, float]], topic: str) -> np.ndarray:
    """Stamps of one stream in seconds: the header stamps, or the receive times when the
    header stamps are all zero."""
    header = np.array([h for _, h in items], dtype=np.float64)
    if len(header) and not np.any(header):
        log.warning("%s: every header stamp is zero; using the bag's receive times", topic)
        return np.array([t * 1e-9 for t, _ in items], dtype=np.float64)
    return header


class BagPairs:
    """Stereo pairs from a ROS 2 bag, in time order (a recorded source for ``Paced``).

    Parameters
    ----------
    path : path-like
        A rosbag2 folder or an ``.mcap`` file.
    left_topic, right_topic : str
        ``sensor_msgs/msg/Image`` or ``CompressedImage`` topics of the raw left and right
        images.
    odom_topic : str, optional
        ``nav_msgs/msg/Odometry`` topic of the body pose.
    loop : bool
        Start again at the end.

    Attributes
    ----------
    pairs : list of (left index, right index, left stamp s, right stamp s)
        The matched images, by their position in each topic.
    """

    def __init__(
        self,
        path: str | Path,
        left_topic: str,
        right_topic: str,
        *,
        odom_topic: str | None = None,
        loop: bool = False,
    ) -> None:
        self.path = Path(path)
        if left_topic == right_topic:
            raise InputError(f"--left-topic and --right-topic are the same topic {left_topic}")
        self.loop = loop
        self._reader = open_bag(self.path)
        try:
            self._left = _connections(self._reader, left_topic, IMAGE_TYPES, "--left-topic", self.path)
            self._right = _connections(self._reader, right_topic, IMAGE_TYPES, "--right-topic", self.path)
            odom = (
                _connections(self._reader, odom_topic, (ODOMETRY_TYPE,), "--odom-topic", self.path)
                if odom_topic
                else []
            )
            self.pairs = self._match(left_topic, right_topic)
            self._poses = self._read_poses(odom)
        except BaseException:
            self._reader.close()
            raise
        if not self.pairs:
            self._reader.close()
            raise InputError(
                f"{self.path}: no left/right image pairs on {left_topic} and {right_topic} "
                "(a topic without messages?)"
            )
        raw_t = np.array([max(tl, tr) for _, _, tl, tr in self.pairs])
        # Pauses longer than MAX_REPLAY_GAP_S are replayed that long, as for a PNG recording
        # (the stamps written out stay the bag's own).
        gaps = np.diff(raw_t, prepend=raw_t[0])
        self._shift = np.cumsum(np.where(gaps > MAX_REPLAY_GAP_S, gaps - MAX_REPLAY_GAP_S, 0.0))
        if self._shift[-1] > 0:
            log.warning(
                "%s: %d pause(s) longer than %.1f s replayed as %.1f s",
                self.path, int(np.sum(gaps > MAX_REPLAY_GAP_S)), MAX_REPLAY_GAP_S, MAX_REPLAY_GAP_S,
            )  # fmt: skip
        t = raw_t - self._shift
        step = replay_step_s(t)
        self._period = t[-1] - t[0] + step
        # The same on the poses' own clock (pauses not shortened): each round's pose stamps
        # come after the last round's.
        self._pose_period = raw_t[-1] - raw_t[0] + step
        self._round = 0
        self._read_round = 0  # the round of the last pair read
        self._stream: Iterator[tuple[int, Any, Any]] | None = None
        self._next: tuple[int, Any, Any] | None = None
        self._index = 0
        self._advance()

    def __len__(self) -> int:
        return len(self.pairs)

    def _match(self, left_topic: str, right_topic: str) -> list[tuple[int, int, float, float]]:
        items: dict[str, list[tuple[int, float]]] = {"l": [], "r": []}
        left_ids = {id(c) for c in self._left}
        for conn, t_ns, raw in _messages(self._reader, self._left + self._right, self.path, decode=False):
            stamp = _raw_stamp(raw)
            if stamp is None:
                stamp = _header_s(self._deserialize(raw, conn))
            items["l" if id(conn) in left_ids else "r"].append((t_ns, stamp))
        tl, tr = _stamps(items["l"], left_topic), _stamps(items["r"], right_topic)
        if not (np.all(np.isfinite(tl)) and np.all(np.isfinite(tr))):
            raise InputError(f"{self.path}: image header stamps are not finite")
        ol, orr = np.argsort(tl, kind="stable"), np.argsort(tr, kind="stable")
        pairs = [
            (int(ol[i]), int(orr[j]), float(tl[ol[i]]), float(tr[orr[j]]))
            for i, j in match_stamps(tl[ol], tr[orr])
        ]
        return pairs

    def _deserialize(self, raw: Any, conn: Any) -> Any:
        try:
            return self._reader.deserialize(raw, conn.msgtype)
        except Exception as exc:  # a malformed message
            raise InputError(f"a {conn.msgtype} message on {conn.topic} does not decode: {exc}") from None

    def _read_poses(self, conns: list[Any]) -> list[_Pose]:
        poses = []
        for _, _, msg in _messages(self._reader, conns, self.path) if conns else ():
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            values = [float(v) for v in (p.x, p.y, p.z)]
            if not all(math.isfinite(v) for v in values):
                continue  # the loop would ignore it anyway
            try:
                rpy = _rpy_from_quaternion(float(q.x), float(q.y), float(q.z), float(q.w))
            except InputError:
                continue  # a bad orientation: no pose for the pairs near it, as for NaN positions
            t_s = _header_s(msg)
            poses.append(_Pose(t_s, Odometry((values[0], values[1], values[2]), rpy[2], t_s), rpy))
        poses.sort(key=lambda p: p.t_s)
        self._pose_times = np.array([p.t_s for p in poses], dtype=np.float64)
        return poses

    def _pose_at(self, t_s: float) -> _Pose | None:
        if not self._poses:
            return None
        times = self._pose_times
        k = int(np.searchsorted(times, t_s))
        best = min((c for c in (k - 1, k) if 0 <= c < len(times)), key=lambda c: abs(times[c] - t_s))
        return self._poses[best] if abs(times[best] - t_s) <= MAX_ODOMETRY_GAP_S else None

    # ----------------------------------------------------------------- streaming

    def _pair_stream(self) -> Iterator[tuple[int, Any, Any]]:
        """(pair number, left (conn, raw), right (conn, raw)) in the order pairs complete; the
        images are decoded only when read (a skipped pair costs no decoding)."""
        want_l = {li: k for k, (li, _, _, _) in enumerate(self.pairs)}
        want_r = {ri: k for k, (_, ri, _, _) in enumerate(self.pairs)}
        left_ids = {id(c) for c in self._left}
        held: dict[int, dict[str, Any]] = {}
        n = {"l": 0, "r": 0}
        for conn, _, msg in _messages(self._reader, self._left + self._right, self.path, decode=False):
            side = "l" if id(conn) in left_ids else "r"
            k = (want_l if side == "l" else want_r).get(n[side])
            n[side] += 1
            if k is None:
                continue
            got = held.setdefault(k, {})
            got[side] = (conn, bytes(msg))  # a copy: the reader may reuse its buffers
            if len(got) == 2:
                del held[k]
                yield k, got["l"], got["r"]

    def _advance(self) -> None:
        while True:
            if self._stream is None:
                self._stream = self._pair_stream()
            self._next = next(self._stream, None)
            if self._next is not None or not self.loop:
                return
            self._stream = None
            self._round += 1

    def _time(self, k: int) -> float:
        _, _, tl, tr = self.pairs[k]
        return max(tl, tr) - self._shift[k] + self._round * self._period

    def peek_time(self) -> float | None:
        return None if self._next is None else self._time(self._next[0])

    def skip(self) -> None:
        self._index += 1
        self._advance()

    def read(self) -> CaptureEvent:
        if self._next is None:
            return CaptureEvent(END)
        k, (lc, lm), (rc, rm) = self._next
        offset = self._round * self._period
        pose_offset = self._round * self._pose_period
        restart, self._read_round = self._round > self._read_round, self._round
        index = self._index
        self.skip()
        _, _, tl, tr = self.pairs[k]
        try:
            left = decode_image(self._deserialize(lm, lc), lc.msgtype)
            right = decode_image(self._deserialize(rm, rc), rc.msgtype)
        except InputError as exc:
            return CaptureEvent(UNREADABLE, detail=f"pair {index}: {exc}")
        pose = self._pose_at(max(tl, tr))
        frame = StereoFrame(
            left,
            right,
            tl - self._shift[k] + offset,
            tr - self._shift[k] + offset,
            index,
            # a looped replay's later rounds come later on the poses' clock too
            None if pose is None else dataclasses.replace(pose.odometry, stamp_s=pose.t_s + pose_offset),
            None if pose is None else pose.rpy,
            stamp_s=max(tl, tr) + offset,
            restart=restart,
        )
        return CaptureEvent(FRAME, frame)

    def close(self) -> None:
        self._stream = None
        try:
            self._reader.close()
        except Exception:  # already closed
            pass


# --------------------------------------------------------------------------- CameraInfo


def _matrix(values: Any, shape: tuple[int, int], name: str, where: str) -> np.ndarray:
    try:
        a = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {name} is not numeric") from None
    if a.size != shape[0] * shape[1]:
        raise InputError(f"{where}: {name} must have {shape[0] * shape[1]} values, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{where}: {name} has non-finite values")
    return a.reshape(shape)


def _distortion(info: Any, where: str) -> np.ndarray:
    model = str(info.distortion_model)
    d = np.asarray(info.d, dtype=np.float64).reshape(-1)
    if model in ("equidistant", "fisheye"):
        raise InputError(f"{where}: distortion model {model!r} (fisheye) is not supported; rectify first")
    if d.size == 0:
        return np.zeros(5)
    if model not in ("plumb_bob", "rational_polynomial", ""):
        raise InputError(
            f"{where}: distortion model {model!r} is not supported (plumb_bob, rational_polynomial)"
        )
    if not np.all(np.isfinite(d)):
        raise InputError(f"{where}: distortion coefficients are not finite")
    if d.size not in (4, 5, 8, 12, 14):
        raise InputError(f"{where}: {d.size} distortion coefficients (expected 4, 5, 8, 12 or 14)")
    return d


def _rotation(values: Any, name: str, where: str) -> np.ndarray:
    R = _matrix(values, (3, 3), name, where)
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-4) or np.linalg.det(R) < 0.5:
        raise InputError(f"{where}: {name} is not a rotation (the rectification rotation)")
    return R


def calibration_from_camera_info(left: Any, right: Any, source: str = "CameraInfo") -> StereoCalibration:
    """The stereo calibration in two ``sensor_msgs/msg/CameraInfo`` messages.

    ROS's stereo convention (``camera_calibration``, ``image_pipeline``): ``K`` and ``D`` of
    each raw camera, ``R`` the rotation of each camera into the common rectified frame, and
    ``P`` the rectified projection, with the right ``P[0, 3] = Tx = -fx * baseline``. So
    ``X_rect_left = R_left X_left``, ``X_rect_right = X_rect_left + t`` with
    ``t = P_right[:, :3]^-1 P_right[:, 3]`` (and the left's own, normally 0, taken off), and

    ``R = R_right^T R_left``, ``T = R_right^T t`` (``X_right = R X_left + T``, metres).

    Raises :class:`InputError` (one line) for a message that does not describe a horizontal
    stereo pair of the same image size.
    """
    where_l, where_r = f"{source} (left)", f"{source} (right)"
    sizes = []
    for info, where in ((left, where_l), (right, where_r)):
        try:
            w, h = int(info.width), int(info.height)
        except (TypeError, ValueError, OverflowError):
            raise InputError(f"{where}: width and height must be integers") from None
        if w <= 0 or h <= 0:
            raise InputError(f"{where}: image size {w}x{h} is not positive (an uncalibrated camera?)")
        sizes.append((w, h))
    if sizes[0] != sizes[1]:
        raise InputError(f"{source}: the left camera is {sizes[0]} but the right {sizes[1]}")
    K1, K2 = _matrix(left.k, (3, 3), "K", where_l), _matrix(right.k, (3, 3), "K", where_r)
    for K, where in ((K1, where_l), (K2, where_r)):
        if not (K[0, 0] > 0 and K[1, 1] > 0 and abs(K[2, 2] - 1.0) < 1e-9):
            raise InputError(f"{where}: K is not a camera matrix (fx, fy > 0, K[2,2] = 1)")
    D1, D2 = _distortion(left, where_l), _distortion(right, where_r)
    R1, R2 = _rotation(left.r, "R", where_l), _rotation(right.r, "R", where_r)
    P1, P2 = _matrix(left.p, (3, 4), "P", where_l), _matrix(right.p, (3, 4), "P", where_r)
    offsets = []
    for P, where in ((P1, where_l), (P2, where_r)):
        if abs(np.linalg.det(P[:, :3])) < 1e-12:
            raise InputError(f"{where}: P is singular")
        offsets.append(np.linalg.solve(P[:, :3], P[:, 3]))
    t = offsets[1] - offsets[0]
    if not t[0] < 0:
        raise InputError(
            f"{where_r}: P[0,3] (Tx = -fx * baseline) must be negative for the right camera, "
            f"got {P2[0, 3]:g}; are the left and right topics swapped?"
        )
    R = R2.T @ R1
    T = R2.T @ t
    return StereoCalibration(K1, D1, K2, D2, R, T, sizes[0], source=source)


def camera_info_fields(calib: StereoCalibration) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``CameraInfo`` fields (``width height distortion_model d k r p``) of both cameras
    of ``calib``, with the rectification OpenCV's ``stereoRectify`` gives (alpha 0, zero
    disparity): what ``camera_calibration`` would publish for this rig."""
    from ..rectify import compute_rectification

    rect = compute_rectification(calib, fov="valid")
    w, h = calib.image_size
    out = []
    for K, D, R, P in ((calib.K1, calib.D1, rect.R1, rect.P1), (calib.K2, calib.D2, rect.R2, rect.P2)):
        d = np.asarray(D, dtype=np.float64).reshape(-1)
        out.append(
            {
                "width": w,
                "height": h,
                "distortion_model": "plumb_bob" if d.size <= 5 else "rational_polynomial",
                "d": d,
                "k": np.asarray(K, dtype=np.float64).reshape(-1),
                "r": np.asarray(R, dtype=np.float64).reshape(-1),
                "p": np.asarray(P, dtype=np.float64).reshape(-1),
            }
        )
    return out[0], out[1]


def info_topic(image_topic: str) -> str:
    """The ``camera_info`` topic beside an image topic (``/cam/left/image_raw`` ->
    ``/cam/left/camera_info``), as ROS camera drivers name them."""
    ns = image_topic.rstrip("/").rsplit("/", 1)[0]
    if ns.endswith("/compressed") or image_topic.endswith("/compressed"):
        ns = image_topic.rstrip("/").removesuffix("/compressed").rsplit("/", 1)[0]
    return f"{ns}/camera_info"


def read_camera_info_calibration(path: str | Path, left_topic: str, right_topic: str) -> StereoCalibration:
    """The calibration from the first message on each of two ``CameraInfo`` topics."""
    path = Path(path)
    reader = open_bag(path)
    try:
        first: dict[str, Any] = {}
        conns = []
        for topic, option in ((left_topic, "left"), (right_topic, "right")):
            found = [c for c in reader.connections if c.topic == topic]
            if not found:
                infos = sorted({c.topic for c in reader.connections if c.msgtype == CAMERA_INFO_TYPE})
                raise InputError(
                    f"no --calib given and {path} has no {option} CameraInfo topic {topic} "
                    f"(CameraInfo topics: {', '.join(infos) or 'none'}); pass --calib or "
                    f"--{option}-info-topic"
                )
            conns += _connections(reader, topic, (CAMERA_INFO_TYPE,), f"--{option}-info-topic", path)
        for conn, _, msg in _messages(reader, conns, path):
            first.setdefault(conn.topic, msg)
            if len(first) == 2:
                break
        if len(first) < 2:
            missing = right_topic if left_topic in first else left_topic
            raise InputError(f"{path}: the CameraInfo topic {missing} has no messages")
        return calibration_from_camera_info(
            first[left_topic], first[right_topic], source=f"{path} ({left_topic}, {right_topic})"
        )
    finally:
        reader.close()
