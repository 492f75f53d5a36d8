"""Issue 11: how noisy the grid samples' normals are, measured where it decides things.

The orientation method accepts a sample into a plane when its normal is within
``normal_agreement_deg`` (20 deg) of the plane's. A sample's normal comes from the
differences of 9x9 box means of disparity 8 px apart (``cloud.sample_disparity``), so
what the matcher's noise moves is the disparity gradient ``(dd/du, dd/dv)``; a normal's
tilt from a vertical riser is ``atan(f |dd/dv| / d)``. The 20 deg test is thus a gradient
tolerance of ``tan(20 deg) d / f`` px/px, which shrinks with distance, while the
gradient's noise does not.

Printed, per profile (rendered scenes, the pipeline's disparity after its fills, truth
from the renderer's depth):

- the robust sigma (1.4826 MAD) of the vertical gradient's error on riser pixels, and
  the median disparity there, with the gradient tolerance the 20 deg test gives at it;
- per scene of ``--every`` and for the real scenes of ../shared/data: a frame-level
  estimate of the same sigma from the disparity alone (the spread of the differences of
  gradients two grid cells apart, which share no pixel), to see whether a frame's own
  data could set the test.

    .venv/bin/python benchmarks/bench_normal_noise.py [--scenes 20] [--seed 11]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.pipeline import Pipeline

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_real_stairs import real_pairs  # noqa: E402
from bench_stair_disparity import surface_classes, true_disparity  # noqa: E402

K = 4  # the box half-size and half the tangents' length at 640 px (cloud.sample_disparity)


def box_means(d: np.ndarray, k: int = K) -> np.ndarray:
    """Means of the valid disparities in (2k+1)^2 boxes; NaN where fewer than half valid."""
    valid = np.isfinite(d).astype(np.float32)
    total = cv2.boxFilter(np.nan_to_num(d).astype(np.float32), -1, (2 * k + 1, 2 * k + 1), normalize=False)
    count = cv2.boxFilter(valid, -1, (2 * k + 1, 2 * k + 1), normalize=False)
    m = total / np.maximum(count, 1.0)
    m[count < 0.5 * (2 * k + 1) ** 2] = np.nan
    return m


def gradients(d: np.ndarray, k: int = K) -> tuple[np.ndarray, np.ndarray]:
    """(dd/du, dd/dv) from box means k px either side, as the cloud stage takes them."""
    m = box_means(d, k)
    gu, gv = np.full_like(m, np.nan), np.full_like(m, np.nan)
    gu[:, k:-k] = (m[:, 2 * k :] - m[:, : -2 * k]) / (2 * k)
    gv[k:-k] = (m[2 * k :] - m[: -2 * k]) / (2 * k)
    return gu, gv


def robust_sigma(e: np.ndarray) -> float:
    e = e[np.isfinite(e)]
    return float(1.4826 * np.median(np.abs(e - np.median(e)))) if e.size else float("nan")


def frame_sigma(d: np.ndarray, stride: int = 4) -> float:
    """The vertical gradient's noise from one disparity map: differences of gradients two
    grid cells (8 px) apart, robust sigma over sqrt(2)."""
    _, gv = gradients(d)
    g = gv[::stride, ::stride]
    return robust_sigma((g[2:] - g[:-2]).ravel()) / math.sqrt(2.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--every", type=int, default=5)
    args = ap.parse_args()
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    print("| profile | riser pixels | gradient error sigma | p90 abs | median d px | 20 deg test |")
    print("| --- | --- | --- | --- | --- | --- |")
    frames: list[str] = []
    for profile in ("default", "realistic"):
        rng = np.random.default_rng(args.seed)
        errors, disparities, focal = [], [], []
        for i in range(args.scenes):
            scene = render_scene(random_scene_spec(rng, profile=profile))
            result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
            rect = result.disparity.rectification
            truth, labels = true_disparity(scene.depth_left, scene.labels_left, rect)
            classes = surface_classes(labels, [p["name"] for p in scene.truth["planes"]])
            riser = (classes == 1) & np.isfinite(truth)
            riser[:, : result.disparity.max_disparity_px] = False
            measured = gradients(result.disparity.disparity)[1]
            e = (measured - gradients(truth)[1])[riser]
            ok = np.isfinite(e)
            errors.append(e[ok])
            disparities.append(truth[riser][ok])
            focal.append(rect.focal_px)
            if i % args.every == 0:
                frames.append(f"{profile} {i}: {frame_sigma(result.disparity.disparity):.3f}")
        e, d = np.concatenate(errors), np.concatenate(disparities)
        d_med, f = float(np.median(d)), float(np.median(focal))
        print(
            f"| {profile} | {e.size} | {robust_sigma(e):.3f} | {np.percentile(np.abs(e), 90):.3f} "
            f"| {d_med:.1f} | {math.tan(math.radians(20.0)) * d_med / f:.3f} |",
            flush=True,
        )
    for name, calibration, left, right in real_pairs():
        r = Pipeline(calibration, None, warm_up=False).run(left, right)
        frames.append(f"{name}: {frame_sigma(r.disparity.disparity):.3f}")
    print("\nFrame-level estimates of the vertical gradient's sigma (px/px):")
    for line in frames:
        print("-", line)


if __name__ == "__main__":
    main()
