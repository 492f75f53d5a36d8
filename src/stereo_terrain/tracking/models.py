"""A tracked staircase as a :class:`~stereo_terrain.terrain.StairModel`, and a single
frame's model in the same form."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._numeric import wrap_angle
from ..msac import Plane
from ..odometry import Odometry
from ..terrain import NONE, STAIRS, Polytope, StairModel, Step
from .state import TrackedStaircase


def pose_of(odo: Odometry | None) -> tuple[np.ndarray, float, float]:
    """(xy, z, yaw) of the body in the world frame; the origin without odometry."""
    if odo is None:
        return np.zeros(2), 0.0, 0.0
    p = odo.position_m
    return np.array([float(p[0]), float(p[1])]), float(p[2]), float(odo.yaw_rad)


def finite_or(x: float | None, default: float) -> float:
    return default if x is None or not math.isfinite(x) else float(x)


def tracked_model(track: TrackedStaircase, odometry: Odometry | None, frame: str = "yaw") -> StairModel:
    """The tracked staircase as a :class:`StairModel` in the body's yaw frame now: each
    riser's distance along the body x axis, its height above the body, the sigmas.

    Risers behind the body (negative distance) are kept: they have only left the view.
    """
    xy, z, body_yaw = pose_of(odometry)
    rel = wrap_angle(track.yaw_rad - body_yaw)
    c = math.cos(rel)
    c_safe = c if abs(c) > 0.2 else math.copysign(0.2, c or 1.0)
    u_w = np.array([math.cos(track.yaw_rad), math.sin(track.yaw_rad)])
    base = float(u_w @ (xy - np.asarray(track.anchor_xy_m)))
    u = np.array([math.cos(rel), math.sin(rel), 0.0])
    ground = track.ground_z_m - z
    steps = []
    top = ground
    for ts in track.steps:
        top += ts.rise_m
        dist = (ts.position_m - base) / c_safe
        riser = Plane(-u, dist * c)  # vertical, facing the robot, through (dist, 0, 0)
        steps.append(
            Step(
                ts.rise_m, ts.run_m, float(dist), ts.width_m, float(top), float(dist * c), riser,
                None, False, ts.rise_sigma_m, ts.run_sigma_m, ts.position_sigma_m / abs(c_safe),
                ts.width_sigma_m,
            )
        )  # fmt: skip
    note = f"tracked ({track.state}): {len(steps)} step(s) from {track.frames} frame(s)"
    obstacle = STAIRS if steps else NONE
    return StairModel(
        obstacle, tuple(steps), rel, ground, Polytope(np.zeros((0, 3))), frame, note, track.yaw_sigma_rad
    )


def single_frame_model(model: StairModel, floor_z_m: float | None) -> StairModel:
    """A single frame's model as it is published without tracking: with the robot's floor
    height known, a frame whose surface before its nearest riser is ``k`` rises above that
    floor sees riser ``k + 1`` first (the ``k`` nearer ones have left the view under the
    camera); the first step's distance, meant as the first riser's, is then long by about
    ``k`` runs, and its sigma says so: ``hypot(sigma, k * run)`` (the runs seen, else the
    distance itself: the first riser is between the robot and the one seen).

    Parameters
    ----------
    model : StairModel
        Yaw frame, with the sigmas of :func:`~stereo_terrain.terrain.estimate_step_sigmas`.
    floor_z_m : float or None
        The robot's floor in the same frame (``TrackingConfig.floor_z_m``); None: the model
        unchanged.
    """
    if floor_z_m is None or model.obstacle != STAIRS or not model.steps:
        return model
    rise = float(np.median([st.rise_m for st in model.steps]))
    above = model.ground_z_m - floor_z_m
    if not (rise > 0 and above > 0.5 * rise):
        return model
    hidden = max(1, round(above / rise))
    runs = [st.run_m for st in model.steps if st.run_m is not None]
    first = model.steps[0]
    short = hidden * max(runs) if runs else max(first.distance_m, 0.0)
    sigma = math.hypot(finite_or(first.distance_sigma_m, 0.0), short)
    first = dataclasses.replace(first, distance_sigma_m=sigma)
    return dataclasses.replace(model, steps=(first, *model.steps[1:]))
