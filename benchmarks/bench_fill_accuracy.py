"""Issue 11: how right the fills' planes are, per filled region, on rendered scene folders.

The planar fill (``stereo/fill.py``) and the Manhattan fill (``stereo/manhattan.py``) give
texture-poor regions a plane from the disparities on their outline. For every region that
the pipeline (with the scene's rig) fills, this compares the filled disparity with the
truth from the renderer's depth, and prints per fill (``planar``: the planar fill's plane
kept; ``planar, refitted``: the Manhattan fill fitted it again; ``manhattan``: filled by the
Manhattan fill only) the regions, the filled pixels, their share within 1 px and beyond
3 px of the truth (the regions' own pixels, not the rings around them that the
Manhattan fill also fills), and the regions that are wrong (fewer than half of their pixels within
1 px) with the share of their pixels that the plane puts too near (a foreground's
disparity: an occluder's edge, fattened by the matcher, in the support). ``refused``
counts the regions whose plane the planar fill refused as an occluder's
(``fill.max_behind_ratio``).

    .venv/bin/python benchmarks/bench_fill_accuracy.py --scenes-dir DIR [--scenes-dir DIR2]
        [--scenes N] [--config CFG.yaml]

``DIR`` holds scenes as ``stereo-terrain render`` writes them (``depth_left.npy`` included).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_stair_disparity import true_disparity  # noqa: E402

from stereo_terrain.calibration import read_calibration  # noqa: E402
from stereo_terrain.frames import load_rig  # noqa: E402
from stereo_terrain.pipeline import Pipeline, PipelineConfig  # noqa: E402
from stereo_terrain.rectify import read_image  # noqa: E402
from stereo_terrain.stereo.fill import fill_planar_regions  # noqa: E402

SOURCES = ("planar", "planar, refitted", "manhattan")


class _Recording(Pipeline):
    """A pipeline that keeps the matcher's disparity and the fill's regions of its last frame."""

    def _fill(self, disp, pair, flat, *args, **kwargs):
        self.last_raw, self.last_flat, self.last_pair = disp, flat, pair
        return super()._fill(disp, pair, flat, *args, **kwargs)


def scene_regions(d: Path, config: PipelineConfig) -> tuple[list[dict], int]:
    """One dict per filled region of scene folder ``d`` (source, pixels, errors), and the
    number of regions refused as occluded."""
    pipe = _Recording(read_calibration(d / "calib.yaml"), load_rig(d / "rig.yaml"), config, warm_up=False)
    result = pipe.run(read_image(d / "left.png"), read_image(d / "right.png"))
    depth = np.load(d / "depth_left.npy")
    truth, _ = true_disparity(depth, np.zeros(depth.shape, np.int16), pipe.rectification)
    raw, flat, pair = pipe.last_raw, pipe.last_flat, pipe.last_pair
    refused: list[int] = []
    planar_values, planar = fill_planar_regions(
        raw.disparity,
        pair.left,
        config.fill,
        max_disparity_px=raw.max_disparity_px,
        valid=pair.rectification.valid_left,
        regions=flat,
        occluded=refused,
    )
    values, filled = result.disparity.disparity, result.disparity.filled
    large = flat.stats[:, 4] >= config.fill.min_region_fraction * values.size
    rows = []
    for k in np.unique(flat.labels[filled]):
        region = flat.labels == k
        scored = region & filled & np.isfinite(truth)
        if k == 0 or not large[k] or not scored.any():
            continue  # the rings the fills reach into are not counted
        mine = region & planar
        if not mine.any():
            source = "manhattan"
        elif np.array_equal(values[mine], planar_values[mine]):
            source = "planar"
        else:
            source = "planar, refitted"
        err = values[scored] - truth[scored]
        rows.append(
            {
                "source": source,
                "n": int(scored.sum()),
                "good": int(np.sum(np.abs(err) <= 1.0)),
                "bad": int(np.sum(np.abs(err) > 3.0)),
                "near": int(np.sum(err > 1.0)),
            }
        )
    return rows, len(refused)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes-dir", type=Path, action="append", required=True)
    ap.add_argument("--scenes", type=int, default=0, help="first N scenes of each folder (0 = all)")
    ap.add_argument("--config", type=Path)
    args = ap.parse_args()
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    print(
        "| scenes | fill | regions | filled px | <= 1 px | > 3 px | wrong regions | "
        "their px | of which too near | refused |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for folder in args.scenes_dir:
        dirs = sorted(folder.glob("scene_*"))
        dirs = dirs[: args.scenes] if args.scenes > 0 else dirs
        rows: list[dict] = []
        refused = 0
        for i, d in enumerate(dirs):
            scene_rows, scene_refused = scene_regions(d, config)
            rows += scene_rows
            refused += scene_refused
            sys.stderr.write(f"\r{folder.name}: {i + 1}/{len(dirs)}")
        sys.stderr.write("\n")
        for source in SOURCES:
            mine = [r for r in rows if r["source"] == source]
            n = sum(r["n"] for r in mine)
            wrong = [r for r in mine if r["good"] < 0.5 * r["n"]]
            n_wrong = sum(r["n"] for r in wrong)
            if n:
                share = f"{sum(r['good'] for r in mine) / n:.1%} | {sum(r['bad'] for r in mine) / n:.1%}"
            else:
                share = "- | -"
            near = "-" if n_wrong == 0 else f"{sum(r['near'] for r in wrong) / n_wrong:.0%}"
            tail = refused if source == "planar" else ""
            print(
                f"| {folder.name} | {source} | {len(mine)} | {n} | {share} | {len(wrong)} | "
                f"{n_wrong} | {near} | {tail} |"
            )
        sys.stdout.flush()


if __name__ == "__main__":
    main()
