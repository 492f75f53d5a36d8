"""Two versions of the package timed frame by frame interleaved in one process.

The machine is shared and noisy: only ratios measured in one process count. A copy of
the base version of the package, imported under another name (e.g. ``git archive BASE
src/stereo_terrain | tar -x -C /tmp/base && mv /tmp/base/src/stereo_terrain
/tmp/base/stereo_terrain_base``), runs beside this checkout's package on the same scenes
(``render`` layout, with their rig unless ``--no-rig``). Per scene both pipelines are
built and warmed; then ``repeat`` rounds, in each of which every version (in alternating
order) times OpenCV SGBM 3-way alone on its rectified pair and then one warm frame. Printed
per version: the median frame, its ratio to 3-way (median over frames), the median of
each ``timing_ms`` stage; and *after/before*, the median over rounds of the two frames'
ratio. ``--compare`` also reports on how many scenes the first frames' results (JSON
without its timings) and disparities are the same bit for bit, and the accuracy of each
version's first frames against ``truth.json`` (scored alike, by this package).

    .venv/bin/python benchmarks/bench_versions.py SCENES_DIR --base /tmp/base
        [--base-name stereo_terrain_base] [--scenes 30] [--repeat 5] [--no-rig] [--compare]
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import stereo_terrain
from stereo_terrain.bench import read_bench_scene
from stereo_terrain.evaluation import score_result, summarize


def _package(name: str) -> dict[str, Any]:
    """The modules of package ``name`` the comparison uses."""
    return {
        "name": name,
        "pipeline": importlib.import_module(f"{name}.pipeline"),
        "calibration": importlib.import_module(f"{name}.calibration"),
        "frames": importlib.import_module(f"{name}.frames"),
        "stereo": importlib.import_module(f"{name}.stereo"),
        "opencv": importlib.import_module(f"{name}.stereo.opencv"),
    }


def _same_without_timing(result: dict[str, Any]) -> str:
    r = dict(result)
    r.pop("timing_ms", None)
    return json.dumps(r, sort_keys=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes_dir", type=Path)
    ap.add_argument("--base", type=Path, required=True, help="folder holding the base package copy")
    ap.add_argument("--base-name", default="stereo_terrain_base")
    ap.add_argument("--scenes", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-rig", action="store_true")
    ap.add_argument("--compare", action="store_true", help="same outputs? accuracy of each")
    args = ap.parse_args()
    sys.path.insert(0, str(args.base))
    versions = [_package(args.base_name), _package("stereo_terrain")]
    labels = ["before", "after"]
    frames: list[list[float]] = [[], []]
    ref: list[list[float]] = [[], []]
    stages: list[dict[str, list[float]]] = [{}, {}]
    same_json = same_disp = 0
    differ: list[str] = []
    scores: list[list[Any]] = [[], []]
    dirs = sorted(d for d in args.scenes_dir.iterdir() if d.is_dir())[: args.scenes]
    for s, d in enumerate(dirs):
        scene = read_bench_scene(d)  # images and truth; each version reads its own calibration
        pipes, matchers, pairs, firsts = [], [], [], []
        for v in versions:
            calib = v["calibration"].read_calibration(d / "calib.yaml")
            rig = None if args.no_rig or scene.rig is None else v["frames"].load_rig(d / "rig.yaml")
            cfg = v["pipeline"].PipelineConfig()
            p = v["pipeline"].Pipeline(calib, rig, cfg)
            first = p.run(scene.left, scene.right)
            n = v["stereo"].default_max_disparity(p.rectification, cfg.min_depth_m)
            m = v["opencv"].create_sgbm(cfg.sgbm, n, mode="sgbm_3way")
            m.compute(first.rectified.left, first.rectified.right)
            pipes.append(p)
            matchers.append(m)
            pairs.append((first.rectified.left, first.rectified.right))
            firsts.append(first)
        if args.compare:
            js = [f.to_json_dict() for f in firsts]
            if _same_without_timing(js[0]) == _same_without_timing(js[1]):
                same_json += 1
            else:
                differ.append(d.name)
            h = [
                hashlib.sha1(np.ascontiguousarray(f.disparity.disparity).tobytes()).hexdigest()
                for f in firsts
            ]
            same_disp += h[0] == h[1]
            if scene.truth is not None:
                for k in range(2):
                    scores[k].append(score_result(js[k], scene.truth))
        for r in range(args.repeat):
            order = (0, 1) if (r + s) % 2 == 0 else (1, 0)
            for k in order:
                t = time.perf_counter()
                matchers[k].compute(*pairs[k])
                ref[k].append((time.perf_counter() - t) * 1000.0)
                timing = pipes[k].run(scene.left, scene.right).timing_ms
                frames[k].append(timing["total"])
                for key, val in timing.items():
                    stages[k].setdefault(key, []).append(val)
        print(f"\r{s + 1}/{len(dirs)}", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    a = [np.array(f) for f in frames]
    o = [np.array(x) for x in ref]
    keys = [k for k in stages[1] if k != "total"]
    print(f"{args.scenes_dir} ({len(dirs)} scenes x {args.repeat}, {'no rig' if args.no_rig else 'rig'})")
    print("| code | frame ms | Hz | 3-way ms | ratio to 3-way | " + " | ".join(keys) + " |")
    for k in range(2):
        st = " | ".join(f"{np.median(stages[k].get(key, [0.0])):.2f}" for key in keys)
        print(
            f"| {labels[k]} | {np.median(a[k]):.1f} | {1000 / np.median(a[k]):.0f} | {np.median(o[k]):.1f} | "
            f"**{np.median(a[k] / o[k]):.2f}** | {st} |"
        )
    print(f"after/before, median of frame pairs: {np.median(a[1] / a[0]):.3f}")
    if args.compare:
        n = len(dirs)
        print(f"first frames the same bit for bit: result JSON {same_json}/{n}, disparity {same_disp}/{n}")
        if differ:
            print(f"results that differ: {', '.join(differ)}")
        for k in range(2):
            if scores[k]:
                m = summarize(scores[k])
                print(
                    f"accuracy {labels[k]}: detected {m['detection_rate']:.0%}, "
                    f"step count {m['count_rate']:.0%}, rise err median / p90 "
                    f"{100 * m['rise_median_m']:.2f} / {100 * m['rise_p90_m']:.2f} cm"
                )
    print(f"(after = {Path(stereo_terrain.__file__).parent})")


if __name__ == "__main__":
    main()
