"""Plane-stage speed against Open3D's ``segment_plane`` run in a loop (issue 4).

Open3D is not a dependency of the package: ``make bench-open3d`` installs it in its own
environment (``benchmarks/.venv-open3d``) and runs this script there.

For each rendered 640x480 staircase the pipeline's plane stage (orientation method on the
grid sample) is timed, and Open3D's RANSAC ``segment_plane`` is run in a loop -- find the
largest plane, remove its inliers, repeat -- as many times as our stage found planes, on
(a) the same grid sample and (b) the full-resolution cloud of the same disparity. Both
are timed interleaved in one run. Each of our planes counts as found by Open3D when one of
Open3D's planes has its normal within 1 degree and its offset within 2 cm.

    make bench-open3d        # or: benchmarks/.venv-open3d/bin/python benchmarks/bench_open3d.py
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from stereo_terrain.cloud import disparity_to_cloud, transform_cloud
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.planes.orientation import extract_planes_orientation
from stereo_terrain.synthetic import random_scene_spec, render_scene

NORMAL_TOL_DEG = 1.0
OFFSET_TOL_M = 0.02


def open3d_loop(o3d, points: np.ndarray, n_planes: int, threshold_m: float, iterations: int, seed: int):
    """Planes ``(normal, offset)`` from Open3D RANSAC, largest first, inliers removed."""
    o3d.utility.random.seed(seed)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    planes = []
    for _ in range(n_planes):
        if len(pcd.points) < 3:
            break
        model, inliers = pcd.segment_plane(threshold_m, 3, iterations)
        n = np.asarray(model[:3], dtype=np.float64)
        norm = np.linalg.norm(n)
        planes.append((n / norm, model[3] / norm))
        pcd = pcd.select_by_index(inliers, invert=True)
    return planes


def matched(ours, theirs) -> int:
    count = 0
    cos_tol = np.cos(np.radians(NORMAL_TOL_DEG))
    for seg in ours:
        n, d = seg.plane.normal, seg.plane.offset
        for m, e in theirs:
            c = float(n @ m)
            if abs(c) >= cos_tol and abs(d - np.sign(c) * e) <= OFFSET_TOL_M:
                count += 1
                break
    return count


def _import_open3d():
    """Open3D's wheel links libusb-1.0, which slim systems lack; the benchmark environment
    gets it from the ``libusb-package`` wheel, loaded before Open3D."""
    try:
        import ctypes
        import os

        import libusb_package

        lib = os.path.join(os.path.dirname(libusb_package.__file__), "libusb-1.0.so")
        if os.path.exists(lib):
            ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
    except (ImportError, OSError):
        pass  # the system's libusb may do
    import open3d

    return open3d


def main() -> None:
    try:
        o3d = _import_open3d()
    except ImportError:
        sys.exit("Open3D is missing: run `make bench-open3d` (it installs Open3D in benchmarks/.venv-open3d)")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=6)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--iterations", type=int, default=1000, help="Open3D RANSAC iterations per plane")
    ap.add_argument("--threshold", type=float, default=0.02, help="Open3D inlier distance, metres")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    ours_ms, o3d_grid_ms, o3d_full_ms = [], [], []
    found = {"grid": 0, "full": 0, "ours": 0}
    n_points = {"grid": [], "full": []}
    for _ in range(args.scenes):
        scene = render_scene(random_scene_spec(rng, kind="stairs", weak_texture=False))
        pipe = Pipeline(scene.calibration, scene.rig, PipelineConfig(max_disparity_px=64))
        result = pipe.run(scene.left, scene.right)
        samples = result.planes.samples
        cloud = transform_cloud(disparity_to_cloud(result.disparity), result.T_yaw_camera_rect)
        full = cloud.points[cloud.valid]
        grid = samples.points
        n_points["grid"].append(len(grid))
        n_points["full"].append(len(full))
        extract_planes_orientation(samples)  # warm-up (JIT)
        for r in range(args.repeats):
            t0 = time.perf_counter()
            planes = extract_planes_orientation(samples)
            ours_ms.append((time.perf_counter() - t0) * 1000)
            k = len(planes.segments)
            t0 = time.perf_counter()
            on_grid = open3d_loop(o3d, grid, k, args.threshold, args.iterations, r)
            o3d_grid_ms.append((time.perf_counter() - t0) * 1000)
            t0 = time.perf_counter()
            on_full = open3d_loop(o3d, full, k, args.threshold, args.iterations, r)
            o3d_full_ms.append((time.perf_counter() - t0) * 1000)
        found["ours"] += k
        found["grid"] += matched(planes.segments, on_grid)
        found["full"] += matched(planes.segments, on_full)
    ours = statistics.median(ours_ms)
    grid_ms = statistics.median(o3d_grid_ms)
    full_ms = statistics.median(o3d_full_ms)
    print(
        f"{args.scenes} rendered 640x480 staircases x {args.repeats} runs, Open3D {o3d.__version__} "
        f"segment_plane ({args.iterations} iterations, {args.threshold} m) looped once per plane we found"
    )
    print()
    print(
        "| plane extraction | points | median ms | ratio to ours | our planes it also found (1 deg, 2 cm) |"
    )
    print("| --- | --- | --- | --- | --- |")
    print(f"| ours (orientation, grid sample) | {int(np.median(n_points['grid']))} | {ours:.2f} | 1 | - |")
    print(
        f"| Open3D loop on the same grid sample | {int(np.median(n_points['grid']))} | {grid_ms:.1f} | "
        f"{grid_ms / ours:.0f}x | {found['grid']}/{found['ours']} |"
    )
    print(
        f"| Open3D loop on the full-resolution cloud | {int(np.median(n_points['full']))} | {full_ms:.1f} | "
        f"{full_ms / ours:.0f}x | {found['full']}/{found['ours']} |"
    )


if __name__ == "__main__":
    main()
