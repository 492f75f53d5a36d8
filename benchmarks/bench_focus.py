"""Issue 11: how well the two webcams' focus difference is found from the images alone
(:func:`stereo_terrain.stereo.blur.relative_blur_px`), on rendered scenes whose truth.json
holds each camera's blur (the realistic profile blurs the two raw images on their own,
0.5-1.5 px; the default profile blurs both alike). Results are recorded in
docs/benchmarks.md ("Fifteenth session").

    .venv/bin/python benchmarks/bench_focus.py SCENES_DIR [SCENES_DIR ...]

Per folder: the estimate's error against the true difference ``sqrt(|s_R^2 - s_L^2|)``
with its sign (median and p90, pixels), how often the blurrier image is named wrong where
the difference is over 0.5 px, how often the focus rematch would run (estimate at least
``MIN_BLUR_PX``), and the time (median ms) on the rectified pair of the estimate and of
the pipeline's decision (``at_least_px=MIN_BLUR_PX``: a pair focused alike skips the
bisection).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.rectify import compute_rectification, read_image, rectify
from stereo_terrain.stereo.blur import MIN_BLUR_PX, relative_blur_px


def true_difference(spec: dict) -> float:
    """The signed blur difference of a rendered scene's spec (positive: right blurrier)."""
    left = float(spec["blur_sigma_px"])
    right = spec.get("right_blur_sigma_px")
    right = left if right is None else float(right)
    return math.copysign(math.sqrt(abs(right**2 - left**2)), right - left)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes_dir", type=Path, nargs="+")
    args = ap.parse_args()
    print(
        "| scenes | n | error median / p90 (px) | wrong image (diff > 0.5 px) | would run | ms "
        "| decision ms |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for folder in args.scenes_dir:
        rows = []
        for d in sorted(folder.glob("scene_*")):
            truth = json.loads((d / "truth.json").read_text())
            rect = compute_rectification(read_calibration(d / "calib.yaml"))
            pair = rectify(read_image(d / "left.png"), read_image(d / "right.png"), rect)
            t0 = time.perf_counter()
            got = relative_blur_px(pair.left, pair.right, rect.valid_left, rect.valid_right)
            t1 = time.perf_counter()
            valid = (rect.valid_left, rect.valid_right)
            relative_blur_px(pair.left, pair.right, *valid, at_least_px=MIN_BLUR_PX)
            t2 = time.perf_counter()
            rows.append((true_difference(truth["spec"]), got, (t1 - t0) * 1000.0, (t2 - t1) * 1000.0))
        if not rows:
            continue
        a = np.array(rows)
        err = np.abs(a[:, 0] - a[:, 1])
        big = np.abs(a[:, 0]) > 0.5
        wrong = int(np.sum(big & (np.sign(a[:, 0]) != np.sign(a[:, 1]))))
        runs = float(np.mean(np.abs(a[:, 1]) >= MIN_BLUR_PX))
        print(
            f"| {folder.name} | {len(a)} | {np.median(err):.2f} / {np.percentile(err, 90):.2f} | "
            f"{wrong} of {int(big.sum())} | {100 * runs:.0f}% | {np.median(a[:, 2]):.1f} | "
            f"{np.median(a[:, 3]):.1f} |"
        )


if __name__ == "__main__":
    main()
