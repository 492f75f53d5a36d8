"""Rendering a :class:`SceneSpec`: both views, sensor, calibration, rig and ground truth."""

from __future__ import annotations

import dataclasses
import json
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from ..calibration import StereoCalibration
from ..errors import InputError
from ..frames import Rig, Transform
from .appearance import _Appearance, _appearance, _shade
from .camera import _rig, _rotation, _stereo_geometry, _undistort
from .geometry import _FACE_BOX0, _FACE_GROUND, _FACE_WALL, _cast, _Geometry, _scene_geometry
from .sensor import _sensor
from .spec import CameraIntrinsics, SceneSpec, StairSpec, _side_wall_span


@dataclass(frozen=True)
class SyntheticScene:
    """A rendered scene: raw stereo pair, its calibration and rig, and the ground truth.

    Attributes
    ----------
    spec : SceneSpec
    left, right : (H, W) uint8
        Raw (unrectified, distorted) grey images.
    calibration : StereoCalibration
        Exact intrinsics, distortion and ``R, T`` (``X_right = R X_left + T``, metres).
    rig : Rig
        ``T_body_camera`` of the raw left camera and ``body_rpy``.
    truth : dict
        JSON-serialisable terrain result (CONVENTIONS.md keys), see :func:`render_scene`.
    depth_left : (H, W) float32, metres
        Z of the surface hit by each left pixel centre's ray, raw left camera frame; NaN
        where nothing is hit.
    labels_left : (H, W) int16
        Index into ``truth["planes"]`` of the surface hit by each left pixel centre; -1
        for nothing (sky) and for faces not listed there (stair/box sides and backs, the
        ends and tops of side walls, handrails and balusters).
    """

    spec: SceneSpec
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    calibration: StereoCalibration = field(repr=False)
    rig: Rig = field(repr=False)
    truth: dict = field(repr=False)
    depth_left: np.ndarray = field(repr=False)
    labels_left: np.ndarray = field(repr=False)


def _render_view(
    cam: CameraIntrinsics,
    R_yaw_cam: np.ndarray,
    origin: np.ndarray,
    spec: SceneSpec,
    geom: _Geometry,
    app: _Appearance,
    *,
    want_truth: bool,
):
    """Radiance image (H, W) float32 of one camera, and (t, face) of its pixel centres."""
    w, h = spec.image_size
    ss = spec.supersample
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    x, y, j00, j01, j10, j11 = _undistort(uu.ravel(), vv.ravel(), cam)
    R = R_yaw_cam.astype(np.float64)
    centre = None
    if want_truth:
        dxc = R[0, 0] * x + R[0, 1] * y + R[0, 2]
        dyc = R[1, 0] * x + R[1, 1] * y + R[1, 2]
        dzc = R[2, 0] * x + R[2, 1] * y + R[2, 2]
        centre = _cast(origin, dxc.astype(np.float32), dyc.astype(np.float32), dzc.astype(np.float32), geom)
    # Sub-pixel samples on a regular ss x ss grid inside each pixel, placed through the
    # local inverse of the distortion (second-order error ~1e-7 px).
    offs = (np.arange(ss) + 0.5) / ss - 0.5
    ou, ov = np.meshgrid(offs, offs)
    eu = (ou.ravel() / cam.fx).astype(np.float32)[None, :]
    ev = (ov.ravel() / cam.fy).astype(np.float32)[None, :]
    x32, y32 = x.astype(np.float32)[:, None], y.astype(np.float32)[:, None]
    j00, j01, j10, j11 = (j.astype(np.float32)[:, None] for j in (j00, j01, j10, j11))
    xs = (x32 + j00 * eu + j01 * ev).ravel()
    ys = (y32 + j10 * eu + j11 * ev).ravel()
    Rf = R.astype(np.float32)
    dx = Rf[0, 0] * xs + Rf[0, 1] * ys + Rf[0, 2]
    dy = Rf[1, 0] * xs + Rf[1, 1] * ys + Rf[1, 2]
    dz = Rf[2, 0] * xs + Rf[2, 1] * ys + Rf[2, 2]
    del xs, ys
    t, face = _cast(origin, dx, dy, dz, geom)
    rad = _shade(origin, dx, dy, dz, t, face, geom, app, 0.5 * (cam.fx + cam.fy), ss)
    img = rad.reshape(h * w, ss * ss).mean(axis=1).reshape(h, w)
    return img, centre


def _truth(spec: SceneSpec, T_yaw_camera: Transform) -> dict:
    ob = spec.obstacle
    ground = {"normal": [0.0, 0.0, 1.0], "offset": 0.0, "kind": "horizontal", "name": "ground"}
    planes: list[dict] = [ground]
    steps: list[dict] = []
    yaw = None
    kind = "none"
    if ob is not None:
        yaw = float(ob.yaw_rad)
        c, s = math.cos(ob.yaw_rad), math.sin(ob.yaw_rad)
        s0 = ob.distance_m * c
        toward = [-c, -s, 0.0]  # riser normals point toward the camera (-u)
        if isinstance(ob, StairSpec):
            kind = "stairs"
            n, rise, run = ob.n_steps, ob.rise_m, ob.run_m
        else:
            kind = "box"
            n, rise, run = 1, ob.height_m, ob.depth_m
        for i in range(n):
            a_i = s0 + i * run
            top = n == 1 and kind == "box"
            steps.append(
                {
                    "rise": float(rise),
                    "run": float(run) if (i < n - 1 or top) else None,
                    "distance": float(a_i / c),
                    "width": float(ob.width_m),
                }
            )
            planes.append(
                {
                    "normal": [float(v) for v in toward],
                    "offset": float(a_i),
                    "kind": "vertical",
                    "name": f"riser_{i + 1}",
                }
            )
            planes.append(
                {
                    "normal": [0.0, 0.0, 1.0],
                    "offset": float(-(i + 1) * rise),
                    "kind": "horizontal",
                    "name": f"tread_{i + 1}",
                }
            )
    if spec.back_wall_m is not None:
        yw = 0.0 if ob is None else ob.yaw_rad
        planes.append(
            {
                "normal": [-math.cos(yw), -math.sin(yw), 0.0],
                "offset": float(spec.back_wall_m),
                "kind": "vertical",
                "name": "back_wall",
            }
        )
    # Side walls: normal toward the stairs (the camera), -v on the left, +v on the right.
    yw = 0.0 if ob is None else ob.yaw_rad
    v = (-math.sin(yw), math.cos(yw), 0.0)
    for side, b in (("left", spec.left_wall_m), ("right", spec.right_wall_m)):
        if b is None:
            continue
        sign = -1.0 if side == "left" else 1.0
        planes.append(
            {
                "normal": [sign * c + 0.0 for c in v],
                "offset": float(-sign * b) + 0.0,
                "kind": "vertical",
                "name": f"{side}_wall",
            }
        )
    return {
        "version": 1,
        "frame": "yaw",
        "obstacle": kind,
        "steps": steps,
        "yaw": yaw,
        "planes": planes,
        "camera_height_m": float(spec.camera_height_m),
        "camera_center_yaw": [float(v) for v in T_yaw_camera.translation],
        "pitch_down_rad": float(spec.pitch_down_rad),
        "body_rpy": [float(v) for v in spec.body_rpy],
        "weak_texture": bool(spec.weak_texture),
        "image_size": [int(v) for v in spec.image_size],
        "seed": int(spec.seed),
        "profile": spec.profile,
        "spec": _spec_to_json(spec),
    }


def _spec_to_json(spec: SceneSpec) -> dict:
    d = dataclasses.asdict(spec)
    ob = spec.obstacle
    d["obstacle"] = None if ob is None else {"type": type(ob).__name__, **dataclasses.asdict(ob)}
    return json.loads(json.dumps(d))  # tuples -> lists


def _labels_table(spec: SceneSpec, geom: _Geometry, n_faces: int) -> np.ndarray:
    """Face id -> index into truth['planes'] (-1 where the face is not listed).

    The planes are ground, riser/tread of each obstacle box, back wall, left and right
    wall (each only when present), in the order of :func:`_truth`.
    """
    table = np.full(n_faces, -1, dtype=np.int16)
    table[_FACE_GROUND] = 0
    n_boxes = geom.n_obstacle_boxes
    for i in range(n_boxes):
        table[_FACE_BOX0 + 6 * i + 0] = 1 + 2 * i  # riser_{i+1}
        table[_FACE_BOX0 + 6 * i + 5] = 2 + 2 * i  # tread_{i+1}
    nxt = 1 + 2 * n_boxes
    if spec.back_wall_m is not None:
        table[_FACE_WALL] = nxt
        nxt += 1
    for j, side in enumerate(geom.wall_sides):
        # The inner face: -v (k = 2) for the left wall, +v (k = 3) for the right one.
        table[_FACE_BOX0 + 6 * (n_boxes + j) + (2 if side == "left" else 3)] = nxt
        nxt += 1
    return table


def render_scene(spec: SceneSpec) -> SyntheticScene:
    """Render the raw stereo pair of ``spec`` with its calibration, rig and ground truth.

    Parameters
    ----------
    spec : SceneSpec

    Returns
    -------
    SyntheticScene
        ``truth`` holds ``version`` (1), ``frame`` ("yaw"), ``obstacle``, ``steps``
        (nearest first: ``rise``, ``run`` -- None for a staircase's top step, the landing
        --, ``distance`` on the frame's x axis, ``width``), ``yaw`` (None without
        obstacle), ``planes`` (``n . x + d = 0`` in the yaw frame, ``n`` up or toward the
        camera, named ``ground``, ``riser_i``, ``tread_i``, ``back_wall``, ``left_wall``,
        ``right_wall``; walls are never steps), the camera parameters, ``weak_texture``,
        ``image_size``, ``seed``, ``profile`` and the whole ``spec``.

    Raises
    ------
    InputError
        If the camera is inside the obstacle, below the ground or outside the side walls.

    Notes
    -----
    The two views are rendered on two threads; the result does not depend on it. About
    0.4-0.8 s for a 640 x 480 pair with 2 x 2 supersampling on two cores.
    """
    if not isinstance(spec, SceneSpec):
        raise InputError(f"render_scene needs a SceneSpec, got {type(spec).__name__}")
    rig = _rig(spec)
    T_yaw_left = rig.T_yaw_camera
    R, T, centre_right = _stereo_geometry(spec)
    origin_l = T_yaw_left.translation.copy()
    origin_r = T_yaw_left.apply(centre_right)
    geom = _scene_geometry(spec)
    for name, o in (("left", origin_l), ("right", origin_r)):
        if o[2] <= 1e-3:
            raise InputError(f"the {name} camera is at or below the ground (z = {o[2]:.3f} m)")
        oa, ob = geom.to_local(o[0], o[1])
        for box in geom.boxes:
            if box[0] <= oa <= box[1] and box[2] <= ob <= box[3] and o[2] <= box[5]:
                raise InputError(f"the {name} camera is inside the obstacle; move it back")
        a0, a1 = _side_wall_span(spec)
        if a0 <= oa <= a1 and (
            (spec.left_wall_m is not None and ob >= spec.left_wall_m)
            or (spec.right_wall_m is not None and ob <= spec.right_wall_m)
        ):
            raise InputError(f"the {name} camera is outside the side walls; move the walls apart")
    app = _appearance(spec, geom)
    # SceneSpec resolves None cameras in __post_init__.
    left_cam = cast(CameraIntrinsics, spec.left_camera)
    right_cam = cast(CameraIntrinsics, spec.right_camera)
    # A disturbed rig: the right camera turned about its own centre after calibration.
    # The images see the disturbed camera; the calibration below keeps R, T.
    R_seen = _rotation(spec.right_disturbance_rotvec_rad) @ R
    R_yaw_right = T_yaw_left.rotation @ R_seen.T
    # The two views are independent and numpy releases the GIL on large arrays: render
    # them side by side (deterministic: no shared random state).
    with ThreadPoolExecutor(max_workers=2) as pool:
        job_r = pool.submit(_render_view, right_cam, R_yaw_right, origin_r, spec, geom, app, want_truth=False)
        img_l, centre = _render_view(
            left_cam, T_yaw_left.rotation, origin_l, spec, geom, app, want_truth=True
        )
        img_r, _ = job_r.result()
    noise_key = [spec.seed, 3] if spec.noise_seed is None else [spec.seed, 3, spec.noise_seed]
    noise_rng = np.random.default_rng(noise_key)
    jpeg = spec.jpeg_quality or (None, None)
    left = _sensor(img_l, spec, left_cam, 1.0, 0.0, spec.noise_sigma[0], noise_rng, jpeg[0])
    right = _sensor(
        img_r,
        spec,
        right_cam,
        spec.right_gain,
        spec.right_offset_grey,
        spec.noise_sigma[1],
        noise_rng,
        jpeg[1],
        spec.right_blur_sigma_px,
    )
    w, h = spec.image_size
    t_c, face_c = cast(tuple[np.ndarray, np.ndarray], centre)
    depth = np.where(np.isfinite(t_c), t_c, np.nan).astype(np.float32).reshape(h, w)
    labels = _labels_table(spec, geom, len(app.group))[face_c].reshape(h, w)
    calib = StereoCalibration(
        left_cam.matrix,
        np.array(left_cam.distortion),
        right_cam.matrix,
        np.array(right_cam.distortion),
        R,
        T,
        spec.image_size,
        source=f"synthetic scene seed {spec.seed}",
    )
    for a in (left, right, depth, labels):
        a.setflags(write=False)
    return SyntheticScene(spec, left, right, calib, rig, _truth(spec, T_yaw_left), depth, labels)
