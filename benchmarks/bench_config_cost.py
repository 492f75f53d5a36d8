"""What a pipeline option costs per frame: two configs timed interleaved in one process.

The same scenes (``render`` layout) run through a pipeline with config A and one with
config B, frame by frame in turn (each warm), so that the machine's load falls on both
alike; the ratio B / A of the median frame times and the median of the per-frame ratios
are what count (this machine is shared and noisy).

    .venv/bin/python benchmarks/bench_config_cost.py SCENES_DIR --b B.yaml [--a A.yaml]
        [--no-rig] [--scenes 10] [--repeat 5]

e.g. the image's vertical lines without a rig: ``--no-rig --a off.yaml`` with ``off.yaml``
holding ``vanishing: {enabled: false}`` and ``--b`` an empty YAML (the default).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes_dir", type=Path)
    ap.add_argument("--a", type=Path, help="config A (default settings without)")
    ap.add_argument("--b", type=Path, required=True, help="config B")
    ap.add_argument("--no-rig", action="store_true", help="run without the scenes' rig files")
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    configs = [PipelineConfig.from_yaml(p) if p else PipelineConfig() for p in (args.a, args.b)]
    times: list[list[float]] = [[], []]
    dirs = sorted(args.scenes_dir.glob("scene_*"))[: args.scenes]
    for d in dirs:
        calib = read_calibration(d / "calib.yaml")
        rig = None if args.no_rig else load_rig(d / "rig.yaml")
        left, right = read_image(d / "left.png"), read_image(d / "right.png")
        pipes = [Pipeline(calib, rig, c) for c in configs]
        for p in pipes:
            p.run(left, right)  # warm
        for _ in range(args.repeat):
            for k, p in enumerate(pipes):
                t = time.perf_counter()
                p.run(left, right)
                times[k].append(time.perf_counter() - t)
    a, b = (np.array(t) * 1000.0 for t in times)
    print(
        f"{len(dirs)} scenes x {args.repeat}, {'no rig' if args.no_rig else 'rig'}: "
        f"A {np.median(a):.1f} ms, B {np.median(b):.1f} ms; B / A: ratio of medians "
        f"{np.median(b) / np.median(a):.2f}, median of frame ratios {np.median(b / a):.2f}"
    )


if __name__ == "__main__":
    main()
