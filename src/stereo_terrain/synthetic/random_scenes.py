"""Random scene specs: geometry, cameras, textures, lighting and sensor drawn from an ``rng``."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, cast

import numpy as np

from ..errors import InputError
from .camera import _project, _rig
from .spec import (
    _GROUPS,
    BoxSpec,
    CameraIntrinsics,
    SceneSpec,
    StairSpec,
    SurfaceSpec,
    _check_distortion_invertible,
    _check_image_size,
    _obstacle_centre_b,
    _obstacle_far_end,
)


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
    for _ in range(100):
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
        cam = CameraIntrinsics(fx, fy, cx, cy, (k1, k2, float(p1), float(p2), 0.0))
        try:
            _check_distortion_invertible(cam, size, "camera")
        except InputError:
            continue
        return cam
    raise InputError("could not draw an invertible lens distortion")  # pragma: no cover


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


_KINDS = ("stairs", "box", "none")


def random_scene_spec(
    rng: np.random.Generator,
    *,
    image_size: tuple[int, int] = (640, 480),
    kind: str | None = None,
    weak_texture: bool | None = None,
    **overrides: Any,
) -> SceneSpec:
    """Draw a random scene (geometry, cameras, textures, lighting, sensor).

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness; the same state gives the same spec.
    image_size : (width, height)
        Focal lengths scale with the width (``fx`` in ``[0.8, 0.9] * width``).
    kind : {"stairs", "box", "none"} or None
        None draws stairs (70 %), a box (20 %) or nothing (10 %).
    weak_texture : bool or None
        None: weakly textured with probability 0.3. Weak scenes paint the risers and stair
        (or box) sides, and with probability 0.5 the treads (box top), with a texture of
        0.5-1.5 grey levels std before noise; every other surface has a texture of at
        least 6-10 grey levels std.
    **overrides
        Fields of :class:`SceneSpec` or of the obstacle's spec (e.g. ``rise_m=0.2``,
        ``noise_sigma=(0, 0)``). Geometry not overridden is redrawn until the first
        riser (bottom edge: centre and +-35 % of the width) and the top tread's front
        edge are in view of the left camera.

    Notes
    -----
    Exposure is automatic: the ground's nominal grey level is drawn in [95, 150]; albedos
    are lowered where a lit face would exceed grey 200 (no saturated faces).

    Returns
    -------
    SceneSpec

    Raises
    ------
    InputError
        Unknown kind or override, bad values, or overrides that keep the obstacle out of
        view.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    size = _check_image_size(image_size, "random_scene_spec")
    if kind is None:
        kind = str(rng.choice(_KINDS, p=[0.7, 0.2, 0.1]))
    if kind not in _KINDS:
        raise InputError(f"kind must be one of {_KINDS} or None, got {kind!r}")
    weak = bool(rng.random() < 0.3) if weak_texture is None else bool(weak_texture)
    scene_fields = {f.name for f in dataclasses.fields(SceneSpec)}
    ob_cls = {"stairs": StairSpec, "box": BoxSpec, "none": None}[kind]
    ob_fields = {f.name for f in dataclasses.fields(ob_cls)} if ob_cls else set()
    unknown = set(overrides) - scene_fields - ob_fields
    if unknown:
        raise InputError(
            f"unknown override(s) {sorted(unknown)} for a '{kind}' scene; valid: SceneSpec "
            f"fields {sorted(scene_fields)}" + (f" and {sorted(ob_fields)}" if ob_fields else "")
        )
    if "image_size" in overrides or "weak_texture" in overrides:
        raise InputError("pass image_size and weak_texture as keyword arguments, not overrides")
    ob_over = {k: v for k, v in overrides.items() if k in ob_fields and k not in scene_fields}
    sc_over = {k: v for k, v in overrides.items() if k in scene_fields}

    left = _random_camera(rng, size)
    right = _random_camera(rng, size, like=left)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    rotvec = tuple(float(v) for v in axis * math.radians(rng.uniform(0.3, 2.0)))
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
    weak_levels = rng.uniform(0.5, 1.5, len(_GROUPS))
    floor_levels = rng.uniform(6.0, 10.0, len(_GROUPS))
    wall_draw = (bool(rng.random() < 0.5), float(rng.uniform(0.0, 1.0)))

    spec = None
    for _ in range(200):
        ob: StairSpec | BoxSpec | None
        yaw = math.radians(rng.uniform(-25.0, 25.0))
        lateral = float(rng.uniform(-0.2, 0.2))
        distance = float(rng.uniform(0.9, 2.0))
        if kind == "stairs":
            params = {
                "n_steps": int(rng.integers(2, 6)),
                "rise_m": float(rng.uniform(0.10, 0.22)),
                "run_m": float(rng.uniform(0.25, 0.35)),
                "width_m": float(rng.uniform(0.8, 1.6)),
                "distance_m": distance,
                "yaw_rad": yaw,
                "lateral_m": lateral,
                "landing_m": float(rng.uniform(0.6, 1.5)),
            }
            ob = StairSpec(**{**params, **ob_over})
        elif kind == "box":
            params = {
                "height_m": float(rng.uniform(0.10, 0.30)),
                "depth_m": float(rng.uniform(0.3, 0.8)),
                "width_m": float(rng.uniform(0.4, 1.2)),
                "distance_m": distance,
                "yaw_rad": yaw,
                "lateral_m": lateral,
            }
            ob = BoxSpec(**{**params, **ob_over})
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
        raise InputError(
            "could not place the obstacle in view of the left camera with these overrides "
            f"({sorted(overrides)}); relax them"
        )
    weak_groups = ("riser", "side") + (("tread",) if weak_tread else ()) if weak else ()
    return _paint(spec, weak_groups, weak_levels, floor_levels, sc_over)


def _nominal_grey(spec: SceneSpec, surf: SurfaceSpec, normal: np.ndarray) -> float:
    el, az = spec.light_elevation_rad, spec.light_azimuth_rad
    light = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    shade = spec.ambient + spec.diffuse * max(float(normal @ light), 0.0)
    return spec.exposure * surf.albedo * shade


#: Brightest nominal grey level (before texture) of any surface of a random scene.
_MAX_NOMINAL_GREY = 200.0


def _paint(
    spec: SceneSpec,
    weak_groups: tuple[str, ...],
    weak_levels: np.ndarray,
    floor_levels: np.ndarray,
    sc_over: dict,
) -> SceneSpec:
    """Set the texture contrast of every surface in grey levels (std, before noise).

    Albedos are lowered where a face would be brighter than ``_MAX_NOMINAL_GREY``.

    Surfaces in ``weak_groups`` get ``weak_levels`` (0.5-1.5 grey levels: painted); the
    others at least ``floor_levels`` (6-10), so that "textured" holds for dark faces too.
    """
    yaw = 0.0 if spec.obstacle is None else spec.obstacle.yaw_rad
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    up = np.array([0.0, 0.0, 1.0])
    normals = {"ground": [up], "tread": [up], "riser": [-u], "side": [v, -v], "wall": [-u]}
    changes: dict[str, Any] = {}
    for gi, name in enumerate(_GROUPS):
        if name in sc_over:
            continue
        surf: SurfaceSpec = getattr(spec, name)
        brightest = max(_nominal_grey(spec, surf, n) for n in normals[name])
        if brightest > _MAX_NOMINAL_GREY:  # keep lit faces out of saturation
            surf = dataclasses.replace(surf, albedo=surf.albedo * _MAX_NOMINAL_GREY / brightest)
        grey = max(float(np.mean([_nominal_grey(spec, surf, n) for n in normals[name]])), 20.0)
        if name in weak_groups:
            contrast = weak_levels[gi] / grey
        else:
            contrast = max(surf.contrast, floor_levels[gi] / grey)
        changes[name] = dataclasses.replace(surf, contrast=float(min(contrast, 0.6)))
    return dataclasses.replace(spec, **changes)
