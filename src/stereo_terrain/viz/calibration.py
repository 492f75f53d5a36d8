"""Figure of a checkerboard calibration: corner coverage and per-view errors.

Three panels: the corners of every kept view over the left and the right image (a board
outline per view; views worth dropping in red), and the per-view RMS reprojection errors
of both cameras with the drop limit.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .figure import _pyplot

if TYPE_CHECKING:
    from ..calibrate import CheckerboardCalibration


def save_calibration_figure(result: CheckerboardCalibration, path: str | Path) -> None:
    """Write the coverage and per-view error figure of ``result`` to ``path`` (PNG)."""
    plt = _pyplot()
    q, v, board = result.quality, result.views, result.board
    w, h = v.image_size
    dropped = set(q.worth_dropping)
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    for ax, corners, name, cov in zip(
        axes[:2], (v.left, v.right), ("left", "right"), q.coverage, strict=True
    ):
        for view_name, c in zip(v.names, corners, strict=True):
            grid = c.reshape(board.rows, board.cols, 2)
            outline = np.concatenate([grid[0, :], grid[1:, -1], grid[-1, -2::-1], grid[-2::-1, 0]])
            colour = "tab:red" if view_name in dropped else "tab:blue"
            ax.plot(outline[:, 0], outline[:, 1], "-", color=colour, lw=0.8, alpha=0.7)
            ax.plot(c[:, 0], c[:, 1], ".", color=colour, ms=1.5)
        ax.set_xlim(0, w)
        ax.set_ylim(h, 0)
        ax.set_aspect("equal")
        ax.set_title(f"{name} image: boards cover {cov:.0%}")
    ax = axes[2]
    x = np.arange(len(v.names))
    ax.bar(x - 0.2, q.per_view_rms_px[:, 0], 0.4, label="left")
    ax.bar(x + 0.2, q.per_view_rms_px[:, 1], 0.4, label="right")
    limit = q.drop_limit_px
    ax.axhline(limit, color="tab:red", ls="--", lw=1, label=f"drop limit {limit:.2f} px")
    ax.axhline(q.rms_px, color="k", ls=":", lw=1, label=f"overall {q.rms_px:.2f} px")
    ax.set_xticks(x)
    ax.set_xticklabels([n.rsplit(".", 1)[0] for n in v.names], rotation=60, fontsize=7)
    ax.set_ylabel("RMS reprojection error, px")
    ax.set_title("per-view error")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(str(path), dpi=90)
    plt.close(fig)
