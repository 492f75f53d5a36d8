"""Ablation of the texture-poor planar fill on weakly textured staircases (640x480).

.venv/bin/python benchmarks/bench_fill.py [--scenes 20]
"""

from __future__ import annotations

import argparse

import numpy as np

from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.stereo.fill import PlanarFillConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=3)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    scenes = [
        render_scene(random_scene_spec(rng, weak_texture=True, kind="stairs")) for _ in range(args.scenes)
    ]
    configs = {
        "without fill": PipelineConfig(fill=PlanarFillConfig(enabled=False)),
        "with fill": PipelineConfig(),
    }
    print("| weakly textured stairs | detected | step count right | rise median cm | rise p90 cm |")
    print("| --- | --- | --- | --- | --- |")
    for name, config in configs.items():
        scores = [
            score_result(Pipeline(s.calibration, s.rig, config).run(s.left, s.right).to_json_dict(), s.truth)
            for s in scenes
        ]
        m = summarize(scores)
        print(
            f"| {name} | {m['detection_rate']:.0%} | {m['count_rate']:.0%} | "
            f"{m['rise_median_m'] * 100:.1f} | {m['rise_p90_m'] * 100:.1f} |"
        )


if __name__ == "__main__":
    main()
