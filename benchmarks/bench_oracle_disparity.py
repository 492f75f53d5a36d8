"""How much of the gap is the disparity? The pipeline downstream of the matcher, fed better
disparities than the matcher gives, on rendered scenes with their rigs.

Each mode replaces the disparity stage's output (the fill is off: the disparity given is
final) and runs everything after it as the pipeline does:

* ``matcher``: the default backend and fill, unchanged (the reference);
* ``truth``: the true disparity from the renderer's depth (``depth_left.npy``);
* ``noise=S``: the truth plus independent Gaussian noise of S px per pixel;
* ``good=T``: the matcher's disparity where it is within T px of the truth, the truth
  elsewhere (the matcher's own small errors, none of its large ones or holes);
* ``goodonly=T``: the matcher's disparity where it is within T px of the truth, nothing
  elsewhere (its holes and large errors removed, not filled).

    .venv/bin/python benchmarks/bench_oracle_disparity.py DIR [--scenes 30]
        [--modes matcher,truth,noise=0.5,good=1,goodonly=1]

``DIR`` is a ``stereo-terrain render`` folder (each scene with ``depth_left.npy``).
Columns: detection, step count, rise / run error median and p90 (cm), as ``evaluation``
scores them.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.rectify import RectifiedPair, read_image
from stereo_terrain.stereo import DisparityMap

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_stair_disparity import true_disparity  # noqa: E402


def oracle_backend(mode: str, truth: np.ndarray, matcher, rng: np.random.Generator):
    """A backend whose ``compute`` gives the disparity of ``mode`` (see the module doc)."""
    kind, _, value = mode.partition("=")
    param = float(value) if value else 0.0
    clean = np.where(np.isfinite(truth) & (truth > 0), truth, np.nan).astype(np.float32)

    class Oracle:
        name = "oracle"

        def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
            if kind == "truth":
                d = clean.copy()
            elif kind == "noise":
                d = clean + rng.normal(0.0, param, clean.shape).astype(np.float32)
            elif kind in ("good", "goodonly"):
                m = matcher.compute(pair, max_disparity_px).disparity
                ok = np.isfinite(m) & (np.abs(m - clean) <= param)
                d = np.where(ok, m, np.nan if kind == "goodonly" else clean).astype(np.float32)
            else:
                raise SystemExit(f"unknown mode '{mode}'")
            return DisparityMap(d, max_disparity_px, pair.rectification, None, self.name)

    return Oracle()


def print_scores(title: str, first: str, scores: dict[str, list], *, first_distance: bool = False) -> None:
    """A Markdown table of ``evaluation`` summaries, one row per key of ``scores`` (with the
    first riser's distance error when ``first_distance``)."""
    print(title)
    extra = " 1st distance cm |" if first_distance else ""
    print(f"| {first} | detected | step count | rise median / p90 cm | run median / p90 cm |{extra}")
    print("|" + " --- |" * (6 if first_distance else 5))
    for m, rows in scores.items():
        s = summarize(rows)
        cells = (
            f"| {m} | {s['detection_rate']:.0%} | {s['count_rate']:.0%} | "
            f"{100 * s['rise_median_m']:.1f} / {100 * s['rise_p90_m']:.1f} | "
            f"{100 * s['run_median_m']:.1f} / {100 * s['run_p90_m']:.1f} |"
        )
        if first_distance:
            cells += f" {100 * s['first_distance_median_m']:.1f} / {100 * s['first_distance_p90_m']:.1f} |"
        print(cells)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes_dir", type=Path)
    ap.add_argument("--scenes", type=int, default=30)
    ap.add_argument("--modes", default="matcher,truth,noise=0.5,good=1,goodonly=1")
    ap.add_argument("--seed", type=int, default=0, help="of the added noise")
    args = ap.parse_args()
    modes = args.modes.split(",")
    scores: dict[str, list] = {m: [] for m in modes}
    rng = np.random.default_rng(args.seed)
    dirs = sorted(args.scenes_dir.glob("scene_*"))[: args.scenes]
    for k, d in enumerate(dirs):
        truth_json = json.loads((d / "truth.json").read_text())
        left, right = read_image(d / "left.png"), read_image(d / "right.png")
        calib, rig = read_calibration(d / "calib.yaml"), load_rig(d / "rig.yaml")
        depth = np.load(d / "depth_left.npy")
        for m in modes:
            p = Pipeline(calib, rig, warm_up=False)
            if m != "matcher":
                truth, _ = true_disparity(depth, np.zeros(depth.shape, np.int16), p.rectification)
                p.backend = oracle_backend(m, truth, p.backend, rng)
                no_fill = dataclasses.replace(p.config.fill, enabled=False)
                p.config = dataclasses.replace(p.config, fill=no_fill)
            scores[m].append(score_result(p.run(left, right).to_json_dict(), truth_json))
        sys.stderr.write(f"\rscenes {k + 1}/{len(dirs)}")
    sys.stderr.write("\n")
    print_scores(f"{args.scenes_dir} ({len(dirs)} scenes, rig)", "disparity", scores)


if __name__ == "__main__":
    main()
