"""Streak invalidation / row fill of stereo/fill.py, measured where it matters.

Usage::

    PYTHONPATH=src python benchmarks/bench_fill_streaks.py realistic 16
    PYTHONPATH=src python benchmarks/bench_fill_streaks.py middlebury /work/shared/data/middlebury2014Q
    PYTHONPATH=src python benchmarks/bench_fill_streaks.py time

``realistic N``: rectified disparity of N realistic-profile scenes (seed 11, true rig) against
the renderer's depth (turned into rectified disparity), for each fill variant: density,
bad-2 of the pixels that have a value, and ``good`` (|err| <= 1 px, as a fraction of all
pixels with truth). ``middlebury ROOT``: Middlebury bad-2 (missing counts as bad, like
``eval-disparity``) and density, matcher + fill. ``time``: ms of each variant at 640x480.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import rectify
from stereo_terrain.stereo.fill import PlanarFillConfig, fill_planar_regions
from stereo_terrain.stereo.vertical import align_vertical

VARIANTS = {
    "off": PlanarFillConfig(enabled=False),
    "default": PlanarFillConfig(),
    "invalidate": PlanarFillConfig(invalidate=True),
    "invalidate+rows": PlanarFillConfig(invalidate=True, row_fill_max_gap_px=640),
    "horizontal": PlanarFillConfig(texture="horizontal", invalidate=True, split_gradient=1.2),
}


def _realistic(n: int, seed: int = 11):
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    rng = np.random.default_rng(seed)
    for _ in range(n):
        sc = render_scene(random_scene_spec(rng, profile="realistic"))
        p = Pipeline(sc.calibration, sc.rig, PipelineConfig())
        pair, _ = align_vertical(rectify(sc.left, sc.right, p.rectification), p.config.vertical)
        disp = p.backend.compute(pair, p.max_disparity_px)
        r = p.rectification
        # Truth: the raw left depth seen through the rectification, Z turned into the
        # rectified camera's Z (rectified ray r: raw ray R1^T r, Z_rect = Z_raw / (R1^T r).z).
        z_raw = cv2.remap(
            np.nan_to_num(sc.depth_left).astype(np.float32), r.maps[0], r.maps[1], cv2.INTER_NEAREST
        )
        h, w = z_raw.shape
        u, v = np.meshgrid(np.arange(w), np.arange(h))
        ray = np.stack([(u - r.cx) / r.focal_px, (v - r.cy) / r.focal_px, np.ones((h, w))], -1)
        with np.errstate(divide="ignore"):
            gt = np.where(
                z_raw > 0, r.focal_px * r.baseline_m * (ray @ r.R1)[..., 2] / z_raw - r.doffs_px, np.nan
            )
        yield pair.left, disp.disparity, gt, r.valid_left, disp.max_disparity_px


def bench_realistic(n: int) -> None:
    scenes = list(_realistic(n))
    print("| variant | density | bad-2 of valid | good (<=1 px) of all |")
    print("| --- | --- | --- | --- |")
    for name, cfg in VARIANTS.items():
        rows = []
        for left, d0, gt, valid, maxd in scenes:
            d, _ = fill_planar_regions(d0, left, cfg, max_disparity_px=maxd, valid=valid)
            m = np.isfinite(gt) & (valid if valid is not None else True)
            fin = np.isfinite(d) & m
            err = np.abs(d - gt)
            rows.append(
                (
                    fin.sum() / m.sum(),
                    (fin & (err > 2)).sum() / max(fin.sum(), 1),
                    (fin & (err <= 1)).sum() / m.sum(),
                )
            )
        a = np.mean(rows, axis=0)
        print(f"| {name} | {a[0]:.1%} | {a[1]:.1%} | {a[2]:.1%} |", flush=True)


def bench_middlebury(root: Path) -> None:
    from stereo_terrain.cli.scene import _pair_disparity
    from stereo_terrain.evaluation import disparity_errors, middlebury_scene_dirs, read_middlebury_scene

    scenes = []
    for d in middlebury_scene_dirs(root):
        s = read_middlebury_scene(d)
        dm, _ = _pair_disparity("opencv", s.calibration, s.left, s.right, None)
        left = s.left if s.left.ndim == 2 else cv2.cvtColor(s.left, cv2.COLOR_BGR2GRAY)
        scenes.append((s, dm, left))
    print("| variant | bad-2 nonocc | density |")
    print("| --- | --- | --- |")
    for name, cfg in VARIANTS.items():
        e = []
        for s, dm, left in scenes:
            d, _ = fill_planar_regions(dm.disparity, left, cfg, max_disparity_px=dm.max_disparity_px)
            r = disparity_errors(d, s.truth, s.nonoccluded)
            e.append((r["bad2"], r["density"]))
        a = np.mean(e, axis=0)
        print(f"| {name} | {a[0]:.1%} | {a[1]:.0%} |", flush=True)


def bench_time(repeats: int = 10) -> None:
    left, d0, _, valid, maxd = next(_realistic(4))  # scene 0 of the realistic set
    print(f"| variant | ms (640x480, median of {repeats}) |")
    print("| --- | --- |")
    for name, cfg in VARIANTS.items():
        ts = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fill_planar_regions(d0, left, cfg, max_disparity_px=maxd, valid=valid)
            ts.append((time.perf_counter() - t0) * 1000)
        print(f"| {name} | {np.median(ts):.1f} |", flush=True)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "realistic"
    if what == "realistic":
        bench_realistic(int(sys.argv[2]) if len(sys.argv) > 2 else 16)
    elif what == "middlebury":
        bench_middlebury(Path(sys.argv[2]))
    elif what == "time":
        bench_time()
    else:
        raise SystemExit(f"unknown benchmark {what!r}: realistic | middlebury | time")
