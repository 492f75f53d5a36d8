"""Speed and memory of the own SGM engine against OpenCV StereoSGBM, side by side.

640x480 rendered pair, 64 and 128 disparities, in two regimes:

- **Single calls**: interleaved rounds, each calling every method once, 0.2 s apart (each
  call starts on an idle machine). The median is reported, as wall time and as CPU time
  of the whole process (both threads of ours, all of OpenCV's), with the per-round ratios'
  quartiles.
- **At 30 frames per second**: each method gets a run of calls started 1/30 s apart, as
  the live loop calls it (a method slower than that runs back to back); the methods'
  runs are interleaved. The median per call is reported.

On this shared virtual machine a call after an idle spell is slower and more variable
than one in a steady stream (the second core has to be woken), and more so for two
threads than for one, so both regimes are shown.

Memory is measured, not estimated: each method runs once in a fresh child process after a
warm-up on a small image, while a thread samples the resident set every 0.5 ms; the peak
growth over the resident set before the call is reported.

    .venv/bin/python benchmarks/bench_sgm.py [--repeats 15]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from stereo_terrain.rectify import compute_rectification, rectify
from stereo_terrain.stereo import make_backend
from stereo_terrain.synthetic import default_scene_spec, render_scene

METHODS = {
    "sgm (8 paths)": ("sgm", {}),
    "sgm (4 paths)": ("sgm", {"paths": 4}),
    "sgm (16 paths)": ("sgm", {"paths": 16}),
    "opencv HH (8 paths)": ("opencv", {"mode": "hh"}),
    "opencv SGBM (5 paths)": ("opencv", {"mode": "sgbm"}),
    "opencv 3-way": ("opencv", {"mode": "sgbm_3way"}),
}

_MEMORY_CHILD = """
import json, os, sys, threading, time
from stereo_terrain.rectify import RectifiedPair, compute_rectification, rectify
from stereo_terrain.stereo import make_backend
from stereo_terrain.synthetic import default_scene_spec, render_scene

def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

backend, options, n = json.loads(sys.argv[1])
scene = render_scene(default_scene_spec())
pair = rectify(scene.left, scene.right, compute_rectification(scene.calibration))
b = make_backend(backend, **options)
small = RectifiedPair(pair.left[:64, :320].copy(), pair.right[:64, :320].copy(), pair.rectification)
b.compute(small, 64)  # compile and warm up on a small image
del scene
base = peak = rss()
done = False

def sample():
    global peak
    while not done:
        peak = max(peak, rss())
        time.sleep(0.0005)

t = threading.Thread(target=sample)
t.start()
b.compute(pair, n)
done = True
t.join()
print((peak - base) / 2**20)
"""


def peak_memory_mb(backend: str, options: dict, n: int) -> float:
    """Peak growth of the resident set (MB) during one full-size call, in a fresh process."""
    out = subprocess.run(
        [sys.executable, "-c", _MEMORY_CHILD, json.dumps([backend, options, n])],
        capture_output=True,
        text=True,
        check=True,
        # Large blocks straight from the system and back: otherwise a buffer can land in
        # heap memory the scene's rendering left resident, and no growth shows.
        env=dict(os.environ, MALLOC_MMAP_THRESHOLD_="131072"),
    )
    return float(out.stdout.strip().splitlines()[-1])


def paced_calls_ms(backend, pair, n: int, calls: int, fps: float = 30.0) -> list[float]:
    """Wall times (ms) of ``calls`` calls started 1/fps apart (back to back when slower),
    the first (after an idle spell) left out."""
    times = []
    start = time.perf_counter()
    for i in range(calls):
        time.sleep(max(0.0, start + i / fps - time.perf_counter()))
        t0 = time.perf_counter()
        backend.compute(pair, n)
        times.append((time.perf_counter() - t0) * 1000)
    return times[1:]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--paced-calls", type=int, default=16, help="calls per run at 30 fps (3 runs)")
    args = ap.parse_args()
    scene = render_scene(default_scene_spec())
    pair = rectify(scene.left, scene.right, compute_rectification(scene.calibration))
    h, w = pair.left.shape
    backends = {name: make_backend(b, **o) for name, (b, o) in METHODS.items()}
    wall: dict[tuple[str, int], list[float]] = {}
    cpu: dict[tuple[str, int], list[float]] = {}
    for n in (64, 128):
        for b in backends.values():
            b.compute(pair, n)  # warm-up (compilation, buffers)
        for _ in range(args.repeats):
            for name, b in backends.items():
                # Every call starts on an idle machine (no method's threads still busy).
                time.sleep(0.2)
                t0, c0 = time.perf_counter(), time.process_time()
                b.compute(pair, n)
                wall.setdefault((name, n), []).append((time.perf_counter() - t0) * 1000)
                cpu.setdefault((name, n), []).append((time.process_time() - c0) * 1000)
    paced: dict[tuple[str, int], list[float]] = {}
    for n in (64, 128):
        for _ in range(3):
            for name, b in backends.items():
                time.sleep(0.2)
                paced.setdefault((name, n), []).extend(paced_calls_ms(b, pair, n, args.paced_calls))
    med = {k: statistics.median(v) for k, v in wall.items()}
    med_paced = {k: statistics.median(v) for k, v in paced.items()}
    med_cpu = {k: statistics.median(v) for k, v in cpu.items()}
    print(
        f"{w}x{h}, this machine's 2 cores; single calls: median of {args.repeats} interleaved rounds; "
        f"30 fps: median of 3 runs of {args.paced_calls - 1} calls"
    )
    print(
        "| method | 64 disp wall ms | 64 disp CPU ms | 64 disp at 30 fps ms | 128 disp wall ms "
        "| 128 disp CPU ms | 128 disp at 30 fps ms | peak memory 64 disp MB | peak memory 128 disp MB |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, (b, o) in METHODS.items():
        mem = [peak_memory_mb(b, o, n) for n in (64, 128)]
        cells = [
            f"{med[(name, n)]:.0f} | {med_cpu[(name, n)]:.0f} | {med_paced[(name, n)]:.0f}" for n in (64, 128)
        ]
        print(f"| {name} | {cells[0]} | {cells[1]} | {mem[0]:.0f} | {mem[1]:.0f} |", flush=True)
    print()
    for n in (64, 128):
        ours, hh, three = (med[(m, n)] for m in ("sgm (8 paths)", "opencv HH (8 paths)", "opencv 3-way"))
        c_ours, c_three = med_cpu[("sgm (8 paths)", n)], med_cpu[("opencv 3-way", n)]
        print(
            f"{n} disparities: sgm 8 paths is {hh / ours:.2f}x as fast as HH (target >= 2); "
            f"takes {ours / three:.2f}x the wall time of 3-way (target <= 1.5), "
            f"{c_ours / c_three:.2f}x its CPU time"
        )
        # The same ratios round by round (each round runs the methods back to back, so
        # a burst of load from other users of the machine tends to hit both): their
        # median and quartiles say how much the ratios above can be trusted.
        for label, num, den in (
            ("HH / sgm", "opencv HH (8 paths)", "sgm (8 paths)"),
            ("sgm / 3-way", "sgm (8 paths)", "opencv 3-way"),
        ):
            ratios = [a / b for a, b in zip(wall[(num, n)], wall[(den, n)], strict=True)]
            q1, q2, q3 = statistics.quantiles(ratios, n=4)
            print(f"  per round, {label}: median {q2:.2f}, quartiles {q1:.2f}-{q3:.2f}")
        ours, hh, three = (
            med_paced[(m, n)] for m in ("sgm (8 paths)", "opencv HH (8 paths)", "opencv 3-way")
        )
        print(
            f"  at 30 fps: sgm 8 paths is {hh / ours:.2f}x as fast as HH, "
            f"takes {ours / three:.2f}x the wall time of 3-way"
        )


if __name__ == "__main__":
    main()
