"""What both profiles draw alike: a staircase, a box, the overrides, a camera whose lens
distortion inverts, the right camera's rotation, and the texture contrast of every
surface (the paint)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ...errors import InputError
from ..spec import (
    _GROUPS,
    BoxSpec,
    CameraIntrinsics,
    SceneSpec,
    StairSpec,
    SurfaceSpec,
    _check_distortion_invertible,
)

_KINDS = ("stairs", "box", "none")


def _invertible_camera(
    draw: Callable[[], CameraIntrinsics], size: tuple[int, int], tries: int
) -> CameraIntrinsics:
    """The first camera of up to ``tries`` that ``draw`` gives (each profile draws its own
    lens) whose distortion inverts over an image of ``size``."""
    for _ in range(tries):
        cam = draw()
        try:
            _check_distortion_invertible(cam, size, "camera")
        except InputError:
            continue
        return cam
    raise InputError("could not draw an invertible lens distortion")  # pragma: no cover


def _right_rotvec(rng: np.random.Generator) -> tuple[float, ...]:
    """The right camera's rotation against the left one (rotation vector, radians): 0.3-2
    deg about a random axis."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return tuple(float(v) for v in axis * math.radians(rng.uniform(0.3, 2.0)))


def _placement_error(overrides: dict) -> InputError:
    """The error of a profile that could not put the obstacle in view."""
    return InputError(
        "could not place the obstacle in view of the left camera with these overrides "
        f"({sorted(overrides)}); relax them"
    )


def _random_stairs(
    rng: np.random.Generator,
    distance: float,
    yaw: float,
    lateral: float,
    ob_over: dict[str, Any],
    *,
    max_steps: int,
    rise_m: tuple[float, float],
    run_m: tuple[float, float],
    width_m: tuple[float, float],
    landing_m: tuple[float, float],
) -> StairSpec:
    """A staircase with its dimensions drawn from the profile's ranges (2 to
    ``max_steps - 1`` steps; the same draws, in the same order, in both profiles)."""
    params = {
        "n_steps": int(rng.integers(2, max_steps)),
        "rise_m": float(rng.uniform(*rise_m)),
        "run_m": float(rng.uniform(*run_m)),
        "width_m": float(rng.uniform(*width_m)),
        "distance_m": distance,
        "yaw_rad": yaw,
        "lateral_m": lateral,
        "landing_m": float(rng.uniform(*landing_m)),
    }
    return StairSpec(**{**params, **ob_over})


def _random_box(
    rng: np.random.Generator, distance: float, yaw: float, lateral: float, ob_over: dict[str, Any]
) -> BoxSpec:
    """A box of both profiles (the same draws, in the same order, as ever)."""
    params = {
        "height_m": float(rng.uniform(0.10, 0.30)),
        "depth_m": float(rng.uniform(0.3, 0.8)),
        "width_m": float(rng.uniform(0.4, 1.2)),
        "distance_m": distance,
        "yaw_rad": yaw,
        "lateral_m": lateral,
    }
    return BoxSpec(**{**params, **ob_over})


def _split_overrides(kind: str, overrides: dict) -> tuple[dict, dict]:
    """(obstacle overrides, scene overrides); raises on unknown names."""
    scene_fields = {f.name for f in dataclasses.fields(SceneSpec)}
    ob_cls = {"stairs": StairSpec, "box": BoxSpec, "none": None}[kind]
    ob_fields = {f.name for f in dataclasses.fields(ob_cls)} if ob_cls else set()
    unknown = set(overrides) - scene_fields - ob_fields
    if unknown:
        raise InputError(
            f"unknown override(s) {sorted(unknown)} for a '{kind}' scene; valid: SceneSpec "
            f"fields {sorted(scene_fields)}" + (f" and {sorted(ob_fields)}" if ob_fields else "")
        )
    if {"image_size", "weak_texture", "profile"} & set(overrides):
        raise InputError("pass image_size, weak_texture and profile as keyword arguments, not overrides")
    ob_over = {k: v for k, v in overrides.items() if k in ob_fields and k not in scene_fields}
    sc_over = {k: v for k, v in overrides.items() if k in scene_fields}
    return ob_over, sc_over


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
    groups: tuple[str, ...] = _GROUPS,
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
    normals = {"ground": [up], "tread": [up], "riser": [-u], "side": [v, -v], "wall": [-u], "rail": [up, -u]}
    if spec.left_wall_m is not None or spec.right_wall_m is not None:
        normals["wall"] = [-u, v, -v]
    changes: dict[str, Any] = {}
    for gi, name in enumerate(groups):
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
