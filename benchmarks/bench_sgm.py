"""Speed and memory of the own SGM engine against OpenCV StereoSGBM, side by side.

640x480 rendered pair, 64 and 128 disparities, interleaved runs, median ms. Memory is our
engine's working set (cost volume and the two sweep sums) from its array sizes; OpenCV's
is allocated inside C++ and not measured here.

    .venv/bin/python benchmarks/bench_sgm.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

from stereo_terrain.rectify import compute_rectification, rectify
from stereo_terrain.stereo import make_backend
from stereo_terrain.synthetic import default_scene_spec, render_scene

METHODS = {
    "sgm (8 paths)": ("sgm", {}),
    "sgm (4 paths)": ("sgm", {"paths": 4}),
    "opencv HH (8 paths)": ("opencv", {"mode": "hh"}),
    "opencv SGBM (5 paths)": ("opencv", {"mode": "sgbm"}),
    "opencv 3-way": ("opencv", {"mode": "sgbm_3way"}),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    scene = render_scene(default_scene_spec())
    pair = rectify(scene.left, scene.right, compute_rectification(scene.calibration))
    h, w = pair.left.shape
    print(f"{w}x{h}, median of {args.repeats} interleaved runs, this machine's 2 cores")
    print("| method | 64 disp ms | 128 disp ms | working set 128 disp MB |")
    print("| --- | --- | --- | --- |")
    backends = {name: make_backend(b, **o) for name, (b, o) in METHODS.items()}
    times: dict[tuple[str, int], list[float]] = {}
    for n in (64, 128):
        for b in backends.values():
            b.compute(pair, n)  # warm-up (compilation, buffers)
        for _ in range(args.repeats):
            for name, b in backends.items():
                t0 = time.perf_counter()
                b.compute(pair, n)
                times.setdefault((name, n), []).append((time.perf_counter() - t0) * 1000)
    for name in METHODS:
        if name.startswith("sgm"):
            mem = h * w * 128 * (1 + 2 * 2) / 2**20  # uint8 cost + two uint16 sweep sums
        else:  # OpenCV allocates inside C++: not measured here
            mem = float("nan")
        print(
            f"| {name} | {statistics.median(times[(name, 64)]):.0f} | "
            f"{statistics.median(times[(name, 128)]):.0f} | {mem:.0f} |"
        )
    ours = statistics.median(times[("sgm (8 paths)", 64)])
    hh = statistics.median(times[("opencv HH (8 paths)", 64)])
    three = statistics.median(times[("opencv 3-way", 64)])
    print(
        f"\nsgm 8 paths vs HH at 64: {hh / ours:.2f}x faster (target >= 2); "
        f"vs 3-way: {ours / three:.2f}x its time (target <= 1.5)"
    )


if __name__ == "__main__":
    main()
