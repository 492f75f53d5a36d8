"""Figure for docs/benchmarks.md ("Twelfth session"): the real Middlebury ``Staircase`` with
the recovered polytope drawn over the rectified left image, without and with the steps the
image's line segments show (``terrain.nosing_steps``, terrain/nosings/).

    .venv/bin/python benchmarks/figure_staircase_nosings.py [--out docs/figures/staircase_nosings.png]

Needs the ``viz`` extra (Matplotlib) and ../shared/data.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image
from stereo_terrain.terrain import TerrainConfig

SCENE = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "middlebury2014Q_noGT" / "Staircase"


def _faces_in_image(result) -> list[np.ndarray]:
    """The polytope's faces as pixel polygons of the rectified left image."""
    rect = result.rectified.rectification
    T_camera_yaw = np.linalg.inv(result.T_yaw_camera_rect.matrix)
    vertices = np.asarray(result.terrain.polytope.vertices, dtype=np.float64)
    X = vertices @ T_camera_yaw[:3, :3].T + T_camera_yaw[:3, 3]
    f = rect.focal_px
    uv = np.column_stack([f * X[:, 0] / X[:, 2] + rect.cx, f * X[:, 1] / X[:, 2] + rect.cy])
    return [uv[list(face)] for face in result.terrain.polytope.faces]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/figures/staircase_nosings.png"))
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    calibration = read_calibration(SCENE / "calib.txt")
    left, right = read_image(SCENE / "im0.png"), read_image(SCENE / "im1.png")
    off = PipelineConfig(terrain=TerrainConfig(nosing_steps=False))
    runs = [
        ("riser planes only (nosing_steps: false)", off),
        ("with the nosings' lines (default)", PipelineConfig()),
    ]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for ax, (title, config) in zip(axes, runs, strict=True):
        result = Pipeline(calibration, config=config).run(left, right)
        ax.imshow(result.rectified.left, cmap="gray")
        for poly in _faces_in_image(result):
            closed = np.vstack([poly, poly[:1]])
            ax.plot(closed[:, 0], closed[:, 1], "r-", lw=0.8)
        h, w = result.rectified.left.shape[:2]
        ax.set_xlim(0, w)
        ax.set_ylim(h, 0)
        steps = result.terrain.steps
        rises = ", ".join(f"{s.rise_m * 100:.1f}" for s in steps)
        ax.set_title(f"{title}\n{len(steps)} steps, rises {rises} cm", fontsize=9)
        ax.set_axis_off()
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
