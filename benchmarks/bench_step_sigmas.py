"""Are the step sigmas honest? The share of matched steps whose error lies within 2
reported sigmas, and the median of error / sigma, on rendered scenes with and without
their rigs (issue 14's sigmas, on issue 11's renders).

Steps are matched to the true ones by riser distance (within 12 cm,
``evaluation.matched_steps``, as ``score_result`` matches them). Rows: every rise; the
measured rises that do not report the staircase's common one (``measured_rise`` absent,
not inferred, in a staircase of two steps or more); every run; the measured runs that do
not report the common one; every distance. For a
Gaussian error and a right sigma, 95% lie within 2 sigma and the median of error / sigma
is 0.67.

    .venv/bin/python benchmarks/bench_step_sigmas.py DIR [DIR ...] [--scenes 60] [--modes rig,norig]

``DIR`` is a ``stereo-terrain render`` folder. To compare two versions side by side, run
it once with ``PYTHONPATH`` pointing at each version's ``src``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.evaluation import matched_steps
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.rectify import read_image

ROWS = ("rise", "rise, own (not the common)", "run", "run, own (not the common)", "distance")


def ratios(result: dict, truth: dict, out: dict[str, list[float]]) -> None:
    """Append |error| / sigma of each matched step to ``out``'s rows."""
    several = len(result.get("steps", [])) > 1
    for step, true in matched_steps(result, truth):
        for key in ("rise", "run", "distance"):
            sigma, value, right = step.get(f"{key}_sigma"), step.get(key), true.get(key)
            if not sigma or value is None or right is None or not np.isfinite(sigma):
                continue
            r = abs(value - right) / sigma
            out[key].append(r)
            if key == "rise" and several and not step["rise_inferred"] and step.get("measured_rise") is None:
                out[ROWS[1]].append(r)
            if key == "run" and step.get("measured_run") is None and not step["position_inferred"]:
                out[ROWS[3]].append(r)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes_dirs", type=Path, nargs="+")
    ap.add_argument("--scenes", type=int, default=60, help="per folder")
    ap.add_argument("--modes", default="rig,norig")
    args = ap.parse_args()
    out: dict[str, list[float]] = defaultdict(list)
    for root in args.scenes_dirs:
        dirs = sorted(p for p in root.iterdir() if (p / "truth.json").is_file())[: args.scenes]
        for k, d in enumerate(dirs):
            truth = json.loads((d / "truth.json").read_text())
            left, right = read_image(d / "left.png"), read_image(d / "right.png")
            for mode in args.modes.split(","):
                rig = load_rig(d / "rig.yaml") if mode == "rig" else None
                result = Pipeline(read_calibration(d / "calib.yaml"), rig).run(left, right).to_json_dict()
                ratios(result, truth, out)
            sys.stderr.write(f"\r{root.name}: {k + 1}/{len(dirs)}")
        sys.stderr.write("\n")
    print(f"{', '.join(p.name for p in args.scenes_dirs)} ({args.modes})")
    print("| quantity | matched steps | within 2 sigma | median error / sigma |")
    print("| --- | --- | --- | --- |")
    for row in ROWS:
        a = np.array(out[row])
        if len(a):
            print(f"| {row} | {len(a)} | {np.mean(a <= 2):.0%} | {np.median(a):.2f} |")


if __name__ == "__main__":
    main()
