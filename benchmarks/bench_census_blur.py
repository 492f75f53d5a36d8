"""The SGM engine's census on a blurred image (``census_blur_sigma_px``), against no blur
and OpenCV: Middlebury bad-2.0 per scene, the density and accuracy of the disparities on
weakly textured stair faces, and the pipeline on rendered scenes. Results are recorded in
docs/benchmarks.md ("Census on a blurred image").

    .venv/bin/python benchmarks/bench_census_blur.py [--sigma 1.0] [--middlebury DIR]
"""

from __future__ import annotations

import argparse
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
from stereo_terrain.rectify import Rectification, compute_rectification, rectify
from stereo_terrain.stereo import default_max_disparity, make_backend
from stereo_terrain.stereo.sgm import SGM, SGMConfig
from stereo_terrain.synthetic import SyntheticScene, random_scene_spec, render_scene

DEFAULT_MIDDLEBURY = Path(__file__).resolve().parents[2] / "shared" / "data" / "middlebury2014Q"


def true_disparity(scene: SyntheticScene, rect: Rectification) -> tuple[np.ndarray, np.ndarray]:
    """Rectified left disparity from the renderer's depth, and the surface label per pixel."""
    m1, m2 = rect.maps[0], rect.maps[1]
    if m1.dtype != np.float32 or m1.ndim != 2:
        m1, m2 = cv2.convertMaps(m1, m2, cv2.CV_32FC1)
    z = cv2.remap(scene.depth_left, m1, m2, cv2.INTER_NEAREST, borderValue=np.nan)
    labels = cv2.remap(scene.labels_left.astype(np.float32), m1, m2, cv2.INTER_NEAREST, borderValue=-1)
    h, w = z.shape
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    ray = np.stack([(u - rect.cx) / rect.focal_px, (v - rect.cy) / rect.focal_px, np.ones_like(u)], -1)
    z_rect = z / (ray @ rect.T_camera_rect.matrix[2, :3])  # raw depth -> along the rectified axis
    return rect.focal_px * rect.baseline_m / z_rect - rect.doffs_px, labels.astype(int)


def middlebury(root: Path, sigma: float) -> None:
    print(f"| scene | sgm | sgm, census_blur_sigma_px {sigma:g} | OpenCV's best mode |")
    print("| --- | --- | --- | --- |")
    rows = []
    for d in middlebury_scene_dirs(root):
        scene = read_middlebury_scene(d)
        rect = compute_rectification(scene.calibration)
        pair = rectify(scene.left, scene.right, rect)
        n = default_max_disparity(rect, PipelineConfig().min_depth_m)  # as eval-disparity

        def bad2(backend, scene=scene, pair=pair, n=n) -> float:
            return disparity_errors(backend.compute(pair, n).disparity, scene.truth, scene.nonoccluded)[
                "bad2"
            ]

        ours = bad2(SGM())
        blurred = bad2(SGM(SGMConfig(census_blur_sigma_px=sigma)))
        opencv = {m: bad2(make_backend("opencv", mode=m)) for m in ("sgbm_3way", "sgbm", "hh")}
        best = min(opencv, key=opencv.__getitem__)
        rows.append((ours, blurred, opencv[best]))
        print(f"| {scene.name} | {ours:.1%} | {blurred:.1%} | {opencv[best]:.1%} ({best}) |", flush=True)
    mean = np.mean(rows, axis=0)
    print(f"| mean | {mean[0]:.1%} | {mean[1]:.1%} | {mean[2]:.1%} |\n")


def stair_faces(sigma: float, count: int) -> None:
    rng = np.random.default_rng(7)
    specs = []
    while len(specs) < count:
        spec = random_scene_spec(rng, weak_texture=True)
        if type(spec.obstacle).__name__ == "StairSpec":
            specs.append(spec)
    configs = {
        "opencv": PipelineConfig(),
        "sgm": PipelineConfig(backend="sgm"),
        "sgm, no speckle filter": PipelineConfig(backend="sgm", sgm=SGMConfig(speckle_window_px=0)),
        "sgm, no speckle filter, left-right check or uniqueness test": PipelineConfig(
            backend="sgm", sgm=SGMConfig(speckle_window_px=0, lr_max_diff_px=1000.0, uniqueness_ratio_pct=0)
        ),
        f"sgm, blur {sigma:g}": PipelineConfig(backend="sgm", sgm=SGMConfig(census_blur_sigma_px=sigma)),
    }
    found = {k: [] for k in configs}
    for spec in specs:
        scene = render_scene(spec)
        names = [p["name"] for p in scene.truth["planes"]]
        for label, config in configs.items():
            pipeline = Pipeline(scene.calibration, scene.rig, config)
            pair = rectify(scene.left, scene.right, pipeline.rectification)
            truth, labels = true_disparity(scene, pipeline.rectification)
            faces = np.isin(labels, [k for k, n in enumerate(names) if n.startswith(("riser", "tread"))])
            err = np.abs(pipeline.backend.compute(pair, pipeline.max_disparity_px).disparity - truth)
            err = err[faces & np.isfinite(truth)]
            found[label].append((np.isfinite(err).mean(), (err <= 1.0).mean()))
    print(f"Stair faces of {count} weakly textured staircases (before the planar fill):")
    print("| backend | density | within 1 px of the truth |\n| --- | --- | --- |")
    for label, values in found.items():
        density, good = np.mean(values, axis=0)
        print(f"| {label} | {density:.0%} | {good:.0%} |")
    print()


def pipeline(sigma: float, sizes: tuple[int, int, int]) -> None:
    def specs(seed: int, count: int, **kw) -> list:
        rng = np.random.default_rng(seed)
        return [random_scene_spec(rng, **kw) for _ in range(count)]

    weak, textured, small = sizes
    sets = {
        "weakly textured": specs(21, weak, weak_texture=True),
        "textured": specs(22, textured, weak_texture=False),
        "320x240 textured": specs(23, small, image_size=(320, 240), weak_texture=False),
    }
    configs = {
        "opencv": PipelineConfig(),
        "sgm": PipelineConfig(backend="sgm"),
        f"sgm, blur {sigma:g}": PipelineConfig(backend="sgm", sgm=SGMConfig(census_blur_sigma_px=sigma)),
    }
    print("| scenes | backend | detected | false pos. | step count right | rise median cm | rise p90 cm |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, group in sets.items():
        scenes = [render_scene(s) for s in group]
        for label, config in configs.items():
            scores = [
                score_result(
                    Pipeline(s.calibration, s.rig, config).run(s.left, s.right).to_json_dict(), s.truth
                )
                for s in scenes
            ]
            r = summarize(scores)
            print(
                f"| {name} ({len(scenes)}) | {label} | {r['detection_rate']:.0%} | "
                f"{r['false_positive_rate']:.0%} | {r['count_rate']:.0%} | {r['rise_median_m'] * 100:.1f} | "
                f"{r['rise_p90_m'] * 100:.1f} |",
                flush=True,
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sigma", type=float, default=1.0)
    ap.add_argument("--middlebury", type=Path, default=DEFAULT_MIDDLEBURY)
    ap.add_argument("--faces", type=int, default=14, help="weakly textured staircases for the face table")
    ap.add_argument(
        "--scenes", type=int, nargs=3, default=(24, 24, 16), metavar=("WEAK", "TEXTURED", "SMALL"),
        help="rendered scenes per pipeline set (a scene more or less is 2-6 points on these sizes)",
    )  # fmt: skip
    ap.add_argument("--pipeline-only", action="store_true")
    args = ap.parse_args()
    if not args.pipeline_only:
        middlebury(args.middlebury, args.sigma)
        stair_faces(args.sigma, args.faces)
    pipeline(args.sigma, tuple(args.scenes))


if __name__ == "__main__":
    main()
