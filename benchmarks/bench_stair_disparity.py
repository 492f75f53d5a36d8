"""Issue 11, part 4: per-pixel disparity on the stair faces of rendered scenes.

For each matcher variant, the disparity of the rectified left image (after the pipeline's
own rectification and per-frame vertical alignment, before or after the planar fill)
against the truth from the renderer's depth, split by the surface the truth labels give:
``tread``, ``riser`` and ``other`` (floor, walls, rails, balusters, stair sides). Columns:
``good`` (error <= 1 px), ``mid`` (1-3 px), ``bad`` (> 3 px), ``invalid`` (NaN) as shares
of the pixels the truth reaches, ``bad-`` the share of the bad ones whose disparity is too
small (too far), and the median milliseconds of the matcher (with the fill when it is
part of the variant), measured side by side in one run.

    .venv/bin/python benchmarks/bench_stair_disparity.py [--profile realistic] [--scenes 60]
        [--seed 11] [--variants opencv,opencv+fill,sgm,...] [--cache DIR]

``--middlebury DIR`` instead scores the same variants on Middlebury-layout scenes (bad-2.0
over the non-occluded pixels, a missing disparity counting as bad, and the density), each
with its own ``ndisp`` rounded up to 16 as ``eval-disparity`` does.

``--cache DIR`` keeps the rectified pairs and their truth in ``DIR`` (one ``.npz`` per
scene), so that a second run does not render again. The scenes are those ``stereo-terrain
render --profile P --count N --seed S`` writes.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import Rectification, RectifiedPair, rectify
from stereo_terrain.stereo.fill import fill_planar_regions
from stereo_terrain.stereo.vertical import align_vertical

SURFACES = ("tread", "riser", "other")


def true_disparity(
    depth: np.ndarray, labels: np.ndarray, rect: Rectification
) -> tuple[np.ndarray, np.ndarray]:
    """Rectified left disparity from the raw left depth (nearest raw pixel), and the label
    of each rectified pixel (index into ``truth["planes"]``, -1 unlisted, -2 no surface)."""
    m1, m2 = rect.maps[0], rect.maps[1]
    if m1.dtype != np.float32 or m1.ndim != 2:
        m1, m2 = cv2.convertMaps(m1, m2, cv2.CV_32FC1)
    z = cv2.remap(depth, m1, m2, cv2.INTER_NEAREST, borderValue=np.nan)
    lab = cv2.remap(labels.astype(np.float32), m1, m2, cv2.INTER_NEAREST, borderValue=-2)
    h, w = z.shape
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    ray = np.stack([(u - rect.cx) / rect.focal_px, (v - rect.cy) / rect.focal_px, np.ones_like(u)], -1)
    z_rect = z / (ray @ rect.T_camera_rect.matrix[2, :3])
    d = (rect.focal_px * rect.baseline_m / z_rect - rect.doffs_px).astype(np.float32)
    lab = np.where(np.isfinite(d), lab, -2)
    return d, lab.astype(np.int16)


def surface_classes(labels: np.ndarray, names: list[str]) -> np.ndarray:
    """0 tread, 1 riser, 2 other surface, -1 none, per pixel."""
    table = np.full(len(names) + 3, 2, dtype=np.int8)
    for k, name in enumerate(names):
        table[k] = 0 if name.startswith("tread") else 1 if name.startswith("riser") else 2
    table[-2] = -1  # labels -2: no surface
    table[-1] = 2  # labels -1: unlisted faces (rails, balusters, sides)
    return table[labels]


def load_scenes(profile: str, count: int, seed: int, cache: Path | None, vertical: bool = True) -> list[dict]:
    """The rectified pairs of the scenes (vertically aligned as the pipeline does unless
    ``vertical`` is False), their truth and classes."""
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    rng = np.random.default_rng(seed)
    scenes = []
    for i in range(count):
        path = None if cache is None else cache / f"{profile}_{seed}{'' if vertical else '_nov'}_{i:03d}.npz"
        spec = random_scene_spec(rng, profile=profile)  # always drawn: keeps the sequence
        if path is not None and path.exists():
            data = dict(np.load(path, allow_pickle=False))
        else:
            scene = render_scene(spec)
            pipe = Pipeline(scene.calibration, scene.rig)
            pair = rectify(scene.left, scene.right, pipe.rectification)
            if vertical:
                pair, _ = align_vertical(pair, pipe.config.vertical)
            truth, labels = true_disparity(scene.depth_left, scene.labels_left, pipe.rectification)
            names = [p["name"] for p in scene.truth["planes"]]
            data = {
                "left": pair.left,
                "right": pair.right,
                "truth": truth,
                "cls": surface_classes(labels, names),
                "max_disparity": np.int64(pipe.max_disparity_px),
                "raw_left": scene.left,
                "raw_right": scene.right,
                "K1": scene.calibration.K1,
                "D1": scene.calibration.D1,
                "K2": scene.calibration.K2,
                "D2": scene.calibration.D2,
                "R": scene.calibration.R,
                "T": scene.calibration.T,
            }
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                np.savez_compressed(path, **data)
        data["index"] = i
        scenes.append(data)
        sys.stderr.write(f"\rscenes {i + 1}/{count}")
    sys.stderr.write("\n")
    return scenes


def _pair(scene: dict) -> tuple[RectifiedPair, Rectification]:
    """A RectifiedPair for the cached images (the rectification rebuilt from the calibration)."""
    from stereo_terrain.calibration import StereoCalibration

    h, w = scene["raw_left"].shape
    calib = StereoCalibration(
        scene["K1"], scene["D1"], scene["K2"], scene["D2"], scene["R"], scene["T"], (w, h)
    )
    pipe = Pipeline(calib)
    pair = rectify(scene["raw_left"], scene["raw_right"], pipe.rectification)
    pair = dataclasses.replace(pair, left=scene["left"], right=scene["right"])
    return pair, pipe.rectification


def variant(name: str) -> Callable[[RectifiedPair, int], np.ndarray]:
    """A matcher by name: ``BACKEND[:key=value,...][+fill]`` with BACKEND ``opencv`` or
    ``sgm`` and the keys of its config (ints, floats or strings)."""
    from stereo_terrain.stereo import make_backend

    fill = name.endswith("+fill")
    base = name[: -len("+fill")] if fill else name
    backend_name, _, opts = base.partition(":")
    options: dict = {}
    for item in filter(None, opts.split(",")):
        key, _, value = item.partition("=")
        for cast in (int, float):
            try:
                options[key] = cast(value)
                break
            except ValueError:
                continue
        else:
            options[key] = value
    backend = make_backend(backend_name, **options)
    fill_config = PipelineConfig().fill

    def run(pair: RectifiedPair, n: int) -> np.ndarray:
        disp = backend.compute(pair, n).disparity
        if fill:
            disp, _ = fill_planar_regions(
                disp, pair.left, fill_config, max_disparity_px=n, valid=pair.rectification.valid_left
            )
        return disp

    return run


def table_head(title: str, columns: list[str]) -> None:
    """Print a title line and a Markdown table's header."""
    print(title)
    print("| " + " | ".join(columns) + " |")
    print("|" + " --- |" * len(columns))


def score(disp: np.ndarray, truth: np.ndarray, cls: np.ndarray, counts: np.ndarray) -> None:
    """Adds per class (rows: tread, riser, other) the pixel counts good, mid, bad,
    invalid, bad-too-small into ``counts`` (3, 5)."""
    err = disp - truth
    for c in range(3):
        m = cls == c
        e = err[m]
        fin = np.isfinite(e)
        a = np.abs(e[fin])
        counts[c] += (
            np.sum(a <= 1.0),
            np.sum((a > 1.0) & (a <= 3.0)),
            np.sum(a > 3.0),
            np.sum(~fin),
            np.sum(e[fin] < -3.0),
        )


def middlebury(root: Path, names: list[str]) -> None:
    from stereo_terrain.evaluation import disparity_errors, middlebury_scene_dirs, read_middlebury_scene
    from stereo_terrain.rectify import compute_rectification
    from stereo_terrain.stereo import default_max_disparity

    runs = {name: variant(name) for name in names}
    print("| scene | " + " | ".join(names) + " |")
    print("| --- |" + " --- |" * len(names))
    rows = []
    for d in middlebury_scene_dirs(root):
        scene = read_middlebury_scene(d)
        rect = compute_rectification(scene.calibration)
        pair = rectify(scene.left, scene.right, rect)
        n = default_max_disparity(rect, PipelineConfig().min_depth_m)
        errs = [disparity_errors(run(pair, n), scene.truth, scene.nonoccluded) for run in runs.values()]
        rows.append([(e["bad2"], e["density"]) for e in errs])
        print(
            f"| {scene.name} | " + " | ".join(f"{b:.1%} / {dn:.0%}" for b, dn in rows[-1]) + " |", flush=True
        )
    mean = np.mean(np.array(rows), axis=0)
    print("| mean | " + " | ".join(f"{b:.1%} / {dn:.0%}" for b, dn in mean) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="realistic")
    ap.add_argument("--scenes", type=int, default=60)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--variants", default="opencv,opencv+fill,sgm,sgm+fill")
    ap.add_argument("--cache", type=Path)
    ap.add_argument("--middlebury", type=Path, help="score on Middlebury-layout scenes instead")
    ap.add_argument("--no-vertical", action="store_true", help="without the per-frame vertical alignment")
    ap.add_argument("--per-scene", action="store_true", help="also print stair-face good %% per scene")
    args = ap.parse_args()
    if args.middlebury:
        middlebury(
            args.middlebury, args.variants.split(";") if ";" in args.variants else args.variants.split(",")
        )
        return
    scenes = load_scenes(args.profile, args.scenes, args.seed, args.cache, not args.no_vertical)
    names = args.variants.split(";") if ";" in args.variants else args.variants.split(",")
    runs = {name: variant(name) for name in names}
    counts = {name: np.zeros((3, 5), dtype=np.int64) for name in names}
    times: dict[str, list[float]] = {name: [] for name in names}
    per_scene: dict[str, list[float]] = {name: [] for name in names}
    for scene in scenes:
        pair, _ = _pair(scene)
        n = int(scene["max_disparity"])
        for name, run in runs.items():  # side by side, scene by scene
            run(pair, n)  # warm (compilation, buffers)
            t = time.perf_counter()
            disp = run(pair, n)
            times[name].append((time.perf_counter() - t) * 1000.0)
            before = counts[name].copy()
            score(disp, scene["truth"], scene["cls"], counts[name])
            d = (counts[name] - before)[:2].sum(axis=0)
            per_scene[name].append(d[0] / max(1, d[:4].sum()))
        sys.stderr.write(f"\rscored {scene['index'] + 1}/{len(scenes)}")
    sys.stderr.write("\n")
    table_head(
        f"{args.profile}, {len(scenes)} scenes, seed {args.seed}",
        ["variant", "surface", "good <= 1 px", "1-3 px", "bad > 3 px", "invalid", "bad too far", "ms"],
    )
    for name in names:
        c = counts[name]
        rows = [(s, c[i]) for i, s in enumerate(SURFACES)] + [("stair faces", c[0] + c[1])]
        for surface, r in rows:
            total = max(1, r[:4].sum())
            print(
                f"| {name} | {surface} | {r[0] / total:.1%} | {r[1] / total:.1%} | {r[2] / total:.1%} | "
                f"{r[3] / total:.1%} | {r[4] / max(1, r[2]):.0%} | {np.median(times[name]):.1f} |"
            )
    if args.per_scene:
        for name in names:
            print(name, " ".join(f"{v:.2f}" for v in per_scene[name]))


if __name__ == "__main__":
    main()
