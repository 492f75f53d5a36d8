"""Issue 11: risers found from the samples' positions alone, without their normals.

On the realistic profile the plane stage finds no riser plane on many staircases whose
points are there: the grid samples on a true riser lie within 3 cm of it, but their
normals (differences of 9x9 box means 8 px apart) are a median 45-55 deg off, so the
orientation method's normal test (20 deg) refuses nearly all of them. This script
measures what a plane pass that ignores the normals would give, on the plane sets the
pipeline itself built (it is a measurement, not a pipeline stage):

- for each vertical direction the frame shows (the vertical planes found, and the image
  lines' horizontal direction and its perpendicular), the offset along it that most of
  the samples left over lie within their inlier threshold of (``clip(3 sigma, 1.2 cm,
  5 cm)``, as the orientation method), then the largest 8-connected patch of those
  inliers in the sample grid;
- kept as a vertical plane when that patch has at least ``--min-points`` samples, spans
  ``--min-height`` in height (5th-95th percentile) and 15 cm across; repeated up to 8
  times per direction;
- the terrain stage is then run on the plane set with those planes added, and scored as
  ``evaluation`` scores it, beside the plane set as it was.

Two modes: ``all`` (the extra planes always), ``extend`` (only where the planes as they
were already gave a staircase, and only when the new one keeps its steps, rises and
distances within 3 cm, and adds steps).

    .venv/bin/python benchmarks/bench_position_risers.py --scenes-dir DIR [--scenes-dir DIR2]
        [--real] [--no-rig] [--mode all|extend]

The terrain stage runs with ``continue_steps`` off (``TERRAIN``), as when these numbers
were taken; ``terrain/continuation.py`` is what the ``extend`` mode became.

``--real`` adds the real scenes of ../shared/data (no ground truth: their results are
listed when they change).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np

import stereo_terrain.pipeline.core as core
import stereo_terrain.pipeline.fill_steps as fill_steps
from stereo_terrain.calibration import read_calibration
from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.frames import load_rig
from stereo_terrain.msac import Plane
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.planes.orientation import PlaneSegment, PlaneSet
from stereo_terrain.rectify import read_image
from stereo_terrain.terrain import StairModel, TerrainConfig, build_terrain
from stereo_terrain.terrain.continuation import largest_grid_patch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_real_stairs import real_pairs  # noqa: E402

UP = np.array([0.0, 0.0, 1.0])
#: The terrain stage without its own continuation beyond the last riser plane
#: (terrain/continuation.py, which grew out of this script's "extend" mode): the plane sets
#: as they were when these numbers were taken.
TERRAIN = TerrainConfig(continue_steps=False)


class _Capture:
    """What the pipeline handed its terrain stage, and the image lines' horizontal
    direction (the Manhattan fill's argument), caught by wrapping the two calls."""

    def __init__(self) -> None:
        self.seen: dict = {}
        fill, stage = fill_steps.fill_manhattan_faces, core.Pipeline._planes_and_terrain

        def fill_hook(*a, **k):
            self.seen["horizontal_cam"] = np.asarray(a[7], dtype=np.float64)
            return fill(*a, **k)

        def stage_hook(pipeline, planes, image, lap, floor_known, lines=None):
            self.seen["planes"], self.seen["floor_known"] = planes, floor_known
            return stage(pipeline, planes, image, lap, floor_known, lines)

        fill_steps.fill_manhattan_faces = fill_hook
        core.Pipeline._planes_and_terrain = stage_hook

    def run(self, pipeline: Pipeline, left: np.ndarray, right: np.ndarray) -> dict:
        self.seen = {}
        result = pipeline.run(left, right)
        h = self.seen.get("horizontal_cam")
        self.seen["horizontal"] = None if h is None else result.T_yaw_camera_rect.apply_vectors(h)
        return self.seen


def _directions(planes: PlaneSet, horizontal: np.ndarray | None) -> list[np.ndarray]:
    """Unit horizontal directions: the vertical planes' normals, the lines' horizontal
    direction and its perpendicular; one per 5 deg."""
    cands = [s.plane.normal for s in planes.segments if s.kind == "vertical"]
    if horizontal is not None:
        cands += [np.asarray(horizontal, dtype=np.float64), np.cross(UP, horizontal)]
    out: list[np.ndarray] = []
    for n in cands:
        e = np.array([n[0], n[1], 0.0])
        length = float(np.linalg.norm(e))
        if length < 0.5:
            continue
        e /= length
        if all(abs(float(e @ o)) < math.cos(math.radians(5.0)) for o in out):
            out.append(e)
    return out


def add_position_risers(
    planes: PlaneSet, horizontal: np.ndarray | None, min_points: int, min_height_m: float
) -> PlaneSet:
    """The plane set with the position-only vertical planes added (module docstring)."""
    s = planes.samples
    pts = s.points.astype(np.float64)
    free = np.ones(len(pts), dtype=bool)
    for seg in planes.segments:
        free[seg.indices] = False
    thr = np.clip(3.0 * s.sigma_m, 0.012, 0.05)
    added: list[PlaneSegment] = []
    for e in _directions(planes, horizontal):
        across = np.cross(UP, e)
        for _ in range(8):
            idx = np.flatnonzero(free & (pts[:, 2] > -0.1))
            if len(idx) < min_points:
                break
            a = pts[idx] @ e
            sa = np.sort(a)
            t = float(np.median(thr[idx]))
            counts = np.searchsorted(sa, sa + t, side="right") - np.searchsorted(sa, sa - t)
            best: np.ndarray | None = None
            for j in np.argsort(-counts)[:20]:
                patch = largest_grid_patch(idx[np.abs(a - sa[j]) < thr[idx]], s)
                if patch is not None and (best is None or len(patch) > len(best)):
                    best = patch
            if best is None:
                break
            z = pts[best, 2]
            b = pts[best] @ across
            tall = np.percentile(z, 95) - np.percentile(z, 5) >= min_height_m
            wide = np.percentile(b, 95) - np.percentile(b, 5) >= 0.15
            if len(best) < min_points or not (tall and wide):
                break
            a0 = float(np.median(pts[best] @ e))
            normal = e if float(planes.camera_position @ e) > a0 else -e
            offset = -float(normal @ (e * a0))
            rms = float(np.sqrt(np.mean((pts[best] @ normal + offset) ** 2)))
            added.append(PlaneSegment(Plane(normal, offset), "vertical", best.astype(np.int64), rms))
            free[best] = False
    if not added:
        return planes
    return dataclasses.replace(planes, segments=tuple(planes.segments) + tuple(added))


def _as_json(model: StairModel) -> dict:
    return {
        "obstacle": model.obstacle,
        "steps": [{"rise": st.rise_m, "run": st.run_m, "distance": st.distance_m} for st in model.steps],
    }


def _extends(before: StairModel, after: StairModel, tol_m: float = 0.03) -> bool:
    n = len(before.steps)
    return (
        before.obstacle == "stairs"
        and len(after.steps) > n
        and all(
            abs(x.rise_m - y.rise_m) <= tol_m and abs(x.distance_m - y.distance_m) <= tol_m
            for x, y in zip(before.steps, after.steps[:n], strict=False)
        )
    )


def _both(seen: dict, args: argparse.Namespace) -> tuple[StairModel, StairModel]:
    planes, floor_known = seen["planes"], seen["floor_known"]
    before = build_terrain(planes, TERRAIN, floor_known=floor_known)
    if args.mode == "extend" and before.obstacle != "stairs":
        return before, before
    more = add_position_risers(planes, seen["horizontal"], args.min_points, args.min_height)
    after = build_terrain(more, TERRAIN, floor_known=floor_known)
    if args.mode == "extend" and not _extends(before, after):
        after = before
    return before, after


def _rises(model: StairModel) -> list[float]:
    return [round(st.rise_m * 100, 1) for st in model.steps]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes-dir", action="append", default=[], type=Path)
    ap.add_argument("--real", action="store_true")
    ap.add_argument("--no-rig", action="store_true")
    ap.add_argument("--mode", choices=("all", "extend"), default="all")
    ap.add_argument("--min-points", type=int, default=40)
    ap.add_argument("--min-height", type=float, default=0.06)
    args = ap.parse_args()
    cap = _Capture()
    cols = ("scenes", "planes", "detected", "false pos.", "step count", "rise cm med / p90", "run cm")
    print("| " + " | ".join(cols + ("matched steps",)) + " |")  # run: median / p90
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    changed: list[str] = []
    for folder in args.scenes_dir:
        scores: dict[str, list] = {"as found": [], "+ position-only": []}
        for d in sorted(folder.glob("scene_*")):
            rig = None if args.no_rig or not (d / "rig.yaml").exists() else load_rig(d / "rig.yaml")
            pipeline = Pipeline(read_calibration(d / "calib.yaml"), rig, warm_up=False)
            seen = cap.run(pipeline, read_image(d / "left.png"), read_image(d / "right.png"))
            truth = json.loads((d / "truth.json").read_text())
            before, after = _both(seen, args)
            scores["as found"].append(score_result(_as_json(before), truth))
            scores["+ position-only"].append(score_result(_as_json(after), truth))
            if _rises(before) != _rises(after):
                true = [round(st["rise"] * 100, 1) for st in truth.get("steps", [])]
                changed.append(f"{folder.name}/{d.name}: true {true}, {_rises(before)} -> {_rises(after)}")
        for label, sc in scores.items():
            m = summarize(sc)
            print(
                f"| {folder.name} | {label} | {m['detection_rate']:.0%} | {m['false_positive_rate']:.0%} "
                f"| {m['count_rate']:.0%} | {m['rise_median_m'] * 100:.1f} / {m['rise_p90_m'] * 100:.1f} "
                f"| {m['run_median_m'] * 100:.1f} / {m['run_p90_m'] * 100:.1f} | {m['matched_steps']:.0f} |",
                flush=True,
            )
    if args.real:
        for name, calibration, left, right in real_pairs():
            seen = cap.run(Pipeline(calibration, None, warm_up=False), left, right)
            before, after = _both(seen, args)
            changed.append(f"{name}: {before.obstacle} {_rises(before)} -> {after.obstacle} {_rises(after)}")
    print("\nResults that change (rises, cm):")
    for line in changed:
        print("-", line)


if __name__ == "__main__":
    main()
