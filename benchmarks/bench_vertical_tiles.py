"""How well the vertical alignment measures a known offset, for a tile layout (issue 13).

Each rectified pair of the scene folders (``render`` layout) gets its right image moved by
a known vertical shift ``dy + slope * (x - cx)`` (``dy`` uniform in [-2, 2] px, ``slope``
in [-1, 1] px over the image width; several draws per pair), and
:func:`~stereo_terrain.stereo.vertical.estimate_vertical_offset` measures it with the
default layout and with ``--b`` (a YAML mapping of ``VerticalAlignConfig`` fields). The
offset the pair had before the shift (a realistic render has one) is measured by each
layout on the unshifted pair and subtracted. Printed per layout: the share of shifted
pairs measured (enough tiles agree), the error of ``dy(x)`` at the image's centre and at
its edges (median and p90, px), and the time of one estimate (median, ms; interleaved).

    .venv/bin/python benchmarks/bench_vertical_tiles.py DIR [DIR ...] --b B.yaml [--draws 4]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np
import yaml

from stereo_terrain.calibration import read_calibration
from stereo_terrain.rectify import compute_rectification, read_image, rectify
from stereo_terrain.stereo.vertical import VerticalAlignConfig, estimate_vertical_offset


def _shift(img: np.ndarray, dy: float, slope: float, cx: float) -> np.ndarray:
    """``out(x, y) = img(x, y - dy(x))``: content moved down by ``dy(x)``."""
    h, w = img.shape
    M = np.array([[1.0, 0.0, 0.0], [slope, 1.0, dy - slope * cx]])
    return cv2.warpAffine(img, M, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", type=Path, nargs="+")
    ap.add_argument("--b", type=Path, required=True)
    ap.add_argument("--draws", type=int, default=4)
    ap.add_argument("--seed", type=int, default=13)
    args = ap.parse_args()
    layouts = [VerticalAlignConfig(), VerticalAlignConfig(**(yaml.safe_load(args.b.read_text()) or {}))]
    rng = np.random.default_rng(args.seed)
    err_c: list[list[float]] = [[], []]
    err_e: list[list[float]] = [[], []]
    measured = [0, 0]
    ms: list[list[float]] = [[], []]
    total = 0
    for root in args.dirs:
        for d in sorted(p for p in root.iterdir() if p.is_dir()):
            rect = compute_rectification(read_calibration(d / "calib.yaml"))
            pair = rectify(read_image(d / "left.png"), read_image(d / "right.png"), rect)
            h, w = pair.left.shape
            cx = (w - 1) / 2.0
            base = [estimate_vertical_offset(pair.left, pair.right, c) for c in layouts]
            for _ in range(args.draws):
                dy, slope = rng.uniform(-2.0, 2.0), rng.uniform(-1.0, 1.0) / w
                right = _shift(pair.right, dy, slope, cx)
                total += 1
                for k, c in enumerate(layouts):
                    t = time.perf_counter()
                    est = estimate_vertical_offset(pair.left, right, c)
                    ms[k].append((time.perf_counter() - t) * 1000.0)
                    if est.tiles_used == 0:
                        continue
                    measured[k] += 1
                    b = base[k]
                    for x, errs in ((cx, err_c[k]), (0.0, err_e[k]), (w - 1.0, err_e[k])):
                        got = est.offset_px + est.slope * (x - cx) - (b.offset_px + b.slope * (x - cx))
                        errs.append(abs(got - (dy + slope * (x - cx))))
    print(f"{total} shifted pairs from {', '.join(map(str, args.dirs))}")
    for k, name in enumerate(("default", f"B ({args.b.name})")):
        c, e = np.array(err_c[k]), np.array(err_e[k])
        print(
            f"{name}: measured {measured[k] / total:.0%}; error px centre median {np.median(c):.3f} "
            f"p90 {np.percentile(c, 90):.3f}, edges median {np.median(e):.3f} "
            f"p90 {np.percentile(e, 90):.3f}; "
            f"{np.median(ms[k]):.2f} ms"
        )


if __name__ == "__main__":
    main()
