"""Per-stage timing of the pipeline at 640x480 (64 disparities) against OpenCV SGBM alone.

Both are measured in one run, interleaved frame by frame on the same rectified pairs, so
the ratios hold even on a noisy shared machine. Prints a table; results are recorded in
docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_pipeline.py [--scenes 10] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import cv2
import numpy as np

from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import rectify
from stereo_terrain.synthetic import random_scene_spec, render_scene

STAGES = ("rectify", "disparity", "cloud", "gravity", "planes", "polytope", "total")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    cv2.setNumThreads(1)  # one core for both: ratios, not parallel speed-ups
    rng = np.random.default_rng(args.seed)
    times: dict[str, list[float]] = {k: [] for k in STAGES}
    sgbm_ms: list[float] = []
    for _ in range(args.scenes):
        scene = render_scene(random_scene_spec(rng, kind="stairs", weak_texture=False))
        pipeline = Pipeline(scene.calibration, scene.rig, PipelineConfig(max_disparity_px=64))
        pair = rectify(scene.left, scene.right, pipeline.rectification)
        baseline = cv2.StereoSGBM.create(
            0,
            64,
            5,
            P1=8 * 25,
            P2=32 * 25,
            disp12MaxDiff=1,
            uniquenessRatio=10,
            speckleWindowSize=100,
            speckleRange=2,
            mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
        )
        pipeline.run(scene.left, scene.right)  # warm-up
        baseline.compute(pair.left, pair.right)
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            baseline.compute(pair.left, pair.right)
            sgbm_ms.append((time.perf_counter() - t0) * 1000)
            result = pipeline.run(scene.left, scene.right)
            for k in STAGES:
                times[k].append(result.timing_ms[k])
    med = {k: statistics.median(v) for k, v in times.items()}
    sgbm = statistics.median(sgbm_ms)
    after = med["cloud"] + med["gravity"] + med["planes"] + med["polytope"]
    print(f"640x480, 64 disparities, {args.scenes} scenes x {args.repeats} runs, 1 OpenCV thread; median ms")
    print("| stage | ms |")
    print("| --- | --- |")
    for k in STAGES:
        print(f"| {k} | {med[k]:.1f} |")
    print(f"| OpenCV SGBM alone (3-way, same pair) | {sgbm:.1f} |")
    print()
    print(f"whole pipeline / SGBM alone: {med['total'] / sgbm:.2f}")
    ratio = after / med["disparity"]
    print(f"after-disparity stages (cloud+gravity+planes+polytope) / disparity stage: {ratio:.2f}")
    print("  (disparity stage = SGBM + texture-poor planar fill; target < 0.30)")


if __name__ == "__main__":
    main()
