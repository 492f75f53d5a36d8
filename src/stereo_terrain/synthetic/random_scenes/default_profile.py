"""The default profile of :func:`random_scene_spec`: the scenes of version 1, unchanged (a
camera pitched down 0-30 deg over a textured floor, mild lens distortion)."""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np

from ...errors import InputError
from ..camera import _project, _rig
from ..spec import (
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

#: The face groups of version 1, painted by the default profile (it draws one contrast
#: per group: keeping their number keeps its scenes).
_DEFAULT_GROUPS = ("ground", "tread", "riser", "side", "wall")


def _surface(
    rng: np.random.Generator, kinds: tuple[str, ...], albedo: tuple[float, float], tile: tuple[float, float]
) -> SurfaceSpec:
    return SurfaceSpec(
        str(rng.choice(kinds)),
        float(rng.uniform(*tile)),
        float(rng.uniform(*albedo)),
        float(rng.uniform(0.1, 0.28)),
    )


def _random_camera(
    rng: np.random.Generator, size: tuple[int, int], like: CameraIntrinsics | None = None
) -> CameraIntrinsics:
    w, h = size

    def draw() -> CameraIntrinsics:
        if like is None:
            fx = rng.uniform(0.8, 0.9) * w
            fy = fx * (1.0 + rng.uniform(-0.002, 0.002))
            cx = (w - 1) / 2.0 + rng.uniform(-4.0, 4.0)
            cy = (h - 1) / 2.0 + rng.uniform(-4.0, 4.0)
            k1 = rng.uniform(-0.25, 0.05)
            k2 = rng.uniform(-0.02, 0.06)
        else:
            scale = 1.0 + rng.uniform(-0.01, 0.01)
            fx, fy = like.fx * scale, like.fy * scale * (1.0 + rng.uniform(-0.001, 0.001))
            cx = like.cx + rng.uniform(-5.0, 5.0)
            cy = like.cy + rng.uniform(-5.0, 5.0)
            k1 = float(np.clip(like.distortion[0] + rng.uniform(-0.04, 0.04), -0.25, 0.05))
            k2 = float(np.clip(like.distortion[1] + rng.uniform(-0.01, 0.01), -0.02, 0.06))
        p1, p2 = rng.uniform(-5e-4, 5e-4, 2)
        return CameraIntrinsics(fx, fy, cx, cy, (k1, k2, float(p1), float(p2), 0.0))

    return _invertible_camera(draw, size, tries=100)


def _in_view(spec: SceneSpec, margin: float = 0.04) -> bool:
    """True when the first riser's bottom edge and the top tread's front edge (centres)
    project into the left image with a margin."""
    ob = spec.obstacle
    if ob is None:
        return True
    c, s = math.cos(ob.yaw_rad), math.sin(ob.yaw_rad)
    s0 = ob.distance_m * c
    if isinstance(ob, StairSpec):
        a_top, z_top = s0 + (ob.n_steps - 1) * ob.run_m, ob.n_steps * ob.rise_m
    else:
        a_top, z_top = s0, ob.height_m
    b_mid = _obstacle_centre_b(ob)
    pts_local = np.array(
        [
            [s0, b_mid, 0.0],
            [a_top, b_mid, z_top],
            [s0, b_mid - 0.35 * ob.width_m, 0.0],
            [s0, b_mid + 0.35 * ob.width_m, 0.0],
        ]
    )
    pts = np.stack(
        [
            c * pts_local[:, 0] - s * pts_local[:, 1],
            s * pts_local[:, 0] + c * pts_local[:, 1],
            pts_local[:, 2],
        ],
        axis=1,
    )
    T_cam_yaw = _rig(spec).T_yaw_camera.inverse()
    uv = _project(T_cam_yaw.apply(pts), cast(CameraIntrinsics, spec.left_camera))
    w, h = spec.image_size
    mu, mv = margin * w, margin * h
    return bool(
        np.all((uv[:, 0] >= mu) & (uv[:, 0] <= w - 1 - mu) & (uv[:, 1] >= mv) & (uv[:, 1] <= h - 1 - mv))
    )


def _random_default_spec(
    rng: np.random.Generator,
    size: tuple[int, int],
    kind: str | None,
    weak_texture: bool | None,
    overrides: dict,
) -> SceneSpec:
    """The default profile of :func:`random_scene_spec` (its docstring says what it draws)."""
    if kind is None:
        kind = str(rng.choice(_KINDS, p=[0.7, 0.2, 0.1]))
    if kind not in _KINDS:
        raise InputError(f"kind must be one of {_KINDS} or None, got {kind!r}")
    weak = bool(rng.random() < 0.3) if weak_texture is None else bool(weak_texture)
    ob_over, sc_over = _split_overrides(kind, overrides)

    left = _random_camera(rng, size)
    right = _random_camera(rng, size, like=left)
    rotvec = _right_rotvec(rng)
    appearance: dict[str, Any] = {
        "seed": int(rng.integers(0, 2**31 - 1)),
        "left_camera": left,
        "right_camera": right,
        "right_rotvec_rad": rotvec,
        "right_offset_m": tuple(float(v) for v in rng.uniform(-1e-3, 1e-3, 2)),
        "ground": _surface(rng, ("noise", "carpet", "tiles", "speckle"), (0.3, 0.7), (0.6, 1.5)),
        "tread": _surface(rng, ("wood", "carpet", "noise", "speckle", "tiles"), (0.35, 0.85), (0.5, 1.2)),
        "riser": _surface(rng, ("noise", "wood", "speckle", "carpet"), (0.35, 0.85), (0.5, 1.2)),
        "side": _surface(rng, ("noise", "speckle"), (0.35, 0.8), (0.6, 1.2)),
        "wall": _surface(rng, ("noise", "speckle", "tiles"), (0.4, 0.85), (0.8, 2.0)),
        "light_azimuth_rad": float(rng.uniform(-math.pi, math.pi)),
        "light_elevation_rad": math.radians(rng.uniform(35.0, 75.0)),
        "ambient": float(rng.uniform(0.4, 0.6)),
        "diffuse": float(rng.uniform(0.35, 0.55)),
        "exposure": float(rng.uniform(95.0, 150.0)),  # target ground grey, see below
        "sky_grey": float(rng.uniform(150.0, 235.0)),
        "noise_sigma": tuple(float(v) for v in rng.uniform(1.0, 3.0, 2)),
        "right_gain": float(rng.uniform(0.85, 1.15)),
        "right_offset_grey": float(rng.uniform(-10.0, 10.0)),
        "vignetting": float(rng.uniform(0.05, 0.25)) if rng.random() < 0.6 else 0.0,
        "blur_sigma_px": float(rng.uniform(0.0, 0.6)),
    }
    # Auto exposure: the ground's nominal grey level is the drawn target.
    ground_shade = appearance["ambient"] + appearance["diffuse"] * math.sin(appearance["light_elevation_rad"])
    appearance["exposure"] = min(appearance["exposure"] / (appearance["ground"].albedo * ground_shade), 600.0)
    weak_tread = bool(rng.random() < 0.5)
    weak_levels = rng.uniform(0.5, 1.5, len(_DEFAULT_GROUPS))
    floor_levels = rng.uniform(6.0, 10.0, len(_DEFAULT_GROUPS))
    wall_draw = (bool(rng.random() < 0.5), float(rng.uniform(0.0, 1.0)))

    spec = None
    for _ in range(200):
        ob: StairSpec | BoxSpec | None
        yaw = math.radians(rng.uniform(-25.0, 25.0))
        lateral = float(rng.uniform(-0.2, 0.2))
        distance = float(rng.uniform(0.9, 2.0))
        if kind == "stairs":
            ob = _random_stairs(
                rng, distance, yaw, lateral, ob_over,
                max_steps=6, rise_m=(0.10, 0.22), run_m=(0.25, 0.35),
                width_m=(0.8, 1.6), landing_m=(0.6, 1.5),
            )  # fmt: skip
        elif kind == "box":
            ob = _random_box(rng, distance, yaw, lateral, ob_over)
        else:
            ob = None
        geometry: dict[str, Any] = {
            "obstacle": ob,
            "camera_height_m": float(rng.uniform(0.4, 0.8)),
            "pitch_down_rad": math.radians(rng.uniform(0.0, 30.0)),
            "baseline_m": float(rng.uniform(0.075, 0.085)),
            "body_rpy": (math.radians(rng.uniform(-3.0, 3.0)), math.radians(rng.uniform(-3.0, 3.0)), 0.0),
        }
        values: dict[str, Any] = {**appearance, **geometry, "image_size": size, "weak_texture": weak}
        values.update(sc_over)
        if "back_wall_m" not in sc_over:
            end = _obstacle_far_end(values["obstacle"])
            gap = {"stairs": 2.5, "box": 4.0, "none": 5.0}[kind] * wall_draw[1]
            lead = {"stairs": 0.0, "box": 1.5, "none": 3.0}[kind]
            values["back_wall_m"] = end + lead + gap + 1e-3 if wall_draw[0] else None
        candidate = SceneSpec(**values)
        if _in_view(candidate):
            spec = candidate
            break
    if spec is None:
        raise _placement_error(overrides)
    weak_groups = ("riser", "side") + (("tread",) if weak_tread else ()) if weak else ()
    return _paint(spec, weak_groups, weak_levels, floor_levels, sc_over, _DEFAULT_GROUPS)
