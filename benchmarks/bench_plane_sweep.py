"""Issue 11: would a large-window plane sweep along the scene's three directions match the
faces that SGBM leaves as holes? (Gallup et al. 2007: sweep planes along the dominant
directions, so that a slanted tread stays coherent over a large window.)

For realistic scenes (rendered here, with the renderer's depth as truth),
the pipeline runs once to give the rectified pair it matched, its disparity after the
fills, up and the image lines' horizontal direction ``h``. Then, for each direction
``n`` in (up, h, up x h) and each plane offset (disparity ``d = s n.K^-1(u, v, 1)``, from
the 4 m horizon to the disparity range, steps of ``--step`` px where the plane is
nearest), the right image is warped onto the left and scored by ZNCC over
``--window`` px boxes; each pixel keeps its best plane (winner takes all).

Per scene, on the tread and riser pixels (the left band of ``max_disparity`` columns
left out): the share the pipeline's disparity has within 1 px; the share left as holes;
the sweep's share within 1 px in those holes; and, to tell ambiguity from a search
that misses, the ZNCC of the true disparity's warp against the best one found.

    .venv/bin/python benchmarks/bench_plane_sweep.py [--scenes 9,16] [--seed 11]
        [--window 51] [--step 1.0]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

import stereo_terrain.pipeline.core as core
import stereo_terrain.pipeline.fill_steps as fill_steps
from stereo_terrain.pipeline import Pipeline

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_stair_disparity import surface_classes, true_disparity  # noqa: E402


def _render(seed: int, indices: list[int]) -> dict[int, object]:
    """The realistic scenes ``indices`` of ``render --profile realistic --seed SEED``'s
    sequence (the same draws as ``bench_stair_disparity.load_scenes``)."""
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    rng = np.random.default_rng(seed)
    out = {}
    for i in range(max(indices) + 1):
        spec = random_scene_spec(rng, profile="realistic")
        if i in indices:
            out[i] = render_scene(spec)
    return out


def _capture(scene) -> dict:
    """The pipeline's own view of a scene: the pair it matched, its filled disparity, the
    rectification, up and the lines' horizontal direction (by wrapping two calls)."""
    seen: dict = {}
    manhattan, fill = fill_steps.fill_manhattan_faces, core.fill_faces

    def manhattan_hook(*a, **k):
        seen["up"], seen["h"] = np.asarray(a[6], float), np.asarray(a[7], float)
        return manhattan(*a, **k)

    def fill_hook(disp, pair, *rest):
        out = fill(disp, pair, *rest)
        seen.update(
            left=pair.left, right=pair.right, rect=pair.rectification, final=out.disparity.disparity.copy()
        )
        seen["max_d"] = disp.max_disparity_px
        return out

    fill_steps.fill_manhattan_faces, core.fill_faces = manhattan_hook, fill_hook
    try:
        Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    finally:
        fill_steps.fill_manhattan_faces, core.fill_faces = manhattan, fill
    return seen


def _zncc(left: np.ndarray, warped: np.ndarray, window: int) -> np.ndarray:
    def box(x: np.ndarray) -> np.ndarray:
        return cv2.boxFilter(x, -1, (window, window), borderType=cv2.BORDER_REFLECT)

    ml, mw = box(left), box(warped)
    cov = box(left * warped) - ml * mw
    var = (box(left * left) - ml * ml) * (box(warped * warped) - mw * mw)
    return cov / np.sqrt(np.maximum(var, 1e-2))


def sweep(seen: dict, window: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the best ZNCC over the three directions' planes and its disparity."""
    left, right = seen["left"].astype(np.float32), seen["right"].astype(np.float32)
    rect = seen["rect"]
    P1 = rect.P1
    f, cx, cy = P1[0, 0], P1[0, 2], P1[1, 2]
    h, w = left.shape
    uu, vv = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    rx, ry = (uu - cx) / f, (vv - cy) / f
    up, hd = seen["up"], seen["h"]
    families = [(up, (-1,)), (hd, (1, -1)), (np.cross(up, hd), (1, -1))]
    max_d = seen["max_d"]
    d_min = max(rect.focal_px * rect.baseline_m / 4.0, 1.0)
    best = np.full((h, w), -2.0, np.float32)
    best_d = np.full((h, w), np.nan, np.float32)
    for n, signs in families:
        n = n / np.linalg.norm(n)
        g = (n[0] * rx + n[1] * ry + n[2]).astype(np.float32)
        for sign in signs:
            gs = sign * g
            pos = gs[gs > 1e-3]
            if pos.size == 0:
                continue
            s, s_max = d_min / float(pos.max()), max_d / max(float(np.percentile(pos, 1)), 0.02)
            while s <= s_max:
                d = (s * gs).astype(np.float32)
                ok = (d >= d_min) & (d <= max_d)
                if ok.any():
                    warped = cv2.remap(right, uu - d, vv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
                    z = _zncc(left, warped, window)
                    z[~ok] = -2.0
                    better = z > best
                    best[better], best_d[better] = z[better], d[better]
                s += step / min(float(pos.max()), max_d / s)
    return best, best_d


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", default="9,16")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--window", type=int, default=51)
    ap.add_argument("--step", type=float, default=1.0)
    args = ap.parse_args()
    idx = [int(i) for i in args.scenes.split(",")]
    scenes = _render(args.seed, idx)
    print("| scene | pipeline <= 1 px | holes | sweep <= 1 px in the holes | true ZNCC near the best | s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for i in idx:
        scene = scenes[i]
        seen = _capture(scene)
        if "up" not in seen:
            print(f"| {i} | (no Manhattan fill ran: no horizontal direction) | | | | |")
            continue
        t0 = time.perf_counter()
        best, best_d = sweep(seen, args.window, args.step)
        truth, labels = true_disparity(scene.depth_left, scene.labels_left, seen["rect"])
        classes = surface_classes(labels, [p["name"] for p in scene.truth["planes"]])
        face = ((classes == 0) | (classes == 1)) & np.isfinite(truth)  # treads and risers
        face[:, : seen["max_d"]] = False
        holes = face & ~np.isfinite(seen["final"])
        h, w = truth.shape
        uu, vv = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
        warped = cv2.remap(
            seen["right"].astype(np.float32),
            uu - np.nan_to_num(truth).astype(np.float32),
            vv,
            cv2.INTER_LINEAR,
        )
        z_true = _zncc(seen["left"].astype(np.float32), warped, args.window)
        print(
            f"| {i} | {np.mean(np.abs(seen['final'][face] - truth[face]) <= 1):.0%} "
            f"| {holes.sum() / face.sum():.0%} "
            f"| {np.mean(np.abs(best_d[holes] - truth[holes]) <= 1) if holes.any() else 0:.0%} "
            f"| {np.mean(z_true[face] >= best[face] - 0.02):.0%} | {time.perf_counter() - t0:.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
