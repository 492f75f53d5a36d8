"""Figures of a pipeline result (nothing in the package imports this module).

One figure: the rectified left image with each plane's inliers, the disparity map, and
the cloud and the recovered polytope seen from the side along the stair axis, with the
rise and run of each step written on it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..pipeline import TerrainResult


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _profile(steps: list[dict[str, Any]], ground_z: float, yaw: float) -> tuple[list[float], list[float]]:
    """Side profile (axis position, height) of a step list in JSON form."""
    xs, zs = [0.0], [ground_z]
    z = ground_z
    c = np.cos(yaw)
    for i, s in enumerate(steps):
        pos = s["distance"] * c
        xs += [pos, pos]
        zs += [z, z + s["rise"]]
        z += s["rise"]
        if i == len(steps) - 1:
            run = s["run"] if s["run"] is not None else 0.3
            xs.append(pos + run)
            zs.append(z)
    return xs, zs


def save_result_figure(result: TerrainResult, path: str | Path, *, truth: dict | None = None) -> None:
    """Write a PNG of ``result`` (and the true profile when ``truth`` is given)."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
    left = result.rectified.left
    ax = axes[0]
    ax.imshow(left, cmap="gray")
    samples = result.planes.samples
    cmap = plt.get_cmap("tab10")
    for k, seg in enumerate(result.planes.segments):
        ax.scatter(
            samples.cols[seg.indices],
            samples.rows[seg.indices],
            s=1.5,
            color=cmap(k % 10),
            label=f"{seg.kind[0].upper()}{k}",
        )
    ax.set_title("rectified left + plane inliers (H/V)")
    ax.axis("off")
    if result.planes.segments:
        ax.legend(fontsize=6, markerscale=4, loc="lower right", ncol=2)

    ax = axes[1]
    im = ax.imshow(result.disparity.disparity, cmap="turbo")
    fig.colorbar(im, ax=ax, fraction=0.035, label="disparity [px]")
    ax.set_title(f"disparity ({result.disparity.backend}, density {result.disparity.density:.0%})")
    ax.axis("off")

    ax = axes[2]
    t = result.terrain
    u = np.array([np.cos(t.yaw_rad), np.sin(t.yaw_rad), 0.0])
    pts = result.cloud.points[result.cloud.valid]
    if len(pts) > 20000:
        pts = pts[:: len(pts) // 20000]
    ax.scatter(pts @ u, pts[:, 2], s=0.2, color="0.7", label="cloud")
    data = result.to_json_dict()
    if data["steps"]:
        xs, zs = _profile(data["steps"], t.ground_z_m, t.yaw_rad)
        ax.plot(xs, zs, "r-", lw=2, label=f"recovered {t.obstacle}")
        lines: list[str] = []
        for i, s in enumerate(data["steps"]):
            x = s["distance"] * np.cos(t.yaw_rad)
            ztop = t.steps[i].top_z_m
            run = "?" if s["run"] is None else f"{100 * s['run']:.1f}"
            ax.annotate(
                str(i + 1), (x, ztop), xytext=(-9, 3), textcoords="offset points", fontsize=8, color="r"
            )
            lines.append(f"{i + 1}: rise {100 * s['rise']:.1f} cm, run {run} cm")
        ax.text(
            0.98,
            0.04,
            "\n".join(lines),
            transform=ax.transAxes,
            ha="right",
            va="bottom",
            fontsize=7,
            color="r",
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"},
        )
    if truth and truth.get("steps"):
        xs, zs = _profile(truth["steps"], 0.0, truth.get("yaw", 0.0))
        ax.plot(xs, zs, "k--", lw=1, label="truth")
    if data["steps"]:
        last = data["steps"][-1]["distance"] * np.cos(t.yaw_rad)
        ax.set_xlim(0.0, last + 1.0)
        ax.set_ylim(t.ground_z_m - 0.2, t.steps[-1].top_z_m + 0.5)
    ax.set_xlabel("along stair axis [m]")
    ax.set_ylabel("height [m] (yaw frame)")
    ax.set_title("side view")
    ax.set_aspect("equal", adjustable="box")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(str(path), dpi=90)
    plt.close(fig)
