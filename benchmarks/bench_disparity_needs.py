"""Issue 11, part 4: what disparity the plane and terrain stages need, on realistic scenes.

The pipeline (with the true rig) is fed the true disparity of each scene (from the
renderer's depth, see ``bench_stair_disparity.py``), degraded in one controlled way at a
time, and scored end to end: detection, step count, rise error (median / p90, cm).

- ``truth``: as it is;
- ``round``: rounded to whole pixels (what SGM leaves where its costs are flat);
- ``round+smooth R``: then the local-plane smoothing of ``stereo/smooth.py`` (radius R);
- ``noise S``: Gaussian noise of S px on every pixel;
- ``holes F``: a share F of the pixels invalid, in blobs;
- ``outliers F``: a share F of the pixels 3-15 px too small (too far, as most of the
  matchers' bad pixels are);
- ``truth where M``: the truth only where matcher variant M (``bench_stair_disparity``
  syntax) has a value: the matcher's coverage with perfect values.

    .venv/bin/python benchmarks/bench_disparity_needs.py --scenes-dir DIR [--scenes 20] \\
        [--cache CACHE] [--matchers "opencv;sgm:census_epsilon_grey=8"] [--config CFG.yaml]
        [--modes "truth;round;noise 0.7"]

``--config`` runs the stages after the disparity with that pipeline config (e.g. the
plane stage's thresholds); ``--modes`` picks the degradations (``;``-separated).

``DIR`` holds the scenes ``stereo-terrain render --profile realistic --count N --seed S``
wrote; the same seed is drawn again for the truth labels and disparities.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np
from bench_stair_disparity import load_scenes, table_head, variant

from stereo_terrain.calibration import read_calibration
from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image, rectify
from stereo_terrain.stereo import DisparityMap
from stereo_terrain.stereo.smooth import smooth_planar
from stereo_terrain.stereo.vertical import align_vertical


class GivenDisparity:
    """A backend that returns a given disparity map (the pipeline's stages after it run
    as usual, the planar fill included)."""

    name = "given"

    def __init__(self, disparity: np.ndarray) -> None:
        self.disparity = disparity

    def compute(self, pair, max_disparity_px: int) -> DisparityMap:
        return DisparityMap(self.disparity.copy(), max_disparity_px, pair.rectification, None, self.name)


def degrade(mode: str, truth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    kind, _, value = mode.partition(" ")
    d = truth.copy()
    if kind == "round":
        return np.round(d)
    if kind == "round+smooth":
        return smooth_planar(np.round(d), int(value))
    if kind == "noise":
        return (d + rng.normal(0.0, float(value), d.shape)).astype(np.float32)
    if kind == "holes":
        field = cv2.GaussianBlur(rng.normal(size=d.shape).astype(np.float32), (0, 0), 6)
        d[field < np.quantile(field, float(value))] = np.nan
        return d
    if kind == "outliers":
        hit = rng.random(d.shape) < float(value)
        d[hit] -= rng.uniform(3.0, 15.0, int(hit.sum())).astype(np.float32)
        return d
    return d


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes-dir", type=Path, required=True)
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--cache", type=Path)
    ap.add_argument("--matchers", default="opencv;sgm:census_epsilon_grey=8")
    ap.add_argument("--config", type=Path, help="pipeline config YAML for the stages after the disparity")
    ap.add_argument("--modes", default="truth;round;round+smooth 5;noise 0.7;holes 0.5;outliers 0.15")
    args = ap.parse_args()
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    scenes = load_scenes("realistic", args.scenes, args.seed, args.cache)
    modes = [m for m in args.modes.split(";") if m]
    matchers = {name: variant(name) for name in args.matchers.split(";") if name}
    labels = modes + [f"truth where {m}" for m in matchers]
    scores: dict[str, list] = {k: [] for k in labels}
    rng = np.random.default_rng(0)
    for scene in scenes:
        d = args.scenes_dir / f"scene_{scene['index']:03d}"
        truth_json = json.loads((d / "truth.json").read_text())
        left, right = read_image(d / "left.png"), read_image(d / "right.png")
        calib, rig = read_calibration(d / "calib.yaml"), load_rig(d / "rig.yaml")
        truth = scene["truth"].astype(np.float32)
        maps = {mode: degrade(mode, truth, rng) for mode in modes}
        if matchers:
            p = Pipeline(calib, rig)
            pair, _ = align_vertical(rectify(left, right, p.rectification), p.config.vertical)
            for name, run in matchers.items():
                est = run(pair, p.max_disparity_px)
                maps[f"truth where {name}"] = np.where(np.isfinite(est), truth, np.nan).astype(np.float32)
        for label, disp in maps.items():
            result = Pipeline(calib, rig, config, backend=GivenDisparity(disp)).run(left, right)
            scores[label].append(score_result(result.to_json_dict(), truth_json))
        sys.stderr.write(f"\r{scene['index'] + 1}/{len(scenes)}")
    sys.stderr.write("\n")
    table_head(
        f"realistic, {len(scenes)} scenes, seed {args.seed}, true rig",
        ["disparity fed to the pipeline", "detected", "step count", "rise cm med / p90"],
    )
    for label in labels:
        s = summarize(scores[label])
        print(
            f"| {label} | {s['detection_rate']:.0%} | {s['count_rate']:.0%} | "
            f"{s['rise_median_m'] * 100:.1f} / {s['rise_p90_m'] * 100:.1f} |"
        )


if __name__ == "__main__":
    main()
