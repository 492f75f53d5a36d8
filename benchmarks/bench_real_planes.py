"""Plane quality on the real scenes: planes drawn over the image, plane-fit RMS (issue 4).

For the OAK-D Lite scenes and Middlebury Classroom2 (no rig: the floor levels the frame)
the pipeline runs with the orientation and the contour method. Each plane's grid-sample
inliers are painted over the rectified left image (one colour per plane; H horizontal,
V vertical, O other, with the RMS in cm), orientation left, contour right, and written to
``docs/figures/planes_<scene>.png``. The table gives, per plane with >= 50 samples, the
RMS distance of its grid-sample inliers and of every full-resolution pixel in the image
cells of those inliers (no cut-off: edge pixels count).

    .venv/bin/python benchmarks/bench_real_planes.py [--out docs/figures]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SCENES = {
    "living_room": ("oakd_lite/living_room", "left.png", "right.png", "stereodemo_calibration.json"),
    "desk": ("oakd_lite/desk", "left.png", "right.png", "stereodemo_calibration.json"),
    "corridor": ("oakd_lite/corridor", "left.png", "right.png", "stereodemo_calibration.json"),
    "Classroom2": ("middlebury2014Q_noGT/Classroom2", "im0.png", "im1.png", "calib.txt"),
}
COLOURS = [
    (230, 25, 75),
    (60, 180, 75),
    (255, 225, 25),
    (0, 130, 200),
    (245, 130, 48),
    (145, 30, 180),
    (70, 240, 240),
    (240, 50, 230),
    (210, 245, 60),
    (250, 190, 212),
    (0, 128, 128),
    (170, 110, 40),
]
MIN_SAMPLES = 50


def draw(result, title: str) -> np.ndarray:
    img = (
        cv2.cvtColor(result.rectified.left, cv2.COLOR_GRAY2BGR)
        if result.rectified.left.ndim == 2
        else (result.rectified.left.copy())
    )
    s = result.planes.samples
    r = max(2, s.stride_px // 2)
    over = img.copy()
    for i, seg in enumerate(result.planes.segments):
        col = COLOURS[i % len(COLOURS)][::-1]
        for y, x in zip(s.rows[seg.indices], s.cols[seg.indices], strict=True):
            cv2.rectangle(over, (int(x) - r, int(y) - r), (int(x) + r, int(y) + r), col, -1)
    img = cv2.addWeighted(img, 0.45, over, 0.55, 0)
    for i, seg in enumerate(result.planes.segments):
        if seg.count < MIN_SAMPLES:
            continue
        y, x = int(np.median(s.rows[seg.indices])), int(np.median(s.cols[seg.indices]))
        label = f"{seg.kind[0].upper()}{i} {seg.rms_m * 100:.1f}"
        cv2.putText(img, label, (x - 30, y), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (0, 0, 0), 4)
        cv2.putText(img, label, (x - 30, y), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 2)
    cv2.putText(img, title, (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (0, 0, 0), 4)
    cv2.putText(img, title, (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (255, 255, 255), 2)
    return img


def full_resolution_rms(result, seg) -> float:
    """RMS distance to the plane of every valid full-resolution pixel in the image cells of
    the plane's grid-sample inliers."""
    s = result.planes.samples
    cloud = result.cloud
    h, w = cloud.shape
    mask = np.zeros((h, w), bool)
    half = s.stride_px // 2
    for y, x in zip(s.rows[seg.indices], s.cols[seg.indices], strict=True):
        mask[max(0, y - half) : y + half + 1, max(0, x - half) : x + half + 1] = True
    mask &= cloud.valid
    res = seg.plane.residuals(cloud.points[mask].astype(np.float64))
    return float(np.sqrt(np.mean(res**2))) if len(res) else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "figures")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    print(
        "| scene | method | planes (>= 50 samples) | kinds | grid-sample RMS cm, per plane | "
        "full-resolution RMS cm, per plane | obstacle |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, (folder, left, right, calib) in SCENES.items():
        d = DATA / folder
        if not d.is_dir():
            print(f"| {name} | - | skipped: {d} absent | | | | |")
            continue
        calibration = read_calibration(d / calib)
        L, R = read_image(d / left), read_image(d / right)
        panels = []
        for method in ("orientation", "contour"):
            result = Pipeline(calibration, None, PipelineConfig(method=method)).run(L, R)
            big = [g for g in result.planes.segments if g.count >= MIN_SAMPLES]
            kinds = "".join(g.kind[0].upper() for g in big)
            grid_rms = ", ".join(f"{g.rms_m * 100:.1f}" for g in big)
            full_rms = ", ".join(f"{full_resolution_rms(result, g) * 100:.1f}" for g in big)
            print(
                f"| {name} | {method} | {len(big)} | {kinds} | {grid_rms} | {full_rms} | "
                f"{result.terrain.obstacle} |"
            )
            panels.append(draw(result, f"{name}: {method}"))
        fig = np.hstack(panels)
        scale = 640.0 / fig.shape[1]
        fig = cv2.resize(fig, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        cv2.imwrite(str(args.out / f"planes_{name}.png"), fig)


if __name__ == "__main__":
    main()
