"""Pipeline accuracy on rendered scenes with each rectification ``fov``, same scenes, same run.

The renderer's random mix at 640x480 and textured scenes at 320x240 (as
``bench_accuracy.py`` draws them), each run with ``rectify_fov`` ``valid`` (OpenCV alpha 0,
the earlier default) and ``full-height``; per-frame vertical alignment as configured
(default on; ``--no-vertical`` for off).

    .venv/bin/python benchmarks/bench_rectify_accuracy.py [--scenes 30] [--small 10] [--seed 1]
"""

from __future__ import annotations

import argparse

import numpy as np

from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.stereo.vertical import VerticalAlignConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=30)
    ap.add_argument("--small", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--backend", choices=["opencv", "sgm"], default="opencv")
    ap.add_argument("--no-vertical", action="store_true")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    groups = {
        "640x480 random mix": [random_scene_spec(rng) for _ in range(args.scenes)],
        "320x240 textured": [
            random_scene_spec(rng, image_size=(320, 240), weak_texture=False) for _ in range(args.small)
        ],
    }
    vertical = VerticalAlignConfig(enabled=not args.no_vertical)
    fovs = ("valid", "full-height")
    print(
        "| scenes | fov | n | detected | false pos. | step count right | rise median cm | "
        "rise p90 cm | run median cm |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, specs in groups.items():
        scores: dict[str, list] = {f: [] for f in fovs}
        for spec in specs:
            scene = render_scene(spec)
            for fov in fovs:
                cfg = PipelineConfig(backend=args.backend, rectify_fov=fov, vertical=vertical)
                data = Pipeline(scene.calibration, scene.rig, cfg).run(scene.left, scene.right).to_json_dict()
                scores[fov].append(score_result(data, scene.truth))
        for fov in fovs:
            s = summarize(scores[fov])
            print(
                f"| {name} | {fov} | {int(s['scenes'])} | {s['detection_rate']:.0%} | "
                f"{s['false_positive_rate']:.0%} | {s['count_rate']:.0%} | {s['rise_median_m'] * 100:.1f} | "
                f"{s['rise_p90_m'] * 100:.1f} | {s['run_median_m'] * 100:.1f} |"
            )


if __name__ == "__main__":
    main()
