"""ROS 2 message definitions and the messages of one processed pair.

The standard definitions (``sensor_msgs``, ``visualization_msgs``, ``tf2_msgs``, ...) are
those of ``rosbags``' type store for a ROS 2 distribution (:data:`~stereo_terrain.ros.DISTROS`),
so the schemas written into an MCAP file are the distribution's own, field for field. For
the types written here Humble and Jazzy differ only in one constant (``Marker.ARROW_STRIP``,
Jazzy's), not in their fields, so a file of either plays on both.

The package's own ``stereo_terrain_msgs/msg/Terrain`` is built from the LCM
``terrain_t`` (:func:`terrain_msgdef`): a ``std_msgs/Header`` followed by every field of
``terrain_t`` in its order, with its constants and the comments of ``terrain_t.lcm``, so a
field added to the LCM type appears in the ROS message without a change here.

Times are integer nanoseconds since the epoch; frames are those of ``docs/conventions.md``.
"""

from __future__ import annotations

import functools
import re
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..frames import Transform, yaw_from_body
from ..runtime.messages import terrain_t
from . import DEFAULT_DISTRO, DISTROS, TERRAIN_TYPE

#: LCM primitive types and their ROS 2 ``.msg`` equivalents.
LCM_TO_ROS = {
    "int8_t": "int8",
    "int16_t": "int16",
    "int32_t": "int32",
    "int64_t": "int64",
    "float": "float32",
    "double": "float64",
    "boolean": "bool",
    "byte": "uint8",
    "string": "string",
}
_NUMPY = {
    "int8": np.int8,
    "int16": np.int16,
    "int32": np.int32,
    "int64": np.int64,
    "uint8": np.uint8,
    "uint16": np.uint16,
    "uint32": np.uint32,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
    "bool": np.bool_,
}
_SEPARATOR = "=" * 80 + "\n"

# Plane colours (RGB) in the cloud's ``rgb`` field and the viewer; unlabelled points grey.
PALETTE = np.array(
    [
        [230, 25, 75],
        [60, 180, 75],
        [255, 225, 25],
        [0, 130, 200],
        [245, 130, 48],
        [145, 30, 180],
        [70, 240, 240],
        [240, 50, 230],
        [210, 245, 60],
        [250, 190, 212],
        [0, 128, 128],
        [220, 190, 255],
        [170, 110, 40],
        [128, 0, 0],
        [170, 255, 195],
    ],
    dtype=np.uint8,
)
UNLABELLED_RGB = np.array([128, 128, 128], dtype=np.uint8)


def plane_colours(labels: np.ndarray) -> np.ndarray:
    """(N,) int plane labels (-1 none) -> (N, 3) uint8 RGB."""
    labels = np.asarray(labels)
    out = np.broadcast_to(UNLABELLED_RGB, (*labels.shape, 3)).copy()
    has = labels >= 0
    out[has] = PALETTE[labels[has] % len(PALETTE)]
    return out


# --------------------------------------------------------------------------- definitions


def _lcm_notes() -> tuple[dict[str, list[str]], dict[str, str]]:
    """Comments before each field of ``terrain_t`` and the LCM type of each constant, from
    ``terrain_t.lcm`` (documentation only: the fields themselves come from the class)."""
    text = (resources.files("stereo_terrain.runtime") / "lcmtypes" / "terrain_t.lcm").read_text()
    body = text.split("struct terrain_t", 1)[1].split("}", 1)[0]
    comments: dict[str, list[str]] = {}
    consts: dict[str, str] = {}
    pending: list[str] = []
    for raw in body.splitlines():
        line = raw.strip()
        if line.startswith("//"):
            pending.append(line[2:].strip())
            continue
        if const := re.match(r"const\s+(\w+)\s+(.+);", line):
            for item in const.group(2).split(","):
                consts[item.split("=")[0].strip()] = const.group(1)
        elif field := re.match(r"\w+\s+(\w+)\s*(\[[^\]]*\])?\s*;", line):
            comments[field.group(1)] = pending
        pending = [] if not line.startswith("//") else pending
    return comments, consts


def _ros_field_type(lcm_type: str, dims: list[Any] | None, name: str) -> str:
    try:
        base = LCM_TO_ROS[lcm_type]
    except KeyError:
        raise TypeError(f"terrain_t.{name}: LCM type {lcm_type!r} has no ROS 2 equivalent here") from None
    if not dims:
        return base
    if len(dims) != 1:
        raise TypeError(f"terrain_t.{name}: multi-dimensional arrays have no ROS 2 equivalent")
    return f"{base}[{dims[0]}]" if isinstance(dims[0], int) else f"{base}[]"


def terrain_fields() -> list[tuple[str, str]]:
    """(name, ROS 2 type) of every ``terrain_t`` field, in order (without the header)."""
    return [
        (name, _ros_field_type(lcm_type, dims, name))
        for name, lcm_type, dims in zip(
            terrain_t.__slots__, terrain_t.__typenames__, terrain_t.__dimensions__, strict=True
        )
    ]


def terrain_msgdef() -> str:
    """The ``.msg`` text of ``stereo_terrain_msgs/msg/Terrain`` (without its dependencies)."""
    comments, const_types = _lcm_notes()
    lines = [
        "# The terrain ahead of a legged robot, from stereo-terrain: the fields of the LCM type",
        "# stereo_terrain_lcm/terrain_t in its order, after a header whose stamp is the capture",
        "# time of the stereo pair and whose frame_id is 'yaw' (docs/conventions.md). SI units;",
        "# unknown floats are NaN.",
    ]
    constants: list[str] = []  # in definition order (the class's, then a subclass's)
    for cls in reversed(terrain_t.__mro__):
        constants += [
            n for n, v in vars(cls).items() if n.isupper() and type(v) is int and n not in constants
        ]
    for name in constants:
        ros_type = LCM_TO_ROS.get(const_types.get(name, "int32_t"), "int32")
        lines.append(f"{ros_type} {name}={int(getattr(terrain_t, name))}")
    lines.append("std_msgs/Header header")
    for name, ros_type in terrain_fields():
        lines += [f"# {c}" if c else "#" for c in comments.get(name, [])]
        lines.append(f"{ros_type} {name}")
    return "\n".join(lines) + "\n"


@functools.cache
def typestore(distro: str = DEFAULT_DISTRO) -> Any:
    """``rosbags`` type store of ``distro`` with ``stereo_terrain_msgs/msg/Terrain`` added."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    if distro not in DISTROS:
        from ..errors import InputError

        raise InputError(f"ROS 2 distribution must be one of {', '.join(DISTROS)}, got {distro!r}")
    store = get_typestore(Stores.ROS2_JAZZY if distro == "jazzy" else Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(terrain_msgdef(), TERRAIN_TYPE))
    return store


def schema_text(store: Any, typename: str) -> str:
    """The ``ros2msg`` schema of ``typename`` as rosbag2 writes it: the type's definition,
    then each dependency after a line of ``=`` and ``MSG: pkg/Type``."""
    text = store.generate_msgdef(typename, ros_version=2)[0]
    if typename != TERRAIN_TYPE:
        return text
    deps = text.split(_SEPARATOR, 1)[1] if _SEPARATOR in text else ""
    return terrain_msgdef() + (_SEPARATOR + deps if deps else "")


# --------------------------------------------------------------------------- building messages


def _default(store: Any, typename: str) -> Any:
    """A message of ``typename`` with every field zero, empty or default."""
    _, fields = store.fielddefs[typename]
    return store.types[typename](**{name: _default_of(store, desc) for name, desc in fields})


def _default_of(store: Any, desc: tuple[Any, Any]) -> Any:
    kind, rest = int(desc[0]), desc[1]
    if kind == 1:  # base type
        base = rest[0]
        return "" if base == "string" else (False if base == "bool" else (0.0 if "float" in base else 0))
    if kind == 2:  # a nested message
        return _default(store, rest)
    sub, count = rest
    if int(sub[0]) == 1 and sub[1][0] in _NUMPY:  # numeric arrays are numpy arrays
        return np.zeros(count if kind == 3 else 0, dtype=_NUMPY[sub[1][0]])
    return [_default_of(store, sub) for _ in range(count if kind == 3 else 0)]


def make(store: Any, typename: str, **fields: Any) -> Any:
    """A message of ``typename``: the given fields, the others at their defaults (so one call
    builds the same message for every distribution, whichever fields it added)."""
    _, defs = store.fielddefs[typename]
    unknown = set(fields) - {name for name, _ in defs}
    if unknown:
        raise TypeError(f"{typename} has no field(s) {sorted(unknown)}")
    values = {name: fields[name] if name in fields else _default_of(store, desc) for name, desc in defs}
    return store.types[typename](**values)


def stamp(store: Any, stamp_ns: int) -> Any:
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return make(store, "builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)


def header(store: Any, stamp_ns: int, frame_id: str) -> Any:
    return make(store, "std_msgs/msg/Header", stamp=stamp(store, stamp_ns), frame_id=frame_id)


def plane_labels(planes: Any) -> np.ndarray:
    """(N,) int32: index of the plane each grid sample supports (extraction order), -1 none."""
    labels = np.full(len(planes.samples.points), -1, dtype=np.int32)
    for k, seg in enumerate(planes.segments):
        idx = np.asarray(seg.indices, dtype=np.int64)
        idx = idx[labels[idx] < 0]  # a sample two planes claim stays with the first
        labels[idx] = k
    return labels


def cloud_message(store: Any, planes: Any, stamp_ns: int) -> Any:
    """``sensor_msgs/msg/PointCloud2``: the grid-sampled cloud the planes were fitted to, in
    their frame (``yaw``), fields ``x y z`` (float32, m), ``plane`` (int32, index into the
    result's ``planes``, -1 for none) and ``rgb`` (the plane's colour, packed as PCL does)."""
    pts = np.asarray(planes.samples.points, dtype=np.float32).reshape(-1, 3)
    labels = plane_labels(planes)
    rgb = plane_colours(labels).astype(np.uint32)
    packed = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    dtype = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("plane", "<i4"), ("rgb", "<u4")])
    rec = np.empty(len(pts), dtype=dtype)
    rec["x"], rec["y"], rec["z"] = pts[:, 0], pts[:, 1], pts[:, 2]
    rec["plane"], rec["rgb"] = labels, packed
    field_t = "sensor_msgs/msg/PointField"
    fields = [
        make(store, field_t, name=name, offset=dtype.fields[name][1], datatype=code, count=1)  # type: ignore[index]
        for name, code in (("x", 7), ("y", 7), ("z", 7), ("plane", 5), ("rgb", 7))
    ]  # 7 FLOAT32, 5 INT32; rgb is declared FLOAT32 (its bits are the packed colour), as PCL does
    return make(
        store,
        "sensor_msgs/msg/PointCloud2",
        header=header(store, stamp_ns, planes.frame),
        height=1,
        width=len(pts),
        fields=fields,
        is_bigendian=False,
        point_step=dtype.itemsize,
        row_step=dtype.itemsize * len(pts),
        data=rec.view(np.uint8).reshape(-1),
        is_dense=bool(np.all(np.isfinite(pts))),
    )


def _point(store: Any, p: np.ndarray) -> Any:
    return make(store, "geometry_msgs/msg/Point", x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _colour(store: Any, r: float, g: float, b: float, a: float = 1.0) -> Any:
    return make(store, "std_msgs/msg/ColorRGBA", r=r, g=g, b=b, a=a)


def _pose_identity(store: Any) -> Any:
    q = make(store, "geometry_msgs/msg/Quaternion", w=1.0)
    return make(store, "geometry_msgs/msg/Pose", orientation=q)


def _vector(store: Any, x: float, y: float, z: float) -> Any:
    return make(store, "geometry_msgs/msg/Vector3", x=x, y=y, z=z)


def _text_marker(
    store: Any, hdr: Any, ns: str, marker_id: int, at: np.ndarray, text: str, rgb: tuple[float, float, float]
) -> Any:
    """A TEXT_VIEW_FACING marker, 6 cm high, at ``at``."""
    pose = make(
        store,
        "geometry_msgs/msg/Pose",
        position=_point(store, at),
        orientation=make(store, "geometry_msgs/msg/Quaternion", w=1.0),
    )
    return make(
        store, "visualization_msgs/msg/Marker", header=hdr, ns=ns, id=marker_id, type=9, action=0, pose=pose,
        scale=_vector(store, 0.0, 0.0, 0.06), color=_colour(store, *rgb), text=text,
    )  # fmt: skip


def step_label(i: int, step: Any) -> str:
    """``step 1: rise 17.0 cm, run 30.0 cm, at 1.20 m`` (run ``?`` when not seen whole)."""
    run = "?" if step.run_m is None else f"{100 * step.run_m:.1f} cm"
    return f"step {i}: rise {100 * step.rise_m:.1f} cm, run {run}, at {step.distance_m:.2f} m"


def stairs_message(store: Any, terrain: Any, swing: Any, stamp_ns: int) -> Any:
    """``visualization_msgs/msg/MarkerArray`` in the terrain's frame: a DELETEALL (so that
    the markers of the previous pair go), the polytope's risers and treads (triangle lists),
    its edges (a line list), a text per step with its rise and run, and the swing plan."""
    m_t = "visualization_msgs/msg/Marker"
    hdr = header(store, stamp_ns, terrain.frame)
    markers = [make(store, m_t, header=hdr, ns="stairs", action=3)]  # DELETEALL
    verts = np.asarray(terrain.polytope.vertices, dtype=np.float64).reshape(-1, 3)
    faces = [f for f in terrain.polytope.faces if len(f) >= 3]
    tri: dict[str, list[Any]] = {"risers": [], "treads": []}
    edges: list[Any] = []
    for face in faces:
        corners = verts[list(face)]
        normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        kind = "risers" if abs(normal[2]) < 0.5 * (np.linalg.norm(normal) + 1e-12) else "treads"
        for k in range(1, len(face) - 1):
            tri[kind] += [_point(store, corners[0]), _point(store, corners[k]), _point(store, corners[k + 1])]
        for k in range(len(face)):
            edges += [_point(store, corners[k]), _point(store, corners[(k + 1) % len(face)])]
    colours = {"risers": (0.9, 0.45, 0.1, 0.6), "treads": (0.1, 0.55, 0.9, 0.6)}
    common = {"header": hdr, "pose": _pose_identity(store), "action": 0}
    for n, (ns, points) in enumerate(tri.items()):
        if points:
            markers.append(
                make(
                    store,
                    m_t,
                    ns=ns,
                    id=n,
                    type=11,
                    points=points,
                    scale=_vector(store, 1.0, 1.0, 1.0),
                    color=_colour(store, *colours[ns]),
                    **common,
                )
            )
    if edges:
        markers.append(
            make(
                store,
                m_t,
                ns="edges",
                id=0,
                type=5,
                points=edges,
                scale=_vector(store, 0.01, 0.0, 0.0),
                color=_colour(store, 0.05, 0.05, 0.05),
                **common,
            )
        )
    for i, step in enumerate(terrain.steps, 1):
        at = np.array([step.distance_m, 0.0, step.top_z_m + 0.08])
        markers.append(_text_marker(store, hdr, "dimensions", i, at, step_label(i, step), (1.0, 1.0, 1.0)))
    trig = "-" if swing.trigger_distance_m is None else f"{swing.trigger_distance_m:.2f} m"
    text = f"{terrain.obstacle}: swing {swing.height_m:.2f} m, trigger {trig}" + (
        "" if swing.traversable else ", NOT traversable"
    )
    markers.append(_text_marker(store, hdr, "swing", 0, np.array([0.3, 0.0, 0.5]), text, (1.0, 1.0, 0.3)))
    return make(store, "visualization_msgs/msg/MarkerArray", markers=markers)


def frame_transforms(result: Any, body_rpy: tuple[float, float, float] | None) -> list[Transform]:
    """The chain ``yaw -> body -> camera -> camera_rect`` of one result (parents first).

    ``camera -> camera_rect`` is the rectification, and the chain's product is the
    ``T_yaw_camera_rect`` the pipeline used. With a rig, ``yaw -> body`` removes the body's
    roll and pitch (``body_rpy``); without one the body frame is the levelled yaw frame.
    """
    T_yaw_rect = result.T_yaw_camera_rect
    T_camera_rect = result.rectified.rectification.T_camera_rect
    T_yaw_body = (
        Transform(np.eye(4), "yaw", "body") if body_rpy is None else yaw_from_body(body_rpy[0], body_rpy[1])
    )
    T_body_camera = T_yaw_body.inverse() @ T_yaw_rect @ T_camera_rect.inverse()
    return [T_yaw_body, T_body_camera, T_camera_rect]


def _quaternion(R: np.ndarray) -> tuple[float, float, float, float]:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(R, dtype=np.float64)).as_quat()
    return float(x), float(y), float(z), float(w)


def tf_message(store: Any, transforms: list[Transform], stamp_ns: int) -> Any:
    """``tf2_msgs/msg/TFMessage``: each ``T_parent_child`` as a ``TransformStamped`` with
    ``header.frame_id = parent``, ``child_frame_id = child``."""
    out = []
    for T in transforms:
        x, y, z, w = _quaternion(T.rotation)
        t = T.translation
        transform = make(
            store,
            "geometry_msgs/msg/Transform",
            translation=_vector(store, float(t[0]), float(t[1]), float(t[2])),
            rotation=make(store, "geometry_msgs/msg/Quaternion", x=x, y=y, z=z, w=w),
        )
        out.append(
            make(
                store,
                "geometry_msgs/msg/TransformStamped",
                header=header(store, stamp_ns, T.to_frame),
                child_frame_id=T.from_frame,
                transform=transform,
            )
        )
    return make(store, "tf2_msgs/msg/TFMessage", transforms=out)


def world_transform(position_m: tuple[float, float, float], yaw_rad: float) -> Transform:
    """``T_world_yaw`` from odometry: the body position and heading."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Transform.from_rt(R, position_m, "world", "yaw")


def image_message(store: Any, image: np.ndarray, stamp_ns: int, frame_id: str) -> Any:
    """``sensor_msgs/msg/Image``: ``mono8`` (H, W) uint8, ``bgr8`` (H, W, 3) uint8 or
    ``32FC1`` (H, W) float32 (a disparity, NaN invalid)."""
    img = np.ascontiguousarray(image)
    if img.dtype == np.float32 and img.ndim == 2:
        encoding = "32FC1"
    elif img.dtype == np.uint8 and img.ndim == 2:
        encoding = "mono8"
    elif img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3:
        encoding = "bgr8"
    else:
        raise TypeError(f"no ROS image encoding for an array {img.shape} {img.dtype}")
    h, w = img.shape[:2]
    return make(
        store,
        "sensor_msgs/msg/Image",
        header=header(store, stamp_ns, frame_id),
        height=h,
        width=w,
        encoding=encoding,
        is_bigendian=0,
        step=img.strides[0],
        data=img.view(np.uint8).reshape(-1),
    )


def rectified_camera_info(store: Any, rect: Any, stamp_ns: int, frame_id: str = "camera_rect") -> Any:
    """``sensor_msgs/msg/CameraInfo`` of the rectified left image (no distortion, ``R = I``,
    ``P = [K | 0]``), so that viewers can project it into 3D."""
    w, h = rect.image_size
    K = np.array([[rect.focal_px, 0.0, rect.cx], [0.0, rect.focal_px, rect.cy], [0.0, 0.0, 1.0]])
    P = np.hstack([K, np.zeros((3, 1))])
    return make(
        store,
        "sensor_msgs/msg/CameraInfo",
        header=header(store, stamp_ns, frame_id),
        height=h,
        width=w,
        distortion_model="plumb_bob",
        d=np.zeros(5),
        k=K.reshape(-1),
        r=np.eye(3).reshape(-1),
        p=P.reshape(-1),
    )


def terrain_ros_message(store: Any, msg: terrain_t, stamp_ns: int, frame_id: str = "yaw") -> Any:
    """``stereo_terrain_msgs/msg/Terrain`` with the fields of the LCM message ``msg``."""
    values: dict[str, Any] = {"header": header(store, stamp_ns, frame_id)}
    for name, ros_type in terrain_fields():
        value = getattr(msg, name)
        base = ros_type.split("[", 1)[0]
        if "[" in ros_type:
            values[name] = (
                [str(v) for v in value] if base == "string" else np.asarray(value, dtype=_NUMPY[base])
            )
        elif base == "string":
            values[name] = str(value)
        elif base == "bool":
            values[name] = bool(value)
        else:
            values[name] = float(value) if base.startswith("float") else int(value)
    return make(store, TERRAIN_TYPE, **values)


# --------------------------------------------------------------------------- ROS 2 package

_PACKAGE_XML = """<?xml version="1.0"?>
<package format="3">
  <name>stereo_terrain_msgs</name>
  <version>0.1.0</version>
  <description>The terrain message of stereo-terrain (generated from its LCM terrain_t).</description>
  <maintainer email="stereo-terrain@example.invalid">stereo-terrain</maintainer>
  <license>MIT</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>std_msgs</depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""

_CMAKELISTS = """cmake_minimum_required(VERSION 3.8)
project(stereo_terrain_msgs)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(std_msgs REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME} "msg/Terrain.msg" DEPENDENCIES std_msgs)
ament_export_dependencies(rosidl_default_runtime)
ament_package()
"""


def write_msg_package(folder: str | Path) -> list[Path]:
    """Write the ROS 2 package ``stereo_terrain_msgs`` (``package.xml``, ``CMakeLists.txt``,
    ``msg/Terrain.msg``) into ``folder``, e.g. ``ws/src/stereo_terrain_msgs``, so that
    ``colcon build`` gives ROS the type and ``ros2 bag play`` can publish
    ``/stereo_terrain/terrain`` (the other topics need only ROS's own packages). Returns the
    files written."""
    folder = Path(folder)
    (folder / "msg").mkdir(parents=True, exist_ok=True)
    files = {
        folder / "package.xml": _PACKAGE_XML,
        folder / "CMakeLists.txt": _CMAKELISTS,
        folder / "msg" / "Terrain.msg": terrain_msgdef(),
    }
    for path, text in files.items():
        path.write_text(text)
    return list(files)
