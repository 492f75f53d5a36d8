"""An exact disparity map of a ground plane and one step, for unit tests of later stages."""

from __future__ import annotations

import numpy as np

from stereo_terrain.calibration import StereoCalibration
from stereo_terrain.frames import Rig, Transform, camera_mount
from stereo_terrain.rectify import compute_rectification
from stereo_terrain.stereo import DisparityMap

F_PX, B_M, SIZE = 500.0, 0.08, (640, 480)


def rectified_calibration() -> StereoCalibration:
    K = np.array([[F_PX, 0, 320.0], [0, F_PX, 240.0], [0, 0, 1]])
    return StereoCalibration(
        K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-B_M, 0, 0]), SIZE, rectified=True
    )


def step_scene(height=0.6, pitch_deg=20.0, riser_x=1.4, rise=0.18):
    """Disparity (H, W) of: ground z = 0, a riser x = riser_x (0 < z < rise), a tread
    z = rise beyond it; camera ``height`` m up, pitched down. Returns (DisparityMap,
    T_yaw_camera_rect)."""
    rect = compute_rectification(rectified_calibration())
    T = Rig(camera_mount(height, np.radians(pitch_deg))).T_yaw_camera @ Transform(
        np.eye(4), "camera", "camera_rect"
    )
    w, h = SIZE
    u, v = np.meshgrid(np.arange(w), np.arange(h))
    rays = np.stack([(u - 320.0) / F_PX, (v - 240.0) / F_PX, np.ones_like(u, float)], -1)
    d = rays @ T.rotation.T  # direction in yaw frame per unit camera depth
    o = T.translation
    t = np.full(u.shape, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        tg = -o[2] / d[..., 2]  # ground
        x = o[0] + tg * d[..., 0]
        t = np.where((tg > 0) & (x < riser_x), tg, t)
        tr = (riser_x - o[0]) / d[..., 0]  # riser
        z = o[2] + tr * d[..., 2]
        t = np.where((tr > 0) & (z >= 0) & (z <= rise) & (tr < t), tr, t)
        tt = (rise - o[2]) / d[..., 2]  # tread
        x = o[0] + tt * d[..., 0]
        t = np.where((tt > 0) & (x >= riser_x) & (tt < t), tt, t)
    disp = (F_PX * B_M / t).astype(np.float32)  # t is the camera depth Z
    disp[~np.isfinite(t) | (disp < 1)] = np.nan
    return DisparityMap(disp, 64, rect), T
