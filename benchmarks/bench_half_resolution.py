"""Matching at half resolution: per pixel on stair faces, end to end, and on the real scenes.

Why: on the ``realistic`` profile OpenCV's 3-way SGBM gets only about a fifth of the stair
faces' pixels within 1 px (blur, JPEG, sensor noise and faces with little or no texture).
Matching a 2x2-averaged pair (the noise halved, the matcher's block and smoothness reaching
twice as far) is the classic answer and costs an eighth of the full-resolution match. This
script measures three ways of using it, with the package's default pipeline otherwise:

* ``half``: the half-resolution disparity, doubled and upsampled (bilinear; a pixel next
  to an invalid one is invalid);
* ``agree``: ``half``, with the full-resolution disparity wherever it is within
  ``--agree-px`` of it (full precision where both scales agree);
* ``holes``: the full-resolution disparity, ``half`` only in its holes.

Sections: per-pixel shares on treads and risers of rendered scenes (as
``bench_stair_disparity.py`` scores them, the left band of ``max_disparity`` columns
left out), the end-to-end scores on ``render``-layout folders with their rigs
(``evaluation``), and the result on each real scene of ``bench_real_stairs.REAL_SCENES``
and the Middlebury 2014 scenes (no rig, as a new user runs it).

    .venv/bin/python benchmarks/bench_half_resolution.py [--pixels realistic,default]
        [--scenes 30] [--cache DIR] [--scenes-dir DIR ...] [--real] [--modes half,agree,holes]

Result (2026-12-02, docs/benchmarks.md): large gains on rendered realistic scenes, but
false stairs on the real OAK-D corridor (``half``, ``holes``) or the Middlebury Staircase
lost (``agree``): SGBM's propagation into texture-poor areas, which the coarse scale
doubles, is right on the renderer's planar faces and wrong on real ones. Not kept.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import cv2
import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.evaluation import score_result
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.rectify import RectifiedPair, read_image
from stereo_terrain.stereo import DisparityMap
from stereo_terrain.stereo.opencv import OpenCVSGBM, OpenCVSGBMConfig, create_sgbm

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_oracle_disparity import print_scores  # noqa: E402
from bench_real_stairs import DATA, REAL_SCENES  # noqa: E402
from bench_stair_disparity import _pair, load_scenes  # noqa: E402

MODES = ("full", "half", "agree", "holes")


class HalfResolutionSGBM:
    """OpenCV SGBM on the 2x2-averaged pair, combined with the full-resolution match as
    ``mode`` says (a :class:`~stereo_terrain.stereo.DisparityBackend`)."""

    name = "opencv"

    def __init__(self, mode: str, agree_px: float = 1.5) -> None:
        if mode not in MODES:
            raise SystemExit(f"unknown mode '{mode}'; choose from {', '.join(MODES)}")
        self.mode, self.agree_px = mode, agree_px
        self.full = OpenCVSGBM()
        self._half: dict[int, cv2.StereoSGBM] = {}

    def half_disparity(self, pair: RectifiedPair, n: int) -> np.ndarray:
        h, w = pair.left.shape
        size = ((w + 1) // 2, (h + 1) // 2)
        left = cv2.resize(pair.left, size, interpolation=cv2.INTER_AREA)
        right = cv2.resize(pair.right, size, interpolation=cv2.INTER_AREA)
        n2 = max(16, -(-(n // 2) // 16) * 16)
        if n2 not in self._half:
            # Same per-pixel penalties; the speckle window counts a quarter of the pixels.
            c = OpenCVSGBMConfig()
            c = dataclasses.replace(c, speckle_window_px=max(1, c.speckle_window_px // 4))
            self._half[n2] = create_sgbm(c, n2)
        raw = self._half[n2].compute(left, right)
        invalid = raw < 0
        d2 = raw.astype(np.float32) / 8.0  # 1/16 px fixed point, doubled to full-resolution pixels
        d2[invalid] = 0.0
        up = cv2.resize(d2, (w, h), interpolation=cv2.INTER_LINEAR)
        bad = cv2.resize(invalid.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST)
        bad = cv2.dilate(bad, np.ones((3, 3), np.uint8)).astype(bool)
        up[bad] = np.nan
        if pair.rectification.valid_left is not None:
            up[~pair.rectification.valid_left] = np.nan
        return up

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
        full = self.full.compute(pair, max_disparity_px)
        if self.mode == "full":
            return full
        d = self.half_disparity(pair, full.max_disparity_px)
        f = full.disparity
        if self.mode == "agree":
            take = np.isfinite(f) & (np.abs(f - d) <= self.agree_px)
            d[take] = f[take]
        elif self.mode == "holes":
            take = np.isfinite(f)
            d[take] = f[take]
        return DisparityMap(d, full.max_disparity_px, pair.rectification, None, self.name)


def pixel_shares(profile: str, n: int, cache: Path | None, modes: list[str], agree_px: float) -> None:
    scenes = load_scenes(profile, n, 11, cache)
    counts = {m: np.zeros(4) for m in modes}
    backends = {m: HalfResolutionSGBM(m, agree_px) for m in modes}
    for s in scenes:
        pair, _ = _pair(s)
        mx = int(s["max_disparity"])
        face = (s["cls"] == 0) | (s["cls"] == 1)
        face[:, :mx] = False
        for m in modes:
            e = np.abs(backends[m].compute(pair, mx).disparity - s["truth"])[face]
            fin = np.isfinite(e)
            a = e[fin]
            counts[m] += (np.sum(a <= 1), np.sum((a > 1) & (a <= 3)), np.sum(a > 3), np.sum(~fin))
    print(f"\n{profile}, {n} scenes (seed 11), treads and risers")
    print("| mode | good <= 1 px | 1-3 px | bad > 3 px | invalid |")
    print("| --- | --- | --- | --- | --- |")
    for m in modes:
        c = counts[m] / counts[m].sum()
        print(f"| {m} | {c[0]:.1%} | {c[1]:.1%} | {c[2]:.1%} | {c[3]:.1%} |")


def end_to_end(folder: Path, modes: list[str], agree_px: float) -> None:
    scores: dict[str, list] = {m: [] for m in modes}
    for d in sorted(folder.glob("scene_*")):
        truth = json.loads((d / "truth.json").read_text())
        left, right = read_image(d / "left.png"), read_image(d / "right.png")
        for m in modes:
            p = Pipeline(read_calibration(d / "calib.yaml"), load_rig(d / "rig.yaml"), warm_up=False)
            p.backend = HalfResolutionSGBM(m, agree_px)
            scores[m].append(score_result(p.run(left, right).to_json_dict(), truth))
    print_scores(f"\n{folder} ({len(scores[modes[0]])} scenes, rig)", "mode", scores)


def real(modes: list[str], agree_px: float) -> None:
    scenes = [(n, DATA / f, le, ri, c, want) for n, f, le, ri, c, want in REAL_SCENES]
    mb = DATA / "middlebury2014Q"
    if mb.is_dir():
        scenes += [(d.name, d, "im0.png", "im1.png", "calib.txt", "-") for d in sorted(mb.iterdir())]
    print("\nreal scenes (no rig): obstacle and rises (cm)")
    print("| scene | expected | " + " | ".join(modes) + " |")
    print("|" + " --- |" * (len(modes) + 2))
    for name, d, le, ri, c, want in scenes:
        if not d.is_dir():
            continue
        cells = []
        for m in modes:
            p = Pipeline(read_calibration(d / c), None)
            p.backend = HalfResolutionSGBM(m, agree_px)
            j = p.run(read_image(d / le), read_image(d / ri)).to_json_dict()
            cells.append(f"{j['obstacle']} {[round(100 * s['rise'], 1) for s in j['steps']]}")
        print(f"| {name} | {want} | " + " | ".join(cells) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pixels", default="realistic,default", help="profiles of the per-pixel table ('' none)")
    ap.add_argument("--scenes", type=int, default=30)
    ap.add_argument("--cache", type=Path, help="rendered pairs kept here (see bench_stair_disparity.py)")
    ap.add_argument("--scenes-dir", type=Path, action="append", default=[])
    ap.add_argument("--real", action="store_true", help="the real scenes too")
    ap.add_argument("--modes", default=",".join(MODES))
    ap.add_argument("--agree-px", type=float, default=1.5)
    args = ap.parse_args()
    modes = args.modes.split(",")
    for profile in filter(None, args.pixels.split(",")):
        pixel_shares(profile, args.scenes, args.cache, modes, args.agree_px)
    for folder in args.scenes_dir:
        end_to_end(folder, modes, args.agree_px)
    if args.real:
        real(modes, args.agree_px)


if __name__ == "__main__":
    main()
