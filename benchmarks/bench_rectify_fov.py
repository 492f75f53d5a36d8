"""How much of the raw view each rectification keeps, on rendered scenes (with distortion).

For every scene and every ``fov`` of :func:`stereo_terrain.rectify.compute_rectification`,
the raw left pixels (every 4th) are mapped into the rectified left image; a pixel survives
when it lands inside the image and inside ``valid_left`` (not within the margin of the
sourceless border). Printed: the mean share of the raw image that survives, of its
bottom tenth (where a level camera close to stairs sees the floor and first riser), the
rectified focal length relative to ``fov=valid`` and the share of rectified pixels with a
source in both images.

    .venv/bin/python benchmarks/bench_rectify_fov.py [--scenes 20] [--seed 5] [--profile realistic]
"""

from __future__ import annotations

import argparse

import numpy as np

from stereo_terrain.rectify import RECTIFY_FOVS, compute_rectification, rectify_points
from stereo_terrain.synthetic import random_scene_spec, render_scene


def kept(rect, step: int = 4) -> tuple[float, float, float, float]:
    """Shares of the raw image and of its bottom tenth that survive, share of rectified
    pixels with a source in both images, rectified pixels relative to the raw ones."""
    w, h = rect.raw_size
    rw, rh = rect.image_size  # larger than the raw size for fov="keep"
    ys, xs = np.mgrid[0:h:step, 0:w:step]
    pts = np.column_stack([xs.ravel(), ys.ravel()]).astype(np.float64)
    uv = rectify_points(pts, rect, "left")
    u, v = np.round(uv[:, 0]).astype(int), np.round(uv[:, 1]).astype(int)
    inside = (u >= 0) & (u < rw) & (v >= 0) & (v < rh)
    if rect.valid_left is not None:
        inside[inside] &= rect.valid_left[v[inside], u[inside]]
    bottom = pts[:, 1] >= 0.9 * h
    vl = np.ones((rh, rw), bool) if rect.valid_left is None else rect.valid_left
    vr = np.ones((rh, rw), bool) if rect.valid_right is None else rect.valid_right
    return float(inside.mean()), float(inside[bottom].mean()), float((vl & vr).mean()), rw * rh / (w * h)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--profile", choices=["default", "realistic"], default="default")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    res: dict[str, list[tuple[float, ...]]] = {f: [] for f in RECTIFY_FOVS}
    for _ in range(args.scenes):
        scene = render_scene(random_scene_spec(rng, profile=args.profile, supersample=1))
        f0 = compute_rectification(scene.calibration, fov="valid").focal_px
        for fov in RECTIFY_FOVS:
            rect = compute_rectification(scene.calibration, fov=fov)
            res[fov].append((*kept(rect), rect.focal_px / f0))
    print(
        "| fov | raw image kept | raw bottom tenth kept | focal / valid's | rectified px with a source | "
        "rectified px / raw px |"
    )
    print("| --- | --- | --- | --- | --- | --- |")
    for fov, rows in res.items():
        a = np.array(rows)
        print(
            f"| {fov} | {a[:, 0].mean():.1%} (min {a[:, 0].min():.1%}) | {a[:, 1].mean():.1%} "
            f"(min {a[:, 1].min():.1%}) | {a[:, 4].mean():.3f} | {a[:, 2].mean():.1%} | "
            f"{a[:, 3].mean():.2f} |"
        )


if __name__ == "__main__":
    main()
