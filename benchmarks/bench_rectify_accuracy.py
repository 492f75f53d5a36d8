"""Pipeline accuracy on rendered scenes with each rectification ``fov``, same scenes, same run.

The renderer's random mix at 640x480, textured scenes at 320x240 (as ``bench_accuracy.py``
draws them) and the realistic profile at 640x480 (``random_scene_spec(rng,
profile="realistic")``), each run with every ``rectify_fov`` of ``--fovs`` (default
``valid`` (OpenCV alpha 0, the earlier default), ``full-height`` and ``keep``); per-frame
vertical alignment as configured (default on; ``--no-vertical`` for off). ``ms`` is the
median wall time of ``Pipeline.run`` per frame (the first frame of each pipeline, which
builds matchers and buffers, excluded by running it twice).

    .venv/bin/python benchmarks/bench_rectify_accuracy.py [--scenes 30] [--small 10] \
        [--realistic 20] [--seed 1] [--fovs valid,keep]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import RECTIFY_FOVS
from stereo_terrain.stereo.vertical import VerticalAlignConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=30)
    ap.add_argument("--small", type=int, default=10)
    ap.add_argument("--realistic", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--backend", choices=["opencv", "sgm"], default="opencv")
    ap.add_argument("--fovs", default="valid,full-height,keep")
    ap.add_argument("--no-vertical", action="store_true")
    args = ap.parse_args()
    fovs = tuple(args.fovs.split(","))
    if not set(fovs) <= set(RECTIFY_FOVS):
        ap.error(f"--fovs: choose from {', '.join(RECTIFY_FOVS)}")
    rng = np.random.default_rng(args.seed)
    groups = {
        "640x480 random mix": [random_scene_spec(rng) for _ in range(args.scenes)],
        "320x240 textured": [
            random_scene_spec(rng, image_size=(320, 240), weak_texture=False) for _ in range(args.small)
        ],
        "640x480 realistic": [random_scene_spec(rng, profile="realistic") for _ in range(args.realistic)],
    }
    vertical = VerticalAlignConfig(enabled=not args.no_vertical)
    print(
        "| scenes | fov | n | detected | false pos. | step count right | rise median cm | "
        "rise p90 cm | run median cm | ms per frame |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, specs in groups.items():
        if not specs:
            continue
        scores: dict[str, list] = {f: [] for f in fovs}
        times: dict[str, list[float]] = {f: [] for f in fovs}
        for spec in specs:
            scene = render_scene(spec)
            for fov in fovs:
                cfg = PipelineConfig(backend=args.backend, rectify_fov=fov, vertical=vertical)
                pipe = Pipeline(scene.calibration, scene.rig, cfg)
                pipe.run(scene.left, scene.right)  # warm-up: matchers, buffers
                t0 = time.perf_counter()
                data = pipe.run(scene.left, scene.right).to_json_dict()
                times[fov].append((time.perf_counter() - t0) * 1000.0)
                scores[fov].append(score_result(data, scene.truth))
        for fov in fovs:
            s = summarize(scores[fov])
            print(
                f"| {name} | {fov} | {int(s['scenes'])} | {s['detection_rate']:.0%} | "
                f"{s['false_positive_rate']:.0%} | {s['count_rate']:.0%} | {s['rise_median_m'] * 100:.1f} | "
                f"{s['rise_p90_m'] * 100:.1f} | {s['run_median_m'] * 100:.1f} | "
                f"{np.median(times[fov]):.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
