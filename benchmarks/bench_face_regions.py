"""Issue 11: what the planar fill does on the stair faces of realistic rendered scenes.

The fill (``stereo/fill.py``) gives a texture-poor face the plane that the matcher's
disparities on its outline support. Three things can stop it: the face is not one of the
fill's regions (the region finder splits it into crumbs or merges it with its
neighbours), no plane is supported (too few or too scattered outline disparities), or
the supported plane is wrong. For each region mode (``fill.texture``: ``total``, the default, or
``horizontal``; commit f40a8d9 also had an ``edges`` mode, measured in docs/benchmarks.md
and reverted) this prints, as
shares of the stair-face pixels (treads and risers, from the renderer's labels):

- ``in a region``: inside a region large enough to be filled (``min_region_fraction``);
- ``filled``: given a plane's value;
- the filled pixels' error against the true disparity (<= 0.5 px, <= 1 px, > 3 px).

Each mode runs twice: with the matcher's own disparities as the support ("opencv"), and
with the true disparity at the pixels where the matcher has a value ("truth at opencv's
pixels"), which separates a region finder's faults from the matcher's.

    .venv/bin/python benchmarks/bench_face_regions.py [--scenes 20] [--seed 11]
        [--modes total,horizontal] [--cache DIR]

The scenes are those of ``stereo-terrain render --profile realistic --count N --seed S``
(rectified and vertically aligned as the pipeline does; ``--cache`` as in
``bench_stair_disparity.py``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_stair_disparity import _pair, load_scenes, variant  # noqa: E402

from stereo_terrain.pipeline import PipelineConfig  # noqa: E402
from stereo_terrain.stereo.fill import fill_planar_regions, find_flat_regions  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--modes", default="total")
    ap.add_argument("--cache", type=Path)
    args = ap.parse_args()
    scenes = load_scenes("realistic", args.scenes, args.seed, args.cache)
    matcher = variant("opencv")
    base = PipelineConfig().fill
    print("| fill.texture | support | in a region | filled | filled <= 0.5 px | <= 1 px | > 3 px |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for mode in args.modes.split(","):
        config = dataclasses.replace(base, texture=mode)
        for support in ("opencv", "truth at opencv's pixels"):
            n_face = n_region = n_filled = 0
            errors = []
            for s in scenes:
                pair, _ = _pair(s)
                n = int(s["max_disparity"])
                disp = matcher(pair, n)
                truth = s["truth"]
                if support != "opencv":
                    disp = np.where(np.isfinite(disp), truth, np.nan).astype(np.float32)
                valid = pair.rectification.valid_left
                regions = find_flat_regions(pair.left, config, valid)
                values, filled = fill_planar_regions(
                    disp, pair.left, config, max_disparity_px=n, valid=valid, regions=regions
                )
                face = ((s["cls"] == 0) | (s["cls"] == 1)) & np.isfinite(truth)
                h, w = disp.shape
                big = np.flatnonzero(regions.stats[:, 4] >= config.min_region_fraction * h * w)
                in_region = np.isin(regions.labels, big[big > 0])
                n_face += int(face.sum())
                n_region += int((face & in_region).sum())
                n_filled += int((face & filled).sum())
                errors.append(np.abs(values[face & filled] - truth[face & filled]))
            e = np.concatenate(errors)

            def share(x: float) -> str:
                return f"{x:.1%}"

            print(
                f"| {mode} | {support} | {share(n_region / n_face)} | {share(n_filled / n_face)} | "
                f"{share(np.mean(e <= 0.5))} | {share(np.mean(e <= 1.0))} | {share(np.mean(e > 3.0))} |"
            )
            sys.stdout.flush()


if __name__ == "__main__":
    main()
