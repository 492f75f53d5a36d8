"""The realistic profile of :func:`random_scene_spec`: webcam photos of real stairs (a level
camera, side walls, handrails, wood and paint, strong distortion, JPEG), and the OAK-D
Lite overrides of it."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, cast

import numpy as np

from ...errors import InputError
from ..camera import _project, _rig
from ..geometry import _cast, _scene_geometry
from ..spec import (
    _GROUPS,
    BoxSpec,
    CameraIntrinsics,
    SceneSpec,
    StairSpec,
    SurfaceSpec,
    _obstacle_centre_b,
    _obstacle_far_end,
)
from .draws import (
    _KINDS,
    _invertible_camera,
    _paint,
    _placement_error,
    _random_box,
    _random_stairs,
    _right_rotvec,
    _split_overrides,
)

#: Materials of a realistic staircase: (tread, riser) kinds, and their probabilities.
_REALISTIC_MATERIALS = {
    "wood": 0.35,  # treads and risers of the same boards, horizontal grain
    "painted": 0.3,  # everything painted, near uniform (the Middlebury staircase)
    "wood_painted": 0.25,  # wooden treads, painted risers
    "carpet": 0.1,  # carpeted treads and risers
}
#: Materials with painted (weakly textured) risers: ``weak_texture`` in the spec.
_WEAK_MATERIALS = ("painted", "wood_painted")


def oakd_overrides(rng: np.random.Generator) -> dict:
    """Overrides of the realistic profile (``random_scene_spec(..., **overrides)``) for an
    OAK-D Lite held 0.5-1.4 m above the floor: its sensor, both images alike (Gaussian
    noise of 1-2 grey levels with a small shot part, 0.2-0.5 px of blur, no JPEG) instead
    of a cheap webcam's (1.5-3.5 grey, 0.5-1.5 px, JPEG 60-85). Draws three numbers from
    ``rng`` (``benchmarks/bench_far_stairs.py --oakd``)."""
    noise, blur = float(rng.uniform(1.0, 2.0)), float(rng.uniform(0.2, 0.5))
    return {
        "camera_height_m": float(rng.uniform(0.5, 1.4)),
        "noise_sigma": (noise, noise),
        "shot_noise": 0.01,
        "blur_sigma_px": blur,
        "right_blur_sigma_px": blur,
        "jpeg_quality": None,
    }


def _random_webcam(
    rng: np.random.Generator, size: tuple[int, int], like: CameraIntrinsics | None = None
) -> CameraIntrinsics:
    """A cheap webcam: wide angle, non-square pixels, strong barrel distortion."""
    w, h = size

    def draw() -> CameraIntrinsics:
        if like is None:
            fx = rng.uniform(0.7, 0.9) * w
            fy = fx * rng.uniform(0.92, 1.0)
            cx = (w - 1) / 2.0 + rng.uniform(-6.0, 6.0) * w / 640
            cy = (h - 1) / 2.0 + rng.uniform(-6.0, 6.0) * w / 640
            k1 = rng.uniform(-0.45, -0.1)
            k2 = rng.uniform(0.0, 0.45)
        else:  # the same model, another unit
            fx = like.fx * (1.0 + rng.uniform(-0.015, 0.015))
            fy = fx * float(np.clip(like.fy / like.fx + rng.uniform(-0.005, 0.005), 0.92, 1.0))
            cx = like.cx + rng.uniform(-5.0, 5.0) * w / 640
            cy = like.cy + rng.uniform(-5.0, 5.0) * w / 640
            k1 = float(np.clip(like.distortion[0] + rng.uniform(-0.03, 0.03), -0.45, -0.1))
            k2 = float(np.clip(like.distortion[1] + rng.uniform(-0.03, 0.03), 0.0, 0.45))
        p1, p2 = rng.uniform(-1e-3, 1e-3, 2)
        return CameraIntrinsics(fx, fy, cx, cy, (float(k1), float(k2), float(p1), float(p2), 0.0))

    return _invertible_camera(draw, size, tries=200)


def _visible(spec: SceneSpec, pts: np.ndarray, margin: float = 0.04) -> bool:
    """True when every yaw-frame point of ``pts`` (N, 3) projects into the left image with a
    margin and nothing (a side wall, a rail) hides it from the left camera."""
    T_yaw_cam = _rig(spec).T_yaw_camera
    uv = _project(T_yaw_cam.inverse().apply(pts), cast(CameraIntrinsics, spec.left_camera))
    w, h = spec.image_size
    mu, mv = margin * w, margin * h
    if not np.all((uv[:, 0] >= mu) & (uv[:, 0] <= w - 1 - mu) & (uv[:, 1] >= mv) & (uv[:, 1] <= h - 1 - mv)):
        return False
    origin = T_yaw_cam.translation
    d = (pts - origin).astype(np.float32)
    t, _ = _cast(origin, d[:, 0], d[:, 1], d[:, 2], _scene_geometry(spec))
    return bool(np.all(t > 0.99))  # t = 1 at the point: hidden if something is nearer


def _below_view(spec: SceneSpec, pts: np.ndarray) -> bool:
    """True when every yaw-frame point of ``pts`` projects below the left image."""
    uv = _project(_rig(spec).T_yaw_camera.inverse().apply(pts), cast(CameraIntrinsics, spec.left_camera))
    return bool(np.all(uv[:, 1] > spec.image_size[1] - 1))


def _stairs_points(ob: StairSpec | BoxSpec, *, floor_edge: bool) -> np.ndarray:
    """Yaw-frame points that must be seen: the first riser (bottom edge centre and +-35 %
    of the width, or with ``floor_edge`` False its upper part) and the first tread's
    centre (a box: its top's centre), pulled 5 mm toward the camera off the faces."""
    c, s = math.cos(ob.yaw_rad), math.sin(ob.yaw_rad)
    s0 = ob.distance_m * c
    rise = ob.rise_m if isinstance(ob, StairSpec) else ob.height_m
    run = ob.run_m if isinstance(ob, StairSpec) else ob.depth_m
    b_mid = _obstacle_centre_b(ob)
    z_edge = 0.0 if floor_edge else 0.75 * rise
    eps = 0.005
    local = np.array(
        [
            [s0 - eps, b_mid, z_edge + eps],
            [s0 - eps, b_mid - 0.35 * ob.width_m, z_edge + eps],
            [s0 - eps, b_mid + 0.35 * ob.width_m, z_edge + eps],
            [s0 + 0.5 * run, b_mid, rise + eps],
        ]
    )
    return np.stack(
        [c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1], local[:, 2]], axis=1
    )


def _realistic_surfaces(rng: np.random.Generator, material: str) -> dict[str, SurfaceSpec]:
    """Tread, riser, stair side, wall, rail and ground surfaces of a realistic scene."""
    planks = SurfaceSpec("planks", float(rng.uniform(0.6, 1.2)), float(rng.uniform(0.3, 0.6)), 0.25)
    paint = SurfaceSpec("paint", float(rng.uniform(1.0, 3.0)), float(rng.uniform(0.6, 0.9)), 0.02)
    carpet = SurfaceSpec("carpet", float(rng.uniform(0.4, 1.0)), float(rng.uniform(0.3, 0.6)), 0.15)
    tread, riser = {
        "wood": (planks, planks),
        "painted": (dataclasses.replace(paint, texture=str(rng.choice(["paint", "noise"]))), paint),
        "wood_painted": (planks, paint),
        "carpet": (carpet, carpet),
    }[material]
    ground_kind = str(rng.choice(["planks", "tiles", "carpet", "noise"], p=[0.4, 0.2, 0.2, 0.2]))
    ground = SurfaceSpec(
        ground_kind,
        float(rng.uniform(0.8, 1.6)),
        float(rng.uniform(0.3, 0.6)),
        0.2 if ground_kind != "noise" else 0.05,
    )
    wall = SurfaceSpec("paint", float(rng.uniform(1.5, 4.0)), float(rng.uniform(0.6, 0.9)), 0.02)
    rail_kind = str(rng.choice(["paint", "planks"]))
    rail = SurfaceSpec(rail_kind, 0.5, float(rng.uniform(0.3, 0.9)), 0.05)
    side = dataclasses.replace(wall, albedo=float(rng.uniform(0.55, 0.9)))
    return {"tread": tread, "riser": riser, "side": side, "wall": wall, "rail": rail, "ground": ground}


def _random_realistic_spec(
    rng: np.random.Generator,
    size: tuple[int, int],
    kind: str | None,
    weak_texture: bool | None,
    overrides: dict,
) -> SceneSpec:
    """The realistic profile of :func:`random_scene_spec`: webcam photos of real stairs.

    Draws (all from ``rng``):

    * kind: stairs 80 %, a box 10 %, nothing 10 % (a corridor: floor, two side walls and
      a back wall 3-8 m ahead), unless ``kind`` is given;
    * a roughly level camera: ``pitch_down`` -5..+10 deg, body roll and pitch within
      +-3 and +-1.5 deg (in the rig), first riser (box front) 0.8-2.0 m ahead
      (``distance_m``), height 0.25-0.7 m such that the riser's foot is seen 65-95 % of
      the half field of view below the image centre (little floor in view); 20 % of the
      staircases fill the view: seen from 0.8-1.0 m, yaw within +-20 deg, 1.0-1.6 m wide,
      pitch -5..+3 deg, the first riser's foot (and the floor before it) below the image;
    * stairs: yaw +-45 deg, lateral offset +-0.3 m, 2-6 steps, rise 0.12-0.22 m, run
      0.22-0.35 m, width 0.8-1.6 m, a landing of 0.8-1.5 m and a back wall 0-0.3 m beyond
      it (with 4-6 steps the top is usually above the cameras);
    * side walls 1.5-2.5 m high parallel to the stair axis, 0-5 cm beside the stairs: both
      (35 %), left or right only (25 % each), none (15 %); they start at the first riser,
      or up to 1.2 m before it when both cameras stand between them; a handrail on each
      side with probability 0.5 (along the wall, or over the stair's edge on balusters
      on a side without a wall);
    * materials (:data:`_REALISTIC_MATERIALS`): wooden boards with horizontal grain and
      dark gaps, near-uniform paint, wooden treads over painted risers, or carpet;
      treads and risers often of the same material; dark (or light) nosing strips
      2-5 cm deep on 45 % of the staircases; painted walls; floors of boards, tiles,
      carpet or plain concrete;
    * webcam optics (:func:`_random_webcam`): ``fx`` 0.7-0.9 x width, ``fy / fx``
      0.92-1.0, principal point within 6 px (at 640 px) of the centre, ``k1`` -0.45..-0.1,
      ``k2`` 0..0.45 (invertible over the image), the right camera a slightly different
      unit; a relative rotation of 0.3-2 deg;
    * sensor: noise 1.5-3.5 grey levels plus shot noise (0.02-0.1 x grey), blur 0.5-1.5
      px (each camera its own), vignetting 0.15-0.4, right gain 0.8-1.2 and offset +-12 grey levels, JPEG
      quality 60-85 for each camera;
    * indoor light: strong ambient (0.5-0.75), weak directional part (0.2-0.45).

    Every staircase's first riser (bottom edge at the centre and +-35 % of the width, or
    its upper part when the stairs fill the view) and first tread, and a box's front and
    top, are in view of the left camera and not hidden by walls or rails; the geometry
    is redrawn until they are.
    """
    if kind is None:
        kind = str(rng.choice(_KINDS, p=[0.8, 0.1, 0.1]))
    if kind not in _KINDS:
        raise InputError(f"kind must be one of {_KINDS} or None, got {kind!r}")
    ob_over, sc_over = _split_overrides(kind, overrides)
    mats = tuple(_REALISTIC_MATERIALS)
    probs = np.array([_REALISTIC_MATERIALS[m] for m in mats])
    if weak_texture is not None:
        probs = probs * np.array([(m in _WEAK_MATERIALS) == bool(weak_texture) for m in mats])
    material = str(rng.choice(mats, p=probs / probs.sum()))
    weak = material in _WEAK_MATERIALS

    left = _random_webcam(rng, size)
    right = _random_webcam(rng, size, like=left)
    rotvec = _right_rotvec(rng)
    q = int(rng.integers(60, 86))
    q_right = int(np.clip(q + rng.integers(-5, 6), 60, 85))
    surfaces = _realistic_surfaces(rng, material)
    nosing = kind == "stairs" and rng.random() < 0.45
    appearance: dict[str, Any] = {
        "seed": int(rng.integers(0, 2**31 - 1)),
        "left_camera": left,
        "right_camera": right,
        "right_rotvec_rad": rotvec,
        "right_offset_m": tuple(float(v) for v in rng.uniform(-1e-3, 1e-3, 2)),
        **surfaces,
        "nosing_m": float(rng.uniform(0.02, 0.05)) if nosing else 0.0,
        # Mostly dark strips (rubber, stained wood), sometimes light (aluminium, tape).
        "nosing_reflectance": float(rng.uniform(0.25, 0.5) if rng.random() < 0.8 else rng.uniform(1.3, 1.6)),
        "light_azimuth_rad": float(rng.uniform(-math.pi, math.pi)),
        "light_elevation_rad": math.radians(rng.uniform(40.0, 85.0)),
        "ambient": float(rng.uniform(0.5, 0.75)),
        "diffuse": float(rng.uniform(0.2, 0.45)),
        "exposure": float(rng.uniform(90.0, 150.0)),  # target ground grey
        "sky_grey": float(rng.uniform(170.0, 250.0)),  # the ceiling, over the walls
        "noise_sigma": tuple(float(v) for v in rng.uniform(1.5, 3.5, 2)),
        "shot_noise": float(rng.uniform(0.02, 0.1)),
        "right_gain": float(rng.uniform(0.8, 1.2)),
        "right_offset_grey": float(rng.uniform(-12.0, 12.0)),
        "vignetting": float(rng.uniform(0.15, 0.4)),
        "blur_sigma_px": float(rng.uniform(0.5, 1.5)),
        "right_blur_sigma_px": float(rng.uniform(0.5, 1.5)),
        "jpeg_quality": (q, q_right),
    }
    ground_shade = appearance["ambient"] + appearance["diffuse"] * math.sin(appearance["light_elevation_rad"])
    appearance["exposure"] = min(appearance["exposure"] / (appearance["ground"].albedo * ground_shade), 600.0)
    weak_levels = rng.uniform(1.0, 3.0, len(_GROUPS))
    floor_levels = rng.uniform(4.0, 8.0, len(_GROUPS))

    spec = None
    # Stairs that fill the view: close, nearly square on, the first riser's foot (and the
    # floor before it) below the image.
    fill = kind == "stairs" and "distance_m" not in ob_over and rng.random() < 0.2
    for _ in range(300):
        max_yaw = 20.0 if fill else 45.0 if kind == "stairs" else 25.0
        yaw = math.radians(rng.uniform(-max_yaw, max_yaw))
        lateral = float(rng.uniform(-0.3, 0.3))
        distance = float(rng.uniform(0.8, 1.0) if fill else rng.uniform(0.8, 2.0))
        ob: StairSpec | BoxSpec | None
        if kind == "stairs":
            ob = _random_stairs(
                rng, distance, yaw, lateral, ob_over,
                max_steps=7, rise_m=(0.12, 0.22), run_m=(0.22, 0.35),
                width_m=(1.0, 1.6) if fill else (0.8, 1.6), landing_m=(0.8, 1.5),
            )  # fmt: skip
        elif kind == "box":
            ob = _random_box(rng, distance, yaw, lateral, ob_over)
        else:
            ob = None
        pitch = math.radians(rng.uniform(-5.0, 3.0) if fill else rng.uniform(-5.0, 10.0))
        # Little floor in view: the first riser's foot is seen just above the bottom of
        # the image (angle below the horizon: pitch + 65-95 % of the half field of view),
        # or below it when the stairs fill the view; the height follows, within 0.25-0.7 m.
        half_fov = math.atan((size[1] - 1 - left.cy) / left.fy)
        depression = pitch + half_fov * (rng.uniform(1.05, 1.4) if fill else rng.uniform(0.65, 0.95))
        foot = distance if ob is None else ob.distance_m * math.cos(ob.yaw_rad)
        height = float(np.clip(foot * math.tan(max(depression, 0.0)), 0.25, 0.7))
        geometry: dict[str, Any] = {
            "obstacle": ob,
            "camera_height_m": height,
            "pitch_down_rad": pitch,
            "baseline_m": float(rng.uniform(0.06, 0.12)),
            "body_rpy": (math.radians(rng.uniform(-3.0, 3.0)), math.radians(rng.uniform(-1.5, 1.5)), 0.0),
            **_realistic_walls(rng, ob),
        }
        values: dict[str, Any] = {**appearance, **geometry, "image_size": size, "weak_texture": weak}
        values["profile"] = "realistic"
        values.update(sc_over)
        candidate = SceneSpec(**values)
        ob = candidate.obstacle
        if ob is None or (
            _visible(candidate, _stairs_points(ob, floor_edge=not fill))
            and (not fill or _below_view(candidate, _stairs_points(ob, floor_edge=True)[:1]))
        ):
            spec = candidate
            break
    if spec is None:
        raise _placement_error(overrides)
    weak_groups = ("wall", "side", "rail") + (("riser",) if weak else ())
    if material == "painted":
        weak_groups += ("tread",)
    if spec.ground.texture == "noise":
        weak_groups += ("ground",)
    return _paint(spec, weak_groups, weak_levels, floor_levels, sc_over)


def _realistic_walls(rng: np.random.Generator, ob: StairSpec | BoxSpec | None) -> dict[str, Any]:
    """Side walls, back wall and handrails of a realistic scene (SceneSpec fields)."""
    height = float(rng.uniform(1.5, 2.5))
    if ob is None:  # a corridor or a room
        return {
            "left_wall_m": float(rng.uniform(0.5, 1.5)),
            "right_wall_m": -float(rng.uniform(0.5, 1.5)),
            "side_wall_height_m": height,
            "side_wall_start_m": -3.0,
            "back_wall_m": float(rng.uniform(3.0, 8.0)),
        }
    b_mid = _obstacle_centre_b(ob)
    b_lo, b_hi = b_mid - ob.width_m / 2, b_mid + ob.width_m / 2
    s0 = ob.distance_m * math.cos(ob.yaw_rad)
    end = _obstacle_far_end(ob)
    if isinstance(ob, StairSpec):
        sides = str(rng.choice(["both", "left", "right", "none"], p=[0.35, 0.25, 0.25, 0.15]))
        gap = rng.uniform(0.0, 0.05, 2)
        back = end + float(rng.uniform(0.0, 0.3)) + 1e-3
    else:
        sides = str(rng.choice(["both", "left", "right", "none"], p=[0.2, 0.2, 0.2, 0.4]))
        gap = rng.uniform(0.3, 1.5, 2)
        back = end + float(rng.uniform(1.0, 4.0))
    left = b_hi + float(gap[0]) if sides in ("both", "left") else None
    right = b_lo - float(gap[1]) if sides in ("both", "right") else None
    # Walls may reach back past the cameras only when both stand between them with a
    # 0.15 m margin (the left camera at a = b = 0, the right one within 0.12 m to its right).
    between = (left is None or left > 0.15) and (right is None or right < -0.27)
    extra = float(rng.uniform(0.0, 1.2)) if between and (left is not None or right is not None) else 0.0
    out: dict[str, Any] = {
        "left_wall_m": left,
        "right_wall_m": right,
        "side_wall_height_m": height,
        "side_wall_start_m": s0 - extra,
        "back_wall_m": back,
    }
    if isinstance(ob, StairSpec) and ob.n_steps >= 2:
        rails = tuple(side for side in ("left", "right") if rng.random() < 0.5)
        out["handrails"] = rails
        # A rail over an open side stands on balusters (one without would float).
        walls = {"left": left, "right": right}
        out["balusters"] = any(walls[side] is None for side in rails)
        out["handrail_height_m"] = float(rng.uniform(0.8, 1.0))
    return out
