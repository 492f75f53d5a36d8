"""Tracking (issue 14): single frames against the tracked staircase on simulated approaches.

Each approach (``runtime/simulate/``: a trotting robot with the trot's pitch oscillation
walks from 2.2 m to 0.01 m before a staircase, so that the first riser leaves the view
and the swing is raised (0.1 m before it); rises 0.12-0.22 m, stair yaw 0-30 deg, odometry drift 0-2 %,
640x480 and 320x240) is rendered once and every frame runs the pipeline once; the frame's
model then goes (a) to the swing trigger alone, as with ``tracking: {enabled: false}``,
(b) through the tracker without its check of uniform runs (``tracking: {uniform_runs:
false}``, the tracker before the thirty-second session) and (c) through the tracker, as
``run``/``replay`` do by default (:func:`stereo_terrain.runtime.loop.track_and_trigger`
in all three). The odometry given to the
tracker and the trigger is the drifted one; the errors are against the truth.

Per mode, over all frames that report a step (published ``rise_m[0]``, ``distance_m[0]``):
median and p90 of |error| of the first step's rise and distance, the jitter (std of the
error over the frames of an approach, median over approaches), the sigma coverage
(fraction of frames with |error| <= 2 sigma), and the swing-decision flips (changes of
``raise_swing`` beyond the one expected; with tracking, counted once the track is
confirmed; also a swing height changing by more than 2 cm or the trigger point by more
than 5 cm between two frames).

``--profile realistic`` walks the same way toward stairs dressed as the realistic
profile's scenes (issue 11: side walls, handrails, wood or paint, a webcam's lens, noise
and JPEG; ``ApproachConfig.profile``) with a mostly level camera, from 2.0 m to 0.45 m,
on approaches drawn from ``--seed`` (rise 0.12-0.22 m, run 0.22-0.35 m, 3-6 steps, width
0.8-1.6 m, stair yaw +-30 deg, camera 0.3-0.6 m high pitched down 0-10 deg); it adds the
step count: the fraction of frames whose published staircase has the true number of
steps, over all frames and over those with the first riser 0.8 m or more ahead (the
single-frame realistic benchmark's range), and at the last frame.

``--noise`` measures the matching noise the step sigmas assume
(``TerrainConfig.disparity_sigma_px``, ``disparity_bias_px``) on the same frames.

Run: ``PYTHONPATH=src python benchmarks/bench_tracking.py`` (10 approaches, 6 fps, 27
frames each, about 4 min on 2 shared cores); ``--fps 10`` for more frames per approach;
``--profile realistic --count 12`` (19 frames each, about 1 min per approach).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import numpy as np

from stereo_terrain.pipeline import Pipeline
from stereo_terrain.runtime.loop import track_and_trigger
from stereo_terrain.runtime.simulate import ApproachConfig, approach_spec, render_approach, true_x
from stereo_terrain.swing import SwingTrigger
from stereo_terrain.synthetic import render_scene
from stereo_terrain.tracking import TRACK_CONFIRMED, StairTracker, TrackingConfig

#: The floor the simulated robot stands on, in its body (yaw) frame: the approach's rig has
#: its body origin on the ground (a rig off a robot, docs/conventions.md). Single frames
#: use it to tell when their nearest riser is not the first (``TrackingConfig.floor_z_m``).
FLOOR_Z_M = 0.0

#: (rise m, stair yaw deg, odometry drift, image size, seed)
APPROACHES = [
    (0.12, 0.0, 0.00, (320, 240), 1),
    (0.15, 10.0, 0.01, (320, 240), 2),
    (0.17, 20.0, 0.02, (320, 240), 3),
    (0.19, 30.0, 0.00, (320, 240), 4),
    (0.22, 0.0, 0.02, (320, 240), 5),
    (0.14, 30.0, -0.02, (320, 240), 6),
    (0.21, 15.0, 0.01, (320, 240), 7),
    (0.16, 5.0, -0.01, (320, 240), 8),
    (0.18, 25.0, 0.02, (640, 480), 9),
    (0.13, 0.0, 0.01, (640, 480), 10),
]


#: Single frames; the tracker without and with its check of uniform runs
#: (``TrackingConfig.uniform_runs``, the default).
MODES = ("single", "tracked, any runs", "tracked")

#: The single-frame realistic benchmark's range of first-riser distances starts here.
NEAR_M = 0.8


def realistic_approaches(count: int, seed: int, fps: float) -> list[ApproachConfig]:
    """``count`` realistic approaches drawn from ``seed`` (ranges in the module's doc)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        out.append(
            ApproachConfig(
                profile="realistic",
                seed=int(rng.integers(0, 2**31 - 1)),
                fps=fps,
                supersample=2,
                rise_m=float(rng.uniform(0.12, 0.22)),
                run_m=float(rng.uniform(0.22, 0.35)),
                n_steps=int(rng.integers(3, 7)),
                width_m=float(rng.uniform(0.8, 1.6)),
                stair_yaw_rad=math.radians(float(rng.uniform(-30.0, 30.0))),
                camera_height_m=float(rng.uniform(0.3, 0.6)),
                pitch_down_rad=math.radians(float(rng.uniform(0.0, 10.0))),
                odometry_drift=float(rng.uniform(-0.02, 0.02)),
                start_distance_m=2.0,
                end_distance_m=0.45,
            )  # fmt: skip
        )
    return out


def run_approach(cfg: ApproachConfig, noise: list | None = None) -> dict[str, list]:
    """Per mode (:data:`MODES`): per frame (rise error, rise sigma, distance
    error, distance sigma, raise_swing, track state, swing height, trigger point, steps
    published, true first-riser distance)."""
    first = render_scene(approach_spec(cfg, 0.0, 0.0))
    rig = dataclasses.replace(first.rig, body_rpy=(0.0, 0.0, 0.0))
    pipeline = Pipeline(first.calibration, rig)
    modes = {
        "single": (None, SwingTrigger()),
        "tracked, any runs": (StairTracker(TrackingConfig(uniform_runs=False)), SwingTrigger()),
        "tracked": (StairTracker(), SwingTrigger()),
    }
    rows: dict[str, list] = {k: [] for k in modes}
    for frame, _scene in render_approach(cfg):
        pipeline.set_rig(dataclasses.replace(rig, body_rpy=frame.body_rpy))
        result = pipeline.run(frame.left, frame.right)
        if noise is not None:
            noise.append(_noise(result, cfg, frame.t_capture_s, pipeline))
        d_true = cfg.start_distance_m - true_x(cfg, frame.t_capture_s)
        cam_z = float(result.T_yaw_camera_rect.translation[2])
        for name, (tracker, trigger) in modes.items():
            model, state, trig = track_and_trigger(
                tracker, trigger, result.terrain, frame.odometry, frame.t_capture_s,
                camera_z_m=cam_z, floor_z_m=FLOOR_Z_M,
            )  # fmt: skip
            if model.steps:
                s = model.steps[0]
                row = (s.rise_m - cfg.rise_m, s.rise_sigma_m, s.distance_m - d_true, s.distance_sigma_m)
            else:
                row = (math.nan,) * 4
            # the controller's decision: raise or not, the swing height, and where (world x
            # by the odometry) the swing will be raised
            at = math.nan
            if trig.trigger_distance_m is not None:
                at = trig.p0_m[0] + trig.trigger_distance_m * math.cos(trig.heading_rad)
            decision = (trig.raise_swing, state, trig.swing_height_m, at)
            rows[name].append((*row, *decision, len(model.steps), d_true))
    return rows


def _noise(result, cfg: ApproachConfig, t_s: float, pipeline: Pipeline) -> tuple[list, float]:
    """Disparity spread of plane inliers (px) and the first riser's disparity error (px)."""
    rect = pipeline.rectification
    fb = rect.focal_px * rect.baseline_m
    P = result.planes.samples.points
    cam = result.planes.camera_position
    spreads = []
    for seg in result.planes.segments:
        q = P[seg.indices]
        rng = np.linalg.norm(q - cam, axis=1)
        ray_cos = np.abs(((q - cam) / rng[:, None]) @ seg.plane.normal)
        d_px = seg.plane.signed_distance(q) / np.maximum(ray_cos, 0.2) * fb / rng**2
        spreads.append(1.4826 * float(np.median(np.abs(d_px - np.median(d_px)))))
    bias = math.nan
    steps = result.terrain.steps
    d_true = cfg.start_distance_m - true_x(cfg, t_s)
    if steps and abs(steps[0].distance_m - d_true) < 0.1:
        rng0 = float(np.hypot(steps[0].distance_m, cam[2] - steps[0].top_z_m / 2))
        bias = (steps[0].distance_m - d_true) * math.cos(cfg.stair_yaw_rad) * fb / rng0**2
    return spreads, bias


#: A change of the planned swing height or of the point where the swing will be raised
#: larger than these between two frames changes the decision.
HEIGHT_FLIP_M = 0.02
TRIGGER_FLIP_M = 0.05


def flips(rows: list, tracked: bool) -> int:
    """How often the swing decision changes beyond the one expected off -> on of
    ``raise_swing`` (after the track is confirmed, with tracking): ``raise_swing`` toggles,
    the swing height moving by more than HEIGHT_FLIP_M, the trigger point by more than
    TRIGGER_FLIP_M (or appearing / vanishing) between consecutive frames."""
    if tracked:
        start = next((i for i, r in enumerate(rows) if r[5] == TRACK_CONFIRMED), len(rows))
        rows = rows[start:]
    raised = [r[4] for r in rows]
    changes = sum(a != b for a, b in zip(raised, raised[1:], strict=False))
    n = max(0, changes - (1 if any(raised) else 0))
    for a, b in zip(rows, rows[1:], strict=False):
        if not math.isfinite(a[7]) or a[4] or b[4]:
            continue  # no decision yet (the first one is no change), or raised already
        if not math.isfinite(b[7]):
            n += 1  # the decision was dropped
        else:
            n += abs(a[6] - b[6]) > HEIGHT_FLIP_M or abs(a[7] - b[7]) > TRIGGER_FLIP_M
    return n


def _pct(v: np.ndarray, q: float) -> float:
    return float(np.percentile(v, q)) if len(v) else math.nan


def summarize(per_approach: list[dict[str, list]], n_true: list[int]) -> dict[str, dict[str, float]]:
    """Per mode, the errors, jitter, coverage, flips and count rates (NaN where a mode
    published no step)."""
    out = {}
    for mode in MODES:
        a = np.array([r[:4] for rows in per_approach for r in rows[mode]], dtype=float).reshape(-1, 4)
        ok = np.isfinite(a[:, 0])
        a = a[ok]
        jit_r, jit_d, f2f_r, f2f_d = [], [], [], []
        for rows in per_approach:
            b = np.array([r[:4] for r in rows[mode]], dtype=float)
            b = b[np.isfinite(b[:, 0])]
            if len(b) > 2:
                jit_r.append(np.std(b[:, 0]))
                jit_d.append(np.std(b[:, 2]))
                # frame to frame: the change between consecutive frames, rms / sqrt(2)
                f2f_r.append(np.sqrt(np.mean(np.diff(b[:, 0]) ** 2) / 2))
                f2f_d.append(np.sqrt(np.mean(np.diff(b[:, 2]) ** 2) / 2))
        out[mode] = {
            "frames": int(len(a)),
            "rise_med_cm": 100 * _pct(np.abs(a[:, 0]), 50),
            "rise_p90_cm": 100 * _pct(np.abs(a[:, 0]), 90),
            "dist_med_cm": 100 * _pct(np.abs(a[:, 2]), 50),
            "dist_p90_cm": 100 * _pct(np.abs(a[:, 2]), 90),
            "rise_jitter_cm": 100 * _pct(np.array(jit_r), 50),
            "dist_jitter_cm": 100 * _pct(np.array(jit_d), 50),
            "rise_f2f_cm": 100 * _pct(np.array(f2f_r), 50),
            "dist_f2f_cm": 100 * _pct(np.array(f2f_d), 50),
            "rise_cov": float(np.mean(np.abs(a[:, 0]) <= 2 * a[:, 1])) if len(a) else math.nan,
            "dist_cov": float(np.mean(np.abs(a[:, 2]) <= 2 * a[:, 3])) if len(a) else math.nan,
            "flips": int(sum(flips(rows[mode], mode != "single") for rows in per_approach)),
            "raised": int(sum(any(r[4] for r in rows[mode]) for rows in per_approach)),
            **count_rates(per_approach, n_true, mode),
        }
    return out


def count_rates(per_approach: list[dict[str, list]], n_true: list[int], mode: str) -> dict[str, float]:
    """Fractions of frames whose published staircase has the true number of steps: all
    frames, those with the first riser NEAR_M or more ahead, and the approaches' last
    frames."""
    every, far, last = [], [], []
    for rows, n in zip(per_approach, n_true, strict=True):
        right = [r[8] == n for r in rows[mode]]
        every += right
        far += [ok for ok, r in zip(right, rows[mode], strict=True) if r[9] >= NEAR_M]
        last.append(right[-1] if right else False)
    rate = lambda v: float(np.mean(v)) if v else math.nan  # noqa: E731
    return {"count_all": rate(every), "count_far": rate(far), "count_last": rate(last)}


def _brief(m: dict[str, float]) -> str:
    return (
        f"[rise err {m['rise_med_cm']:.2f} jit {m['rise_f2f_cm']:.2f} cov {m['rise_cov']:.0%}; "
        f"dist err {m['dist_med_cm']:.2f} jit {m['dist_f2f_cm']:.2f} cov {m['dist_cov']:.0%}; "
        f"count {m['count_far']:.0%} far, {m['count_all']:.0%} all]"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fps", type=float, default=6.0, help="camera rate of the approaches (default 6)")
    ap.add_argument("--count", type=int, default=len(APPROACHES), help="first N approaches")
    ap.add_argument("--noise", action="store_true", help="also measure the matching noise")
    ap.add_argument(
        "--profile", choices=("default", "realistic"), default="default",
        help="the approaches' look (default: the fixed list of textured staircases)",
    )  # fmt: skip
    ap.add_argument(
        "--seed",
        type=int,
        default=11,
        help="draws the realistic approaches (default 11; the default list is fixed)",
    )
    args = ap.parse_args()
    t0 = time.time()
    per, noise, n_true = [], [] if args.noise else None, []
    if args.profile == "realistic":
        configs = realistic_approaches(args.count, args.seed, args.fps)
    else:
        configs = [
            ApproachConfig(
                rise_m=rise,
                stair_yaw_rad=math.radians(yaw_deg),
                odometry_drift=drift,
                image_size=size,
                seed=seed,
                fps=args.fps,
                supersample=2 if size[0] <= 320 else 1,
                end_distance_m=0.01,
            )  # fmt: skip
            for rise, yaw_deg, drift, size, seed in APPROACHES[: args.count]
        ]
    for cfg in configs:
        rows = run_approach(cfg, noise)
        per.append(rows)
        n_true.append(cfg.n_steps)
        one = summarize([rows], [cfg.n_steps])
        size, drift = cfg.image_size, cfg.odometry_drift
        print(
            f"rise {cfg.rise_m:.2f} yaw {math.degrees(cfg.stair_yaw_rad):5.1f} {cfg.n_steps} steps "
            f"drift {100 * drift:+.0f}% {size[0]}x{size[1]}: "
            f"{len(rows['single'])} frames; single -> tracked (any runs) -> tracked: "
            + " -> ".join(_brief(one[mode]) for mode in MODES),
            flush=True,
        )
    s = summarize(per, n_true)
    print(f"\n{len(per)} {args.profile} approaches at {args.fps:g} fps, {time.time() - t0:.0f} s\n")
    keys = [
        ("frames", "frames with a step", "{:d}"),
        ("rise_med_cm", "rise error median (cm)", "{:.2f}"),
        ("rise_p90_cm", "rise error p90 (cm)", "{:.2f}"),
        ("dist_med_cm", "distance error median (cm)", "{:.2f}"),
        ("dist_p90_cm", "distance error p90 (cm)", "{:.2f}"),
        ("rise_jitter_cm", "rise jitter, std over frames (cm)", "{:.2f}"),
        ("dist_jitter_cm", "distance jitter, std over frames (cm)", "{:.2f}"),
        ("rise_f2f_cm", "rise jitter, frame to frame (cm)", "{:.2f}"),
        ("dist_f2f_cm", "distance jitter, frame to frame (cm)", "{:.2f}"),
        ("rise_cov", "rise coverage, abs(error) <= 2 sigma", "{:.0%}"),
        ("dist_cov", "distance coverage, abs(error) <= 2 sigma", "{:.0%}"),
        ("flips", "swing-decision flips", "{:d}"),
        ("raised", "approaches whose swing was raised", "{:d}"),
        ("count_far", f"step count right, frames with the first riser >= {NEAR_M} m ahead", "{:.0%}"),
        ("count_all", "step count right, all frames", "{:.0%}"),
        ("count_last", "step count right at the last frame", "{:.0%}"),
    ]
    print("| | single frames | tracked, runs not checked | tracked |\n| --- | --- | --- | --- |")
    for key, label, fmt in keys:
        print(f"| {label} | " + " | ".join(fmt.format(s[mode][key]) for mode in MODES) + " |")
    for key in ("rise_jitter_cm", "dist_jitter_cm", "rise_f2f_cm", "dist_f2f_cm"):
        ratio = s["single"][key] / max(s["tracked"][key], 1e-9)
        print(f"{key}: single / tracked = {ratio:.1f}x")
    if noise:
        spreads = [x for sp, _ in noise for x in sp]
        biases = np.array([b for _, b in noise if math.isfinite(b)])
        print(
            f"\nmatching noise: inlier disparity spread median {np.median(spreads):.3f} px "
            f"(p90 {np.percentile(spreads, 90):.3f}); first-riser disparity error rms "
            f"{np.sqrt(np.mean(biases**2)):.3f} px over {len(biases)} frames"
        )


if __name__ == "__main__":
    main()
