"""Issue 11 ("Real stairs"): the realistic rendered profile beside the default one, with and
without a rig, and the real scenes of ../shared/data that have no ground truth.

For each profile, the same scenes are run twice: with the true rig (gravity from the rig)
and without one (gravity from the scene's plane families). Columns: detection, false
positives (scenes without an obstacle), step count, rise / run / first-riser distance
errors (median and p90, cm) and, without a rig, the angle between the estimated and the
true up (median, p90, share within 2 deg). Then one line per real scene.

    .venv/bin/python benchmarks/bench_real_stairs.py [--scenes 60] [--seed 11]
        [--profiles default,realistic] [--config CFG.yaml] [--real-only]
    # or on scenes written by `stereo-terrain render [--profile realistic]` (any version
    # of the package can run this form, so before/after use the same images):
    .venv/bin/python benchmarks/bench_real_stairs.py --scenes-dir DIR [--scenes-dir DIR2 ...]

Gravity error: the angle between the up of the result's yaw frame and the scene's true
up, both in the rectified left camera; a result whose gravity did not come from the scene
(assumed level) counts with its real error.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"

#: (name, folder, left, right, calibration, what a correct result is)
REAL_SCENES = [
    ("Staircase", "middlebury2014Q_noGT/Staircase", "im0.png", "im1.png", "calib.txt", "stairs, >= 4 steps"),
    ("Classroom2", "middlebury2014Q_noGT/Classroom2", "im0.png", "im1.png", "calib.txt", "tiered floor"),
    ("corridor", "oakd_lite/corridor", "left.png", "right.png", "stereodemo_calibration.json", "no stairs"),
    ("desk", "oakd_lite/desk", "left.png", "right.png", "stereodemo_calibration.json", "no stairs"),
    (
        "living_room",
        "oakd_lite/living_room",
        "left.png",
        "right.png",
        "stereodemo_calibration.json",
        "no stairs",
    ),
]


def real_pairs(with_rooms: bool = True):
    """``(name, calibration, left, right)`` of each real scene of ``REAL_SCENES`` that is
    present, then (``with_rooms``) of each Middlebury 2014 object scene (rooms without
    stairs), read from ../shared/data."""
    items = [(n, DATA / f, lf, rf, c) for n, f, lf, rf, c, _ in REAL_SCENES]
    if with_rooms:
        root = DATA / "middlebury2014Q"
        items += [(d.name, d, "im0.png", "im1.png", "calib.txt") for d in sorted(root.glob("*"))]
    for name, d, lf, rf, c in items:
        if d.is_dir():
            yield name, read_calibration(d / c), read_image(d / lf), read_image(d / rf)


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two vectors, degrees (here, not from the package: older versions of it
    must run this script too)."""
    c = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _up(T) -> np.ndarray:
    """Gravity-up in the source frame of ``T`` (``T_yaw_<frame>``)."""
    return T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))


def run_scene(calibration, rig, left, right, truth, config: PipelineConfig, out: dict[str, list]) -> None:
    with_rig = Pipeline(calibration, rig, config)
    out["rig"].append(score_result(with_rig.run(left, right).to_json_dict(), truth))
    free = Pipeline(calibration, None, config)
    result = free.run(left, right)
    data = result.to_json_dict()
    out["scene"].append(score_result(data, truth))
    true_up = _up(rig.T_yaw_camera @ free.rectification.T_camera_rect)
    out["gravity_err"].append(angle_deg(_up(result.T_yaw_camera_rect), true_up))
    sigma = (data.get("gravity") or {}).get("sigma_deg")
    out["gravity_sigma"].append(float("nan") if sigma is None else float(sigma))


def run_profile(profile: str, n: int, seed: int, config: PipelineConfig) -> dict[str, list]:
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    rng = np.random.default_rng(seed)
    out: dict[str, list] = {"rig": [], "scene": [], "gravity_err": [], "gravity_sigma": []}
    for i in range(n):
        scene = render_scene(random_scene_spec(rng, profile=profile))
        run_scene(scene.calibration, scene.rig, scene.left, scene.right, scene.truth, config, out)
        sys.stderr.write(f"\r{profile}: {i + 1}/{n}")
    sys.stderr.write("\n")
    return out


def run_folder(folder: Path, config: PipelineConfig) -> dict[str, list]:
    """Scenes in the layout ``render`` writes (scene_*/left.png, right.png, calib.yaml,
    rig.yaml, truth.json)."""
    from stereo_terrain.frames import load_rig

    out: dict[str, list] = {"rig": [], "scene": [], "gravity_err": [], "gravity_sigma": []}
    dirs = sorted(folder.glob("scene_*"))
    for i, d in enumerate(dirs):
        truth = json.loads((d / "truth.json").read_text())
        left, right = read_image(d / "left.png"), read_image(d / "right.png")
        run_scene(
            read_calibration(d / "calib.yaml"), load_rig(d / "rig.yaml"), left, right, truth, config, out
        )
        sys.stderr.write(f"\r{folder.name}: {i + 1}/{len(dirs)}")
    sys.stderr.write("\n")
    return out


def row(name: str, scores, grav=None, sigma=None) -> str:
    s = {"run_p90_m": float("nan"), "first_distance_p90_m": float("nan"), **summarize(scores)}
    cm = 100.0

    def f(x: float) -> str:
        return "-" if not np.isfinite(x) else f"{x * cm:.1f}"

    g = "| - | - | - | -"
    if grav is not None:
        e = np.array(grav)
        fin = e[np.isfinite(e)]
        g = (
            f"| {np.median(fin):.2f} | {np.percentile(fin, 90):.2f} | {np.mean(e < 2.0):.0%}"
            if len(fin)
            else "| - | - | 0%"
        )
        sg = np.array(sigma if sigma is not None else [np.nan] * len(e))
        has = np.isfinite(sg) & np.isfinite(e)
        # Coverage of the reported 1-sigma: the share of scenes (with a sigma) within 2 sigma.
        g += f" | {np.mean(e[has] <= 2.0 * sg[has]):.0%} of {int(has.sum())}" if has.any() else " | -"
    return (
        f"| {name} | {int(s['scenes'])} | {s['detection_rate']:.0%} | {s['false_positive_rate']:.0%} | "
        f"{s['count_rate']:.0%} | {f(s['rise_median_m'])} / {f(s['rise_p90_m'])} | "
        f"{f(s['run_median_m'])} / {f(s['run_p90_m'])} | "
        f"{f(s['first_distance_median_m'])} / {f(s['first_distance_p90_m'])} {g} |"
    )


def real_scenes(config: PipelineConfig) -> None:
    print(
        "\n| real scene | expected | result | steps (rise / run, cm) | yaw deg | gravity | "
        "up vs planes alone, deg | ms |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, folder, left, right, calib, expected in REAL_SCENES:
        d = DATA / folder
        if not d.is_dir():
            print(f"| {name} | {expected} | (missing: {d}) | | | | |")
            continue
        pipeline = Pipeline(read_calibration(d / calib), None, config)
        L, R = read_image(d / left), read_image(d / right)
        pipeline.run(L, R)  # warm
        t = time.perf_counter()
        result = pipeline.run(L, R)
        ms = (time.perf_counter() - t) * 1000.0
        data = result.to_json_dict()
        steps = ", ".join(
            f"{s['rise'] * 100:.1f}/" + ("-" if s["run"] is None else f"{s['run'] * 100:.1f}")
            for s in data["steps"]
        )
        yaw = "-" if data["yaw"] is None or data["obstacle"] == "none" else f"{np.degrees(data['yaw']):.0f}"
        g = data.get("gravity") or {}
        grav = data["gravity_source"] + (
            f" +-{g['sigma_deg']:.1f} deg" if g.get("sigma_deg") is not None else ""
        )
        print(
            f"| {name} | {expected} | {data['obstacle']} | {steps} | {yaw} | {grav} | "
            f"{_planes_alone_deg(result, config, pipeline.calibration, L, R)} | {ms:.0f} |"
        )


def _planes_alone_deg(result, config: PipelineConfig, calibration, left, right) -> str:
    """Angle between the result's up and the up of the planes alone (the image's vertical
    lines off, ``vanishing: {enabled: false}``); '-' for a version without them."""
    try:
        alone = dataclasses.replace(config, vanishing=dataclasses.replace(config.vanishing, enabled=False))
    except (AttributeError, TypeError):
        return "-"
    other = Pipeline(calibration, None, alone).run(left, right)
    return f"{angle_deg(_up(result.T_yaw_camera_rect), _up(other.T_yaw_camera_rect)):.1f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=60)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--profiles", default="default,realistic")
    ap.add_argument("--config", type=Path, help="pipeline config YAML (default settings without)")
    ap.add_argument("--real-only", action="store_true", help="only the real scenes")
    ap.add_argument("--scenes-dir", type=Path, action="append", help="rendered scenes instead of --profiles")
    ap.add_argument("--dump", type=Path, help="per-scene gravity error and sigma (JSON)")
    args = ap.parse_args()
    dumped: dict[str, dict[str, list]] = {}
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    header = (
        "| scenes, gravity from | n | detected | false pos. | step count | rise cm med / p90 | "
        "run cm med / p90 | 1st distance cm med / p90 | gravity err deg med | p90 | within 2 deg | "
        "err <= 2 sigma |"
    )
    if args.scenes_dir and not args.real_only:
        print(header)
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for folder in args.scenes_dir:
            res = run_folder(folder, config)
            dumped[folder.name] = {k: res[k] for k in ("gravity_err", "gravity_sigma")}
            print(row(f"{folder.name}, rig", res["rig"]))
            print(
                row(f"{folder.name}, scene (no rig)", res["scene"], res["gravity_err"], res["gravity_sigma"])
            )
            sys.stdout.flush()
    elif not args.real_only:
        print(header)
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for profile in args.profiles.split(","):
            res = run_profile(profile, args.scenes, args.seed, config)
            dumped[profile] = {k: res[k] for k in ("gravity_err", "gravity_sigma")}
            print(row(f"{profile}, rig", res["rig"]))
            print(row(f"{profile}, scene (no rig)", res["scene"], res["gravity_err"], res["gravity_sigma"]))
            sys.stdout.flush()
    if args.dump is not None:
        args.dump.write_text(json.dumps(dumped, indent=1) + "\n")
    real_scenes(config)


if __name__ == "__main__":
    main()
