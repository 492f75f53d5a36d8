"""The small geometry of up: unit vectors, angles, the tangent plane of a direction and
the transforms that level a frame."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from .._numeric import cross3
from ..frames import Transform

#: Up in the optical frame of an upright camera (x right, y down, z forward): the weak
#: prior of every estimate without a rig.
CAMERA_UP = np.array([0.0, -1.0, 0.0])
CAMERA_UP.setflags(write=False)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _tangent_basis(u: np.ndarray) -> np.ndarray:
    """(2, 3): two unit vectors orthogonal to ``u`` and to each other."""
    # np.linalg.norm of a vector is sqrt(x.dot(x)) (the same bits, without its wrapper).
    a = cross3(u, (1.0, 0.0, 0.0))
    if math.sqrt(a.dot(a)) < 0.5:
        a = cross3(u, (0.0, 1.0, 0.0))
    a /= math.sqrt(a.dot(a))
    out = np.empty((2, 3))
    out[0] = a
    out[1] = cross3(u, a)
    return out


def rotation_between(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` to unit vector ``b``."""
    ua = np.asarray(a, dtype=np.float64)
    ua = ua / np.linalg.norm(ua)
    ub = np.asarray(b, dtype=np.float64)
    ub = ub / np.linalg.norm(ub)
    v = np.cross(ua, ub)
    c = float(ua @ ub)
    s = float(np.linalg.norm(v))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(ua, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(ua, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K * ((1.0 - c) / (s * s))


def levelling(up: np.ndarray, frame: str = "yaw") -> Transform:
    """``T_<frame>_<frame>``: the smallest rotation that takes ``up`` (in ``frame``) to +z."""
    return Transform.from_rt(rotation_between(up, [0.0, 0.0, 1.0]), np.zeros(3), frame, frame)


def angle_deg(a: ArrayLike, b: ArrayLike) -> float:
    """Angle between two vectors, degrees."""
    c = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def yaw_frame_from_up(up: np.ndarray, frame: str, camera_position: np.ndarray | None = None) -> Transform:
    """``T_yaw_<frame>`` for a camera-fixed ``frame`` whose gravity-up is ``up``: z along
    ``up``, x along the optical axis (+z of ``frame``) projected on the horizontal, origin at
    the camera (``camera_position``, default the frame's origin)."""
    z = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    x = np.array([0.0, 0.0, 1.0]) - z * z[2]
    if np.linalg.norm(x) < 1e-6:  # looking straight up or down: any heading will do
        x = np.array([1.0, 0.0, 0.0]) - z * z[0]
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.vstack([x, y, z])
    cam = np.zeros(3) if camera_position is None else np.asarray(camera_position, dtype=np.float64)
    return Transform.from_rt(R, -R @ cam, "yaw", frame)
