"""Figure of a simulated approach: foot height vs distance over the step profile.

Top: every foot's swing path (world x, height) with the perceived swing (raised once the
trigger fired) and with the blind nominal swing, over the true step profile; where a
swing passes over the first riser's edge its clearance is marked. Bottom: the first
riser distance each frame reported against the truth, and where the swing was raised
against ``d - d_buffer``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .figure import _pyplot

if TYPE_CHECKING:
    from ..runtime.simulate import ApproachResult


def save_approach_figure(result: ApproachResult, path: str | Path) -> None:
    """Write the approach figure (PNG) to ``path``."""
    from ..runtime.simulate import step_profile

    plt = _pyplot()
    cfg = result.config
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(11, 8), gridspec_kw={"height_ratios": [2, 1]})
    xr = cfg.riser_x_m
    lo = xr - 0.9
    hi = xr + cfg.n_steps * cfg.run_m + 0.3
    xs = np.linspace(lo, hi, 2000)
    ax.fill_between(xs, step_profile(cfg, xs), -0.05, color="0.75", step=None, label="steps (truth)")
    colours = {"FL": "tab:blue", "FR": "tab:cyan", "RL": "tab:green", "RR": "tab:olive"}
    for feet, style, label in ((result.blind, ":", "blind nominal swing"), (result.sensed, "-", "perceived")):
        for f in feet:
            if f.x_m.max() < lo or f.x_m.min() > hi:
                continue
            ax.plot(f.x_m, f.z_m, style, color=colours[f.leg], lw=1.2 if style == "-" else 1.0)
            if f.edge_clearance_m is not None:
                hit = f.edge_clearance_m <= 0
                ax.plot(
                    [xr],
                    [cfg.rise_m + f.edge_clearance_m],
                    "x" if hit else "o",
                    color="red" if hit else "green",
                    ms=7,
                )
        ax.plot([], [], style, color="k", label=label)
    ax.plot([], [], "x", color="red", label="hits the first riser edge")
    ax.plot([], [], "o", color="green", label="clears it")
    if result.trigger_x_m is not None:
        ax.axvline(
            result.trigger_x_m,
            color="tab:red",
            lw=1,
            label=f"swing raised (body at {result.trigger_x_m:.3f} m)",
        )
    ax.axvline(xr - result.swing.buffer_m, color="k", lw=1, ls="--", label="true riser - d_buffer")
    for leg, c in colours.items():
        ax.plot([], [], color=c, label=leg)
    ax.set_xlim(lo, hi)
    ax.set_xlabel("world x (m)  [feet: position; vertical lines: body position]")
    ax.set_ylabel("foot height (m)")
    ax.set_title(
        f"{cfg.n_steps} steps of {cfg.rise_m:.2f} m: trot at {cfg.speed_mps:.2f} m/s, swing "
        f"{result.swing.nominal_height_m:.2f} m blind vs raised"
    )
    ax.legend(fontsize=7, ncol=3, loc="upper left")
    ax.set_aspect("auto")
    x_body = np.array([c.x_m for c in result.commands])
    truth = xr - x_body
    bx.plot(x_body, truth, "k-", lw=1, label="true first riser distance")
    bx.plot(x_body, result.first_distances_m, ".", ms=4, label="nearest riser reported by the frame")
    rem = (
        np.array([c.p0_x_m + c.trigger_distance_m + result.swing.buffer_m for c in result.commands]) - x_body
    )
    bx.plot(x_body, rem, "-", color="tab:red", lw=1, label="trigger state machine's first riser estimate")
    bx.set_xlabel("body x (m)")
    bx.set_ylabel("distance ahead (m)")
    bx.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(str(path), dpi=110)
    plt.close(fig)
