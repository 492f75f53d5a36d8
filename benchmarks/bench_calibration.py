"""Calibration and drift check on the real data in ../shared/data.

1. The OpenCV chessboard set (13 pairs, 9x6, 0.025 m): our calibration against OpenCV's
   reference left intrinsics, and the vertical feature disparity of every pair after
   rectification with our result.
2. check-calib on the real rectified scenes (OAK-D Lite, Middlebury): how well their own
   rectification holds, as this tool sees it.

Prints markdown tables; results are recorded in docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_calibration.py
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.calibrate import BoardConfig, calibrate_from_globs, find_image_pairs
from stereo_terrain.calibration import read_calibration
from stereo_terrain.drift import FeatureMatches, check_calibration, check_matches, match_features
from stereo_terrain.rectify import compute_rectification, read_image, rectify

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def chessboard() -> None:
    d = DATA / "calibration" / "opencv_chessboard_9x6"
    ref = cv2.FileStorage(str(d / "left_intrinsics.yml"), cv2.FILE_STORAGE_READ)
    K_ref = ref.getNode("camera_matrix").mat()
    rms_ref = ref.getNode("avg_reprojection_error").real()
    ref.release()
    left_glob, right_glob = str(d / "left*.jpg"), str(d / "right*.jpg")
    result = calibrate_from_globs(left_glob, right_glob, BoardConfig(9, 6, 0.025))
    K, q = result.calibration.K1, result.quality
    print("| left camera | fx | fy | cx | cy | RMS px |")
    print("| --- | --- | --- | --- | --- | --- |")
    print(
        f"| OpenCV reference (aspect fixed) | {K_ref[0, 0]:.2f} | {K_ref[1, 1]:.2f} | {K_ref[0, 2]:.2f} | "
        f"{K_ref[1, 2]:.2f} | {rms_ref:.3f} |"
    )
    print(
        f"| ours | {K[0, 0]:.2f} ({(K[0, 0] / K_ref[0, 0] - 1):+.2%}) | {K[1, 1]:.2f} "
        f"({(K[1, 1] / K_ref[1, 1] - 1):+.2%}) | {K[0, 2]:.2f} ({K[0, 2] - K_ref[0, 2]:+.2f}) | "
        f"{K[1, 2]:.2f} ({K[1, 2] - K_ref[1, 2]:+.2f}) | {q.rms_left_px:.3f} alone, {q.rms_px:.3f} stereo |"
    )
    print(
        f"\nbaseline {q.baseline_m * 1000:.1f} mm; views worth dropping: "
        f"{', '.join(q.worth_dropping) or 'none'}; "
        f"coverage {q.coverage[0]:.0%} / {q.coverage[1]:.0%}; rectified corner epipolar error median "
        f"{q.epipolar_median_px:.3f} px, RMS {q.epipolar_rms_px:.3f} px, max {q.epipolar_max_px:.2f} px\n"
    )
    rect = compute_rectification(result.calibration)
    print("| pair | matches | vertical disparity median px | spread px | verdict (this pair alone) |")
    print("| --- | --- | --- | --- | --- |")
    groups = []
    for lp, rp in find_image_pairs(left_glob, right_glob):
        m = match_features(rectify(read_image(lp), read_image(rp), rect))
        groups.append(m)
        c = check_matches(m, rect)
        print(f"| {lp.name} | {len(m)} | {c.median_px:+.3f} | {c.spread_px:.3f} | {c.verdict} |")
    pooled = FeatureMatches(
        np.concatenate([g.left for g in groups]), np.concatenate([g.right for g in groups])
    )
    c = check_matches(groups, rect)
    print(
        f"| all 13 pooled | {len(pooled)} | {float(np.median(pooled.vertical_px)):+.3f} "
        f"(median abs {float(np.median(np.abs(pooled.vertical_px))):.3f}) | {c.spread_px:.3f} | {c.verdict} |"
    )


def real_scenes() -> None:
    rows = [
        (f"OAK-D Lite {d.name}", d / "stereodemo_calibration.json", d / "left.png", d / "right.png")
        for d in sorted((DATA / "oakd_lite").iterdir())
    ]
    rows += [
        (f"Middlebury {d.name}", d / "calib.txt", d / "im0.png", d / "im1.png")
        for d in sorted((DATA / "middlebury2014Q").iterdir())
        if (d / "calib.txt").is_file()
    ]
    d = DATA / "middlebury2014Q_noGT" / "Classroom2"
    rows.append(("Middlebury Classroom2", d / "calib.txt", d / "im0.png", d / "im1.png"))
    print(
        "\n| scene | matches | vertical disparity median px | spread px | drift rotation x, z deg "
        "| worst vertical px | verdict |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    oakd = []
    for name, calib, left, right in rows:
        rect = compute_rectification(read_calibration(calib))
        pair = rectify(read_image(left), read_image(right), rect)
        if name.startswith("OAK"):
            oakd.append(pair)
        c = check_calibration(pair)
        rot = (
            "-"
            if c.rotation is None
            else ", ".join(f"{v:+.3f}" for v in np.degrees(c.rotation.rotvec_rad)[[0, 2]])
        )
        print(
            f"| {name} | {c.n_matches} | {c.median_px:+.2f} | {c.spread_px:.2f} | {rot} | "
            f"{c.vertical_error_px:.2f} | {c.verdict} |"
        )
    c = check_calibration(oakd)
    print(
        f"| OAK-D Lite, 3 scenes pooled | {c.n_matches} | {c.median_px:+.2f} | {c.spread_px:.2f} | "
        f"yaw confirmed: {c.yaw_confirmed} | {c.vertical_error_px:.2f} | {c.verdict} |"
    )


def main() -> None:
    if not DATA.is_dir():
        raise SystemExit(f"{DATA} is absent")
    chessboard()
    real_scenes()


if __name__ == "__main__":
    main()
