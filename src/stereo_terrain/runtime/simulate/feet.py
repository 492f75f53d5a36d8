"""The kinematic foot model: the four feet of a trot walked over the true step profile
with the swing height chosen at each lift-off (the package docstring)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .approach import ApproachConfig


def step_profile(cfg: ApproachConfig, x: np.ndarray | float) -> np.ndarray:
    """True terrain height (m) at world x (m): ground, then the steps, then the landing."""
    x = np.asarray(x, dtype=np.float64)
    k = np.floor((x - cfg.riser_x_m) / cfg.run_m) + 1
    return np.clip(k, 0, cfg.n_steps) * cfg.rise_m


@dataclass(frozen=True)
class FootSwing:
    """One swing of one foot: its path and its clearance of the first riser's edge.

    Attributes
    ----------
    leg : str
    t_lo_s : float
    height_m : float
        Commanded swing height.
    x_m, z_m : (S,) float
        Foot path (world x, height), metres.
    edge_clearance_m : float or None
        Foot height minus the first riser's top where the swing passes over the riser
        plane (negative: the foot hits the edge); None if this swing does not cross it.
    min_clearance_m : float
        Lowest foot height above the true profile along the swing's moving part.
    """

    leg: str
    t_lo_s: float
    height_m: float
    x_m: np.ndarray = field(repr=False)
    z_m: np.ndarray = field(repr=False)
    edge_clearance_m: float | None
    min_clearance_m: float


def _quintic(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def simulate_feet(
    cfg: ApproachConfig, swing_height: Any, *, samples: int = 200, legs_past_m: float = 0.5
) -> list[FootSwing]:
    """Walk the four feet over the step profile; ``swing_height(x_body) -> height`` at lift-off.

    Runs until the rear feet are ``legs_past_m`` past the first riser.
    """
    v, period = cfg.speed_mps, cfg.gait_period_s
    t_sw = 0.5 * period
    legs = {"FL": (cfg.front_hip_m, 0.0), "RR": (cfg.rear_hip_m, 0.0),
            "FR": (cfg.front_hip_m, 0.5), "RL": (cfg.rear_hip_m, 0.5)}  # fmt: skip
    t_end = (cfg.riser_x_m - cfg.rear_hip_m + legs_past_m) / v
    s = np.linspace(0.0, 1.0, samples)
    a = cfg.lift_fraction
    out: list[FootSwing] = []
    for leg, (hip, phase) in legs.items():
        x_foot = hip  # standing under the hip at t = 0
        t_lo = phase * period
        while t_lo < t_end:
            body_lo = v * t_lo
            t_td = t_lo + t_sw
            x_lo = x_foot
            x_td = hip + v * t_td + v * (period - t_sw) / 2.0
            z_lo, z_td = float(step_profile(cfg, x_lo)), float(step_profile(cfg, x_td))
            h = float(swing_height(body_lo))
            apex = z_lo + h
            xs = x_lo + (x_td - x_lo) * _quintic((s - a) / (1.0 - 2.0 * a))
            zs = np.where(
                s <= 0.5, z_lo + (apex - z_lo) * np.sin(np.pi * s), z_td + (apex - z_td) * np.sin(np.pi * s)
            )
            moving = (s > a) & (s < 1.0 - a)
            ground = step_profile(cfg, xs)
            min_clear = float(np.min((zs - ground)[moving])) if moving.any() else 0.0
            edge = None
            xr = cfg.riser_x_m
            if x_lo < xr <= x_td:
                i = int(np.searchsorted(xs, xr))
                i = min(max(i, 1), len(xs) - 1)
                w = (xr - xs[i - 1]) / max(xs[i] - xs[i - 1], 1e-12)
                edge = float(zs[i - 1] + w * (zs[i] - zs[i - 1]) - cfg.rise_m)
            out.append(FootSwing(leg, t_lo, h, xs, zs, edge, min_clear))
            x_foot = x_td
            t_lo += period
    out.sort(key=lambda f: f.t_lo_s)
    return out
