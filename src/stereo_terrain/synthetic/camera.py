"""Camera model: OpenCV lens distortion, its inverse, projection, the stereo rig."""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..errors import InputError
from ..frames import Rig, camera_mount
from .spec import CameraIntrinsics, SceneSpec

_NEWTON_TOL_PX = 1e-6
_NEWTON_MAX_ITER = 30


# --------------------------------------------------------------------------- lens model


def _distort(x: np.ndarray, y: np.ndarray, dist: tuple[float, ...]):
    """OpenCV distortion of normalized coordinates and its Jacobian.

    Returns ``(xd, yd, dxd_dx, dxd_dy, dyd_dx, dyd_dy)``.
    """
    k1, k2, p1, p2, k3 = dist
    x2, y2, xy = x * x, y * y, x * y
    r2 = x2 + y2
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    g = 2.0 * k1 + r2 * (4.0 * k2 + 6.0 * k3 * r2)  # d radial / d r2 * 2
    xd = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2)
    yd = y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy
    a = radial + g * x2 + 2.0 * p1 * y + 6.0 * p2 * x
    b = g * xy + 2.0 * p1 * x + 2.0 * p2 * y
    d = radial + g * y2 + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, a, b, b, d


def _undistort(u: np.ndarray, v: np.ndarray, cam: CameraIntrinsics):
    """Pixels -> undistorted normalized coordinates by Newton's method (float64).

    Returns ``(x, y, j00, j01, j10, j11)`` where ``j`` is the Jacobian of the undistorted
    coordinates w.r.t. the *distorted normalized* ones at the solution (to place sub-pixel
    samples to first order: an offset of 0.5 px changes them by ~1e-7 px).
    """
    xd = (u - cam.cx) / cam.fx
    yd = (v - cam.cy) / cam.fy
    x, y = xd.copy(), yd.copy()
    f = max(cam.fx, cam.fy)
    for _ in range(_NEWTON_MAX_ITER):
        fx_, fy_, a, b, c, d = _distort(x, y, cam.distortion)
        rx, ry = xd - fx_, yd - fy_
        det = a * d - b * c
        dx = (d * rx - b * ry) / det
        dy = (a * ry - c * rx) / det
        x += dx
        y += dy
        step = float(max(np.abs(dx).max(initial=0.0), np.abs(dy).max(initial=0.0))) * f
        if step < _NEWTON_TOL_PX:
            break
    else:  # pragma: no cover - excluded by _check_distortion_invertible
        raise InputError("undistortion did not converge; the lens distortion is too strong")
    _, _, a, b, c, d = _distort(x, y, cam.distortion)
    det = a * d - b * c
    return x, y, d / det, -b / det, -c / det, a / det


def _project(points_cam: np.ndarray, cam: CameraIntrinsics) -> np.ndarray:
    """(N, 3) camera-frame points -> (N, 2) pixels (NaN behind the camera)."""
    p = np.asarray(points_cam, dtype=np.float64)
    z = p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = p[:, 0] / z, p[:, 1] / z
    xd, yd, *_ = _distort(x, y, cam.distortion)
    uv = np.stack([cam.fx * xd + cam.cx, cam.fy * yd + cam.cy], axis=1)
    uv[~(z > 1e-6)] = np.nan
    return uv


def _rotation(rotvec: tuple[float, float, float]) -> np.ndarray:
    """(3, 3) rotation matrix of a Rodrigues vector (radians)."""
    R, _ = cv2.Rodrigues(np.array(rotvec, dtype=np.float64).reshape(3, 1))
    return R


def _stereo_geometry(spec: SceneSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``R, T`` (``X_right = R X_left + T``) and the right centre in the left frame."""
    R = _rotation(spec.right_rotvec_rad)
    oy, oz = spec.right_offset_m
    b = spec.baseline_m
    centre = np.array([math.sqrt(b * b - oy * oy - oz * oz), oy, oz])
    return R, -R @ centre, centre


def _rig(spec: SceneSpec) -> Rig:
    return Rig(camera_mount(spec.camera_height_m, spec.pitch_down_rad), spec.body_rpy)
