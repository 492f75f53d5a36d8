"""Rigid transforms between named frames, the rig file and the gravity-aligned yaw frame.

Frames (see ``docs/conventions.md``):

* ``camera``: OpenCV optical, x right, y down, z forward; origin at the left camera centre.
  ``camera_rect`` is the same for the *rectified* left camera.
* ``body``: x forward, y left, z up.
* ``yaw``: the paper's Psi frame: body yaw kept, roll and pitch removed, z gravity-up.
* ``world``: z up, fixed.

A transform is named ``T_to_from`` so that ``p_to = T_to_from @ p_from``; composing
``T_a_b @ T_c_d`` raises :class:`FrameError` unless ``b == c``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from .errors import FrameError, InputError

#: Rotation that takes optical axes (x right, y down, z forward) to body axes
#: (x forward, y left, z up) for a level camera looking along body x.
R_BODY_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])

_ORTHO_TOL = 1e-6


def rot_x(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about x (right-handed)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about y (right-handed)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    """Rotation by ``angle`` radians about z (right-handed)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (intrinsic z-y'-x'', aerospace order)."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


@dataclass(frozen=True)
class Transform:
    """A rigid transform ``T_to_from`` between two named frames.

    Parameters
    ----------
    matrix : (4, 4) float64
        Homogeneous matrix, row-major; the rotation block must be orthonormal with
        determinant +1 and the last row ``[0, 0, 0, 1]``.
    to_frame, from_frame : str
        ``p_to = matrix @ p_from``.

    Examples
    --------
    >>> T = Transform.from_rt(np.eye(3), [0.0, 0.0, 0.5], "body", "camera")
    >>> T.apply(np.zeros((1, 3)))
    array([[0. , 0. , 0.5]])
    """

    matrix: np.ndarray = field(repr=False)
    to_frame: str
    from_frame: str

    def __post_init__(self) -> None:
        m = np.array(self.matrix, dtype=np.float64)
        if m.shape != (4, 4):
            raise FrameError(f"transform {self.name}: expected a 4x4 matrix, got shape {m.shape}")
        if not np.all(np.isfinite(m)):
            raise FrameError(f"transform {self.name}: matrix has non-finite entries")
        if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
            raise FrameError(f"transform {self.name}: last row must be [0, 0, 0, 1], got {m[3]}")
        r = m[:3, :3]
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or np.linalg.det(r) < 0.5:
            raise FrameError(
                f"transform {self.name}: rotation block is not a proper rotation "
                "(not orthonormal or det != +1); the rig transform is not invertible as a rigid motion"
            )
        m.setflags(write=False)
        object.__setattr__(self, "matrix", m)

    @classmethod
    def _trusted(cls, matrix: np.ndarray, to_frame: str, from_frame: str) -> Transform:
        """A transform whose ``matrix`` (a new float64 array, made read-only here) is known
        to be rigid: the product or inverse of checked transforms. Skips the check that
        ``__post_init__`` runs on every construction (issue 13: a few of them per frame)."""
        T = object.__new__(cls)
        matrix.setflags(write=False)
        object.__setattr__(T, "matrix", matrix)
        object.__setattr__(T, "to_frame", to_frame)
        object.__setattr__(T, "from_frame", from_frame)
        return T

    @property
    def name(self) -> str:
        return f"T_{self.to_frame}_{self.from_frame}"

    @classmethod
    def identity(cls, frame: str) -> Transform:
        return cls(np.eye(4), frame, frame)

    @classmethod
    def from_rt(cls, rotation: np.ndarray, translation, to_frame: str, from_frame: str) -> Transform:
        m = np.eye(4)
        m[:3, :3] = rotation
        m[:3, 3] = np.asarray(translation, dtype=np.float64).reshape(3)
        return cls(m, to_frame, from_frame)

    @property
    def rotation(self) -> np.ndarray:
        return self.matrix[:3, :3]

    @property
    def translation(self) -> np.ndarray:
        return self.matrix[:3, 3]

    def inverse(self) -> Transform:
        r = self.rotation
        m = np.eye(4)
        m[:3, :3] = r.T
        m[:3, 3] = -r.T @ self.translation
        return Transform._trusted(m, self.from_frame, self.to_frame)

    def __matmul__(self, other: Transform) -> Transform:
        if not isinstance(other, Transform):
            return NotImplemented
        if self.from_frame != other.to_frame:
            raise FrameError(
                f"cannot compose {self.name} @ {other.name}: frame '{self.from_frame}' "
                f"does not chain with '{other.to_frame}'"
            )
        # The product of two checked rigid transforms is rigid (to rounding): not checked again.
        return Transform._trusted(self.matrix @ other.matrix, self.to_frame, other.from_frame)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform points.

        Parameters
        ----------
        points : (..., 3) float
            Points in ``from_frame``.

        Returns
        -------
        (..., 3) same dtype as ``points`` (float64 for integer input), in ``to_frame``.
        """
        p = np.asarray(points)
        if p.shape[-1] != 3:
            raise InputError(f"points must have shape (..., 3), got {p.shape}")
        dtype = p.dtype if np.issubdtype(p.dtype, np.floating) else np.float64
        r = self.rotation.astype(dtype)
        t = self.translation.astype(dtype)
        return p @ r.T + t

    def apply_vectors(self, vectors: np.ndarray) -> np.ndarray:
        """Rotate direction vectors (no translation)."""
        v = np.asarray(vectors)
        return v @ self.rotation.T.astype(v.dtype if np.issubdtype(v.dtype, np.floating) else np.float64)


def camera_mount(
    height_m: float, pitch_down_rad: float, *, forward_m: float = 0.0, roll_rad: float = 0.0
) -> Transform:
    """``T_body_camera`` of a camera looking forward, pitched down by ``pitch_down_rad``.

    The camera centre sits ``height_m`` above the body origin and ``forward_m`` ahead.
    A positive pitch about body y tips the optical axis toward the ground.
    """
    r = rot_y(pitch_down_rad) @ rot_x(roll_rad) @ R_BODY_OPTICAL
    return Transform.from_rt(r, [forward_m, 0.0, height_m], "body", "camera")


def yaw_from_body(roll: float, pitch: float) -> Transform:
    """``T_yaw_body``: removes the body's roll and pitch (the paper's Psi frame).

    With ``R_world_body = Rz(yaw) Ry(pitch) Rx(roll)`` and ``R_world_yaw = Rz(yaw)``,
    ``R_yaw_body = Ry(pitch) Rx(roll)``; both frames share their origin.
    """
    return Transform.from_rt(rot_y(pitch) @ rot_x(roll), np.zeros(3), "yaw", "body")


@dataclass(frozen=True)
class Rig:
    """Mounting of the stereo pair on the robot (the rig file of CONVENTIONS.md).

    Attributes
    ----------
    T_body_camera : Transform
        Raw (unrectified) left camera in the body frame.
    body_rpy : (3,) float64, radians
        Roll, pitch, yaw of the body w.r.t. gravity; only roll and pitch are used for the
        yaw frame.
    """

    T_body_camera: Transform
    body_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.T_body_camera.to_frame != "body" or self.T_body_camera.from_frame != "camera":
            raise FrameError(f"rig needs T_body_camera, got {self.T_body_camera.name}")
        rpy = tuple(float(v) for v in self.body_rpy)
        if len(rpy) != 3 or not all(math.isfinite(v) for v in rpy):
            raise InputError(f"body_rpy must be 3 finite angles in radians, got {self.body_rpy}")
        object.__setattr__(self, "body_rpy", rpy)

    @property
    def T_yaw_camera(self) -> Transform:
        """The paper's eq. (1) without the yaw and position: camera -> gravity-aligned body."""
        return yaw_from_body(self.body_rpy[0], self.body_rpy[1]) @ self.T_body_camera


#: A rig translation longer than this (metres) is taken for millimetres.
MAX_RIG_TRANSLATION_M = 5.0


#: The keys of a rig file (CONVENTIONS.md): the mounting and the body's attitude.
RIG_KEYS = ("T_body_camera", "body_rpy")


def load_rig(path: str | Path) -> Rig:
    """Read a rig YAML file (``T_body_camera`` 4x4 nested list, metres; optional ``body_rpy``).

    Raises :class:`InputError` for a file that is missing, not UTF-8 YAML, not a mapping
    with ``T_body_camera``, has a key other than :data:`RIG_KEYS`, is not rigid, or whose
    translation is longer than :data:`MAX_RIG_TRANSLATION_M` (millimetres instead of
    metres).
    """
    from .checks import load_yaml_file

    path = Path(path)
    data = load_yaml_file(path, "rig file")
    if not isinstance(data, dict) or "T_body_camera" not in data:
        raise InputError(f"rig file {path} must be a mapping with key 'T_body_camera' (4x4 list)")
    unknown = sorted(str(k) for k in data if k not in RIG_KEYS)
    if unknown:  # a misspelt body_rpy would otherwise be a level body, silently
        raise InputError(
            f"rig file {path}: unknown key(s) {', '.join(unknown)}; the keys are {', '.join(RIG_KEYS)}"
        )
    try:
        m = np.array(data["T_body_camera"], dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"rig file {path}: T_body_camera must be a 4x4 list of numbers") from None
    try:
        T = Transform(m, "body", "camera")
        t = float(np.linalg.norm(T.translation))
        if t > MAX_RIG_TRANSLATION_M:
            raise InputError(
                f"rig file {path}: T_body_camera puts the camera {t:.3g} m from the body origin; "
                "the translation must be in metres, not millimetres"
            )
        rpy = data.get("body_rpy", [0.0, 0.0, 0.0])
        rpy_arr = np.array(rpy, dtype=np.float64).reshape(-1)
        if rpy_arr.shape != (3,):
            raise InputError(f"rig file {path}: body_rpy must be [roll, pitch, yaw] in radians")
        if not np.all(np.abs(rpy_arr) <= 2 * math.pi):
            raise InputError(
                f"rig file {path}: body_rpy must be 3 finite angles in radians (within +-2 pi), "
                f"got {rpy_arr.tolist()}"
            )
        return Rig(T, tuple(rpy_arr))  # type: ignore[arg-type]
    except InputError as exc:
        if str(path) in str(exc):
            raise
        raise type(exc)(f"rig file {path}: {exc}") from None
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(f"rig file {path}: {exc}") from None


def save_rig(rig: Rig, path: str | Path) -> None:
    """Write a rig YAML file readable by :func:`load_rig`."""
    data = {
        "T_body_camera": [[float(v) for v in row] for row in rig.T_body_camera.matrix],
        "body_rpy": [float(v) for v in rig.body_rpy],
    }
    Path(path).write_text(yaml.safe_dump(data, sort_keys=False))
