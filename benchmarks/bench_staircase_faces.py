"""Middlebury ``Staircase`` (no ground truth): how much of each step's faces the disparity
gets right, per backend, and what each stage after it keeps (issue 11).

A reference staircase is built from the scene itself: the corners where the step nosings
meet the side wall are sharp 2-D features that match without ambiguity (normalised cross
correlation of a 15 x 15 window along the row, peak >= 0.95); their disparities are
converted to points in the yaw frame of the default pipeline's result (gravity from the
scene), and a line fit through them gives the rise, the run and the stair axis (at right
angles to the wall's normal). Every pixel is ray-cast against the steps of that model (the
wall's plane on one side, ``STAIR_WIDTH_M`` of the flight on the other) and labelled with
its face and model disparity. Then, per face and backend: the share of its pixels whose
disparity is within 1.5 px of the model, the share with any disparity, and the grid
samples of the plane stage on that face (within 1.5 px / all). Pixels where the backend
gives a disparity 6 px above the model (the railing and balusters in front) are left out.

    .venv/bin/python benchmarks/bench_staircase_faces.py [--figure docs/figures/staircase_faces.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.cloud import sample_disparity
from stereo_terrain.frames import Transform
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image

SCENE = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "middlebury2014Q_noGT" / "Staircase"
#: Nosing-wall corners of the 1st to 9th riser (left image, pixels; read off the image).
CORNERS = [
    (319, 347),
    (387, 296),
    (434, 246),
    (475, 201),
    (512, 161),
    (545, 124),
    (576, 91),
    (604, 61),
    (630, 33),
]
STAIR_WIDTH_M = 1.15  # wall to railing, from the side view of the points
CONFIGS = {
    "opencv + fill (default)": {},
    "opencv, no fill": {"fill": {"enabled": False}},
    "sgm + fill": {"backend": "sgm"},
    "sgm, no fill": {"backend": "sgm", "fill": {"enabled": False}},
}


def match_corner(left: np.ndarray, right: np.ndarray, x: int, y: int, half: int = 7) -> tuple[float, float]:
    """Disparity of pixel (x, y) by NCC along its row, sub-pixel; and the peak NCC."""
    t = left[y - half : y + half + 1, x - half : x + half + 1].astype(np.float32)
    lo = max(half, x - 128)
    strip = right[y - half : y + half + 1, lo - half : x + half + 1].astype(np.float32)
    r = cv2.matchTemplate(strip, t, cv2.TM_CCOEFF_NORMED)[0]
    k = int(np.argmax(r))
    sub = 0.0
    if 0 < k < len(r) - 1:
        a, b, c = r[k - 1], r[k], r[k + 1]
        sub = 0.5 * (a - c) / (a - 2 * b + c)
    return float(x - (lo + k + sub)), float(r[k])


def model_faces(result, left, right):
    """(face id per pixel: 2k riser k, 2k+1 tread k, -99 none; model disparity; rise, run)."""
    rect = result.rectified.rectification
    T = result.T_yaw_camera_rect.matrix
    pts = []
    for x, y in CORNERS:
        d, peak = match_corner(left, right, x, y)
        if peak < 0.95:
            continue
        z = rect.focal_px * rect.baseline_m / (d + rect.doffs_px)
        p_cam = np.array([(x - rect.cx) * z / rect.focal_px, (y - rect.cy) * z / rect.focal_px, z])
        pts.append((CORNERS.index((x, y)), T[:3, :3] @ p_cam + T[:3, 3]))
    k = np.array([i for i, _ in pts], dtype=float)
    q = np.array([p for _, p in pts])
    wall = max((s for s in result.planes.segments if s.kind == "vertical"), key=lambda s: s.count)
    n = wall.plane.normal
    u = np.array([n[1], -n[0], 0.0])
    u /= np.linalg.norm(u)
    if np.polyfit(k, q @ u, 1)[0] < 0:
        u = -u
    v = np.array([-u[1], u[0], 0.0])
    run, s0 = np.polyfit(k, q @ u, 1)
    rise, z0 = np.polyfit(k, q[:, 2], 1)
    wall_lat = float(np.median(q @ v))
    side = np.sign(wall_lat)
    h, w = left.shape
    uu, vv = np.meshgrid((np.arange(w) - rect.cx) / rect.focal_px, (np.arange(h) - rect.cy) / rect.focal_px)
    rays = np.stack([uu, vv, np.ones_like(uu)], -1) @ T[:3, :3].T
    c = T[:3, 3]
    rs, rl, rz = rays @ u, rays @ v, rays[..., 2]
    cs, cl, cz = c @ u, c @ v, c[2]
    best = np.full((h, w), np.inf)
    face = np.full((h, w), -99)

    def inside(lat):
        return (side * lat <= side * wall_lat) & (side * lat >= side * wall_lat - STAIR_WIDTH_M)

    for j in range(-2, len(CORNERS) + 2):
        sk, zk = s0 + run * j, z0 + rise * j
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (sk - cs) / rs
            zz, ll = cz + t * rz, cl + t * rl
            ok = (t > 0) & (zz >= zk - rise) & (zz <= zk) & inside(ll) & (t < best)
            best[ok], face[ok] = t[ok], 2 * j
            t = (zk - cz) / rz
            ss, ll = cs + t * rs, cl + t * rl
            ok = (t > 0) & (ss >= sk) & (ss <= sk + run) & inside(ll) & (t < best)
            best[ok], face[ok] = t[ok], 2 * j + 1
    with np.errstate(divide="ignore"):
        disp = rect.focal_px * rect.baseline_m / best - rect.doffs_px
    return face, disp, float(rise), float(run)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--figure", type=Path, help="write the per-pixel check of two backends here")
    args = ap.parse_args()
    calib = read_calibration(SCENE / "calib.txt")
    left, right = read_image(SCENE / "im0.png"), read_image(SCENE / "im1.png")
    base = Pipeline(calib).run(left, right)
    face, model, rise, run = model_faces(base, left, right)
    print(
        f"reference staircase from {len(CORNERS)} wall corners: "
        f"rise {100 * rise:.1f} cm, run {100 * run:.1f} cm"
    )
    n_faces = len(CORNERS)
    header = "| backend | result | " + " | ".join(f"riser {j + 1}" for j in range(n_faces)) + " |"
    print(
        "\nper face: % of pixels within 1.5 px of the reference / % with a disparity; "
        "grid samples within 1.5 px"
    )
    print(header)
    print("|" + " --- |" * (n_faces + 2))
    panels = []
    for name, cfg in CONFIGS.items():
        res = Pipeline(calib, None, PipelineConfig.from_dict(cfg)).run(left, right)
        d = res.disparity.disparity
        front = np.isfinite(d) & (d > model + 6)
        gs = sample_disparity(res.disparity, Transform.identity("camera_rect"), res.cloud_config)
        g_face = face[gs.rows, gs.cols]
        g_ok = np.abs(d[gs.rows, gs.cols] - model[gs.rows, gs.cols]) < 1.5
        cells = {}
        for kind, off in (("riser", 0), ("tread", 1)):
            row = []
            for j in range(n_faces):
                m = (face == 2 * j + off) & ~front
                if m.sum() < 50:
                    row.append("-")
                    continue
                e = np.abs(d - model)[m]
                row.append(
                    f"{100 * np.mean(e < 1.5):.0f} / {100 * np.mean(np.isfinite(e)):.0f}; "
                    f"{int(((g_face == 2 * j + off) & g_ok).sum())}"
                )
            cells[kind] = row
        t = res.terrain
        got = f"{t.obstacle} {len(t.steps)}"
        print(f"| {name}, risers | {got} | " + " | ".join(cells["riser"]) + " |")
        print(f"| {name}, treads | | " + " | ".join(cells["tread"]) + " |")
        if args.figure and name in ("opencv + fill (default)", "sgm + fill"):
            img = cv2.cvtColor(res.rectified.left, cv2.COLOR_GRAY2BGR) // 2
            m = face > -99
            err = d - model
            img[m & ~np.isfinite(d)] = (128, 128, 128)
            img[m & (np.abs(err) < 1.5)] = (0, 200, 0)
            img[m & (err <= -1.5)] = (255, 0, 0)
            img[m & (err >= 1.5) & (err < 6)] = (0, 0, 255)
            cv2.putText(img, name, (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1)
            panels.append(img)
    if args.figure and panels:
        legend = np.zeros((28, sum(p.shape[1] for p in panels), 3), np.uint8)
        text = "green: within 1.5 px of the reference  blue: too far  red: too near  grey: no disparity"
        cv2.putText(legend, text, (8, 19), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1)
        cv2.imwrite(str(args.figure), np.vstack([np.hstack(panels), legend]))
        print(f"\nwrote {args.figure}")


if __name__ == "__main__":
    main()
