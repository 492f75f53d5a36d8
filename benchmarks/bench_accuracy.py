"""Accuracy of the whole pipeline on rendered scenes, by scene kind.

Scenes come from the renderer's random mix (70% stairs, 20% boxes, 10% empty; 30% weakly
textured) at 640x480, plus 320x240 and 1280x720 sets. Prints one table row per group;
results are recorded in docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_accuracy.py [--scenes 60] [--backend opencv|sgm]
        [--config CFG.yaml]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene


def run(specs, config):
    scores, weak = [], []
    for spec in specs:
        scene = render_scene(spec)
        data = Pipeline(scene.calibration, scene.rig, config).run(scene.left, scene.right).to_json_dict()
        scores.append(score_result(data, scene.truth))
        weak.append(spec.weak_texture)
    return scores, weak


def row(name, scores):
    s = summarize(scores)
    cm = 100.0
    print(
        f"| {name} | {int(s['scenes'])} | {s['detection_rate']:.0%} | {s['false_positive_rate']:.0%} | "
        f"{s['count_rate']:.0%} | {s['rise_median_m'] * cm:.1f} | {s['rise_p90_m'] * cm:.1f} | "
        f"{s['run_median_m'] * cm:.1f} | {s['first_distance_median_m'] * cm:.1f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=60)
    ap.add_argument("--small", type=int, default=10, help="scenes at 320x240 and at 1280x720 each")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--backend", choices=["opencv", "sgm"], default=None, help="default: the config's")
    ap.add_argument("--config", type=Path, help="pipeline config YAML (default settings without)")
    args = ap.parse_args()
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    if args.backend is not None:
        config = dataclasses.replace(config, backend=args.backend)
    rng = np.random.default_rng(args.seed)
    mix, weak = run([random_scene_spec(rng) for _ in range(args.scenes)], config)
    low, _ = run(
        [random_scene_spec(rng, image_size=(320, 240), weak_texture=False) for _ in range(args.small)], config
    )
    high, _ = run(
        [random_scene_spec(rng, image_size=(1280, 720), weak_texture=False) for _ in range(args.small)],
        config,
    )
    print(
        "| scenes | n | detected | false pos. | step count right | rise median cm | rise p90 cm | "
        "run median cm | 1st riser distance median cm |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    row("640x480 random mix", mix)
    row("  of which textured", [s for s, w in zip(mix, weak, strict=True) if not w])
    row("  of which weakly textured", [s for s, w in zip(mix, weak, strict=True) if w])
    row("320x240 textured", low)
    row("1280x720 textured", high)


if __name__ == "__main__":
    main()
