"""Grid search of the SGM engine's P1, P2 and uniqueness ratio on Middlebury scenes.

For each setting: mean bad-2.0 (non-occluded, holes count as bad) over the scenes, and the
worst per-scene margin to OpenCV StereoSGBM's best mode (3-way, SGBM, HH) on that scene
(positive: ours is better everywhere).

    .venv/bin/python benchmarks/tune_sgm.py [ROOT] --p1 7 10 14 --p2 64 80 --uniqueness 2 5
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np

from stereo_terrain.evaluation import disparity_errors, middlebury_scene_dirs, read_middlebury_scene
from stereo_terrain.pipeline import PipelineConfig
from stereo_terrain.rectify import compute_rectification, rectify
from stereo_terrain.stereo import default_max_disparity, make_backend

OPENCV_MODES = ("sgbm_3way", "sgbm", "hh")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", type=Path, nargs="?", default=Path("../shared/data/middlebury2014Q"))
    ap.add_argument("--p1", type=int, nargs="+", default=[7, 10, 14])
    ap.add_argument("--p2", type=int, nargs="+", default=[64, 80, 96])
    ap.add_argument("--uniqueness", type=int, nargs="+", default=[2, 5])
    args = ap.parse_args()
    scenes = []
    for d in middlebury_scene_dirs(args.root):
        s = read_middlebury_scene(d)
        rect = compute_rectification(s.calibration)
        pair = rectify(s.left, s.right, rect)
        n = default_max_disparity(rect, PipelineConfig().min_depth_m)
        scenes.append((s.name, pair, n, s.truth, s.nonoccluded))

    def bad2(backend, pair, n, truth, nocc) -> float:
        return disparity_errors(backend.compute(pair, n).disparity, truth, nocc)["bad2"]

    best_opencv = {
        name: min(bad2(make_backend("opencv", mode=m), *rest) for m in OPENCV_MODES) for name, *rest in scenes
    }
    print("OpenCV best mode, bad-2.0 %:", {k: round(100 * v, 1) for k, v in best_opencv.items()})
    print("| P1 | P2 | uniqueness % | mean bad-2.0 | worst margin to OpenCV (points) |")
    print("| --- | --- | --- | --- | --- |")
    for p1, p2, u in itertools.product(args.p1, args.p2, args.uniqueness):
        engine = make_backend("sgm", p1=p1, p2=p2, uniqueness_ratio_pct=u)
        ours = {name: bad2(engine, *rest) for name, *rest in scenes}
        margin = min(best_opencv[k] - v for k, v in ours.items())
        mean = 100 * np.mean(list(ours.values()))
        print(f"| {p1} | {p2} | {u} | {mean:.2f}% | {100 * margin:+.2f} |", flush=True)


if __name__ == "__main__":
    main()
