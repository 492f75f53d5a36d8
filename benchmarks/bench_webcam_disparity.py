"""Disparity and terrain under webcam faults: vertical misalignment, JPEG, wood grain.

Two parts, each a table of ``before`` (the pipeline as it was: OpenCV ``alpha = 0``
rectification, no vertical alignment) against ``after`` (``full-height`` rectification,
per-frame vertical alignment) for the ``opencv`` and ``sgm`` backends:

1. **Rendered scenes** (the renderer's random mix at 640x480, plus scenes whose treads and
   risers are wood with plank seams). Perturbed like a webcam: the raw right image shifted
   down by 0, 1 or 2 px and both images JPEG-compressed (quality 60-85). Scored end to end
   (:func:`stereo_terrain.evaluation.score_result`) and by the disparity of the rectified
   left image against the renderer's exact depth (bad-2.0: error > 2 px or no disparity,
   over the pixels the truth reaches; density; wrong: error > 2 px among the pixels with
   a disparity).
2. **Middlebury 2014 (quarter size, 8 scenes)** with the right image shifted down by 0, 1
   or 2 px and JPEG at quality 75: bad-2.0 and density over the non-occluded pixels.

    .venv/bin/python benchmarks/bench_webcam_disparity.py [--scenes 10] [--seed 11] \
        [--middlebury ../shared/data/middlebury2014Q] [--skip-rendered] [--skip-middlebury]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.evaluation import (
    disparity_errors,
    middlebury_scene_dirs,
    read_middlebury_scene,
    score_result,
    summarize,
)
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import compute_rectification, rectify
from stereo_terrain.stereo import default_max_disparity, make_backend
from stereo_terrain.stereo.vertical import VerticalAlignConfig, align_vertical
from stereo_terrain.synthetic import SurfaceSpec, random_scene_spec, render_scene

BEFORE = {"rectify_fov": "valid", "vertical": VerticalAlignConfig(enabled=False)}
AFTER = {"rectify_fov": "full-height"}  # and the vertical alignment, on by default


def shift_down(image: np.ndarray, dy: float) -> np.ndarray:
    """``image`` moved down by ``dy`` pixels (content of row y now at row y + dy)."""
    if dy == 0:
        return image
    M = np.float32([[1, 0, 0], [0, 1, dy]])
    return cv2.warpAffine(
        image, M, image.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    )


def jpeg(image: np.ndarray, quality: int | None) -> np.ndarray:
    if quality is None:
        return image
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    assert ok
    return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)


def truth_disparity(scene, rect) -> np.ndarray:
    """Disparity of the rectified left image from the raw left depth (NaN where unknown):
    each raw pixel's surface point moved into the rectified camera and projected (nearest
    rectified pixel; the nearest surface wins)."""
    calib = scene.calibration
    h, w = scene.depth_left.shape
    ys, xs = np.mgrid[0:h, 0:w]
    z = scene.depth_left.ravel()
    ok = np.isfinite(z)
    pts = np.column_stack([xs.ravel()[ok], ys.ravel()[ok]]).astype(np.float64).reshape(-1, 1, 2)
    n = cv2.undistortPoints(pts, calib.K1, calib.D1).reshape(-1, 2)
    X = np.column_stack([n * z[ok, None], z[ok]])
    Xr = X @ rect.R1.T
    u = rect.focal_px * Xr[:, 0] / Xr[:, 2] + rect.cx
    v = rect.focal_px * Xr[:, 1] / Xr[:, 2] + rect.cy
    d = rect.focal_px * rect.baseline_m / Xr[:, 2]
    ui, vi = np.rint(u).astype(int), np.rint(v).astype(int)
    inside = (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
    out = np.full((h, w), -np.inf, np.float32)
    np.maximum.at(out, (vi[inside], ui[inside]), d[inside].astype(np.float32))
    out[~np.isfinite(out)] = np.nan
    return out


def rendered_specs(n: int, seed: int) -> list[tuple[str, object]]:
    rng = np.random.default_rng(seed)
    specs = [("mix", random_scene_spec(rng, kind="stairs", supersample=1)) for _ in range(n)]
    wood = SurfaceSpec("wood", 0.8, 0.6, 0.2)
    specs += [
        (
            "wood",
            random_scene_spec(rng, kind="stairs", weak_texture=False, supersample=1, tread=wood, riser=wood),
        )
        for _ in range(max(2, n // 3))
    ]
    return specs


PERTURB = [
    ("clean", 0.0, None),
    ("shift 1 px", 1.0, None),
    ("shift 2 px", 2.0, None),
    ("2 px + JPEG", 2.0, "q"),
]


def part_rendered(n: int, seed: int) -> None:
    rng = np.random.default_rng(seed + 1000)
    specs = rendered_specs(n, seed)
    configs = {
        (backend, tag): PipelineConfig(backend=backend, **opts)
        for backend in ("opencv", "sgm")
        for tag, opts in (("before", BEFORE), ("after", AFTER))
    }
    rows: dict[tuple, list] = {}
    for group, spec in specs:
        scene = render_scene(spec)
        qual = int(rng.integers(60, 86))
        for pname, dy, q in PERTURB:
            right = jpeg(shift_down(scene.right, dy), qual if q else None)
            left = jpeg(scene.left, qual if q else None)
            for (backend, tag), cfg in configs.items():
                p = Pipeline(scene.calibration, scene.rig, cfg)
                res = p.run(left, right)
                truth = truth_disparity(scene, p.rectification)
                known = np.isfinite(truth)
                disp = res.disparity.disparity
                err = disparity_errors(disp, truth)
                have = known & np.isfinite(disp)
                wrong = float(np.mean(np.abs(disp[have] - truth[have]) > 2.0)) if have.any() else 0.0
                score = score_result(res.to_json_dict(), scene.truth)
                for g in (group, "all"):
                    rows.setdefault((g, pname, backend, tag), []).append(
                        (err["bad2"], err["density"], wrong, score)
                    )
    print(
        "| scenes | perturbation | backend | version | n | bad-2.0 | density | wrong | detected | "
        "count right | rise med cm | rise p90 cm |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (g, pname, backend, tag), vals in rows.items():
        a = np.array([v[:3] for v in vals])
        s = summarize([v[3] for v in vals])
        print(
            f"| {g} | {pname} | {backend} | {tag} | {len(vals)} | {a[:, 0].mean():.1%} | "
            f"{a[:, 1].mean():.1%} | {a[:, 2].mean():.1%} | {s['detection_rate']:.0%} | "
            f"{s['count_rate']:.0%} | "
            f"{s['rise_median_m'] * 100:.1f} | {s['rise_p90_m'] * 100:.1f} |"
        )


def part_middlebury(root: Path) -> None:
    scenes = [read_middlebury_scene(d) for d in middlebury_scene_dirs(root)]
    backends = {"opencv": make_backend("opencv"), "sgm": make_backend("sgm")}
    on = VerticalAlignConfig()
    out: dict[tuple, list] = {}
    for sc in scenes:
        rect = compute_rectification(sc.calibration)
        n = default_max_disparity(rect, 0.7)
        for pname, dy, q in PERTURB:
            right = jpeg(shift_down(sc.right, dy), 75 if q else None)
            left = jpeg(sc.left, 75 if q else None)
            pair = rectify(left, right, rect)
            aligned, _est = align_vertical(pair, on)
            for bname, backend in backends.items():
                for tag, pr in (("before", pair), ("after", aligned)):
                    d = backend.compute(pr, n).disparity
                    e = disparity_errors(d, sc.truth, sc.nonoccluded)
                    out.setdefault((pname, bname, tag), []).append((e["bad2"], e["density"]))
    print("| perturbation | backend | version | bad-2.0 (mean of 8) | density |")
    print("| --- | --- | --- | --- | --- |")
    for (pname, bname, tag), vals in out.items():
        a = np.array(vals)
        print(f"| {pname} | {bname} | {tag} | {a[:, 0].mean():.1%} | {a[:, 1].mean():.1%} |")


def timing() -> None:
    """Milliseconds of the new steps at 640x480, side by side with the matchers."""
    spec = random_scene_spec(np.random.default_rng(0), kind="stairs", supersample=1)
    scene = render_scene(spec)
    rect = compute_rectification(scene.calibration)
    pair = rectify(scene.left, shift_down(scene.right, 1.5), rect)
    ocv, sgm = make_backend("opencv"), make_backend("sgm")
    cv2.setNumThreads(1)
    sgm.compute(pair, 64)
    stats: dict[str, list[float]] = {}

    def clock(name, fn):
        t = time.perf_counter()
        fn()
        stats.setdefault(name, []).append((time.perf_counter() - t) * 1e3)

    for _ in range(15):
        clock("rectify (remap)", lambda: rectify(scene.left, scene.right, rect))
        clock("vertical alignment (measure + warp)", lambda: align_vertical(pair))
        clock("opencv SGBM 64", lambda: ocv.compute(pair, 64))
        clock("sgm 64", lambda: sgm.compute(pair, 64))
    print("| step at 640x480 | median ms |")
    print("| --- | --- |")
    for k, v in stats.items():
        print(f"| {k} | {np.median(v):.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument(
        "--middlebury",
        default=str(Path(__file__).resolve().parents[1].parent / "shared/data/middlebury2014Q"),
    )
    ap.add_argument("--skip-rendered", action="store_true")
    ap.add_argument("--skip-middlebury", action="store_true")
    ap.add_argument("--skip-timing", action="store_true")
    args = ap.parse_args()
    if not args.skip_timing:
        timing()
    if not args.skip_middlebury:
        part_middlebury(Path(args.middlebury))
    if not args.skip_rendered:
        part_rendered(args.scenes, args.seed)


if __name__ == "__main__":
    main()
