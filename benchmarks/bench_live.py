"""The live loop on replay at 640x480: the approach over LCM, throughput, latency, memory.

Sections (all by default except ``--memory``'s length, which is given in seconds):

* ``approach``: a rendered approach (>= 100 frames at 640x480) is written by
  ``simulate --record``, replayed by the ``stereo-terrain replay`` command (a separate
  process) publishing on LCM over loopback, received here by a subscriber and logged by
  ``lcm-logger`` at the same time; checks every processed frame gave a message, the
  trigger point against ``d - d_buffer`` and the feet against the blind swing.
* ``throughput``: the same recording replayed in real time at 30 fps (paced: the newest
  pair, stale ones skipped) and as fast as possible: sustained fps and capture-to-publish
  latency (median, p99).
* ``memory``: a looped real-time replay for ``--memory`` seconds, resident memory sampled
  every ``--sample`` seconds (it should stay flat).
* ``real``: the three real OAK-D Lite pairs of ``../shared/data/oakd_lite`` looped as a
  30 fps recording through the same loop.

Usage::

    python benchmarks/bench_live.py --work /tmp/bench_live [--memory 600] [--sections ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import select
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from stereo_terrain.calibration import read_calibration
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.runtime.capture import Capture, FolderPairs, Paced, StereoFrame, write_pairs
from stereo_terrain.runtime.loop import LiveLoop, LoopConfig
from stereo_terrain.runtime.messages import terrain_t
from stereo_terrain.runtime.simulate import evaluate_approach, load_approach

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def ensure_approach(work: Path) -> Path:
    seq = work / "approach"
    if not (seq / "pairs.csv").is_file():
        print(f"rendering the approach into {seq} (640x480, takes a minute or two) ...", flush=True)
        cmd = [str(BIN / "stereo-terrain"), "simulate", "--out", str(work / "sim"), "--record", str(seq)]
        subprocess.run(cmd, check=True)
    return seq


def section_approach(work: Path) -> None:
    """Both replays: every pair (``--as-fast``) and real time at the recording's 30 fps."""
    seq = ensure_approach(work)
    cfg, swing = load_approach(seq)
    rows = [_approach_run(work, seq, cfg, swing, fast) for fast in (True, False)]
    print("\n## approach replayed over LCM (640x480, rendered, loopback multicast)")
    print("| item | every pair (--as-fast) | real time, 30 fps |\n| --- | --- | --- |")
    for key in rows[0]:
        print(f"| {key} | {rows[0][key]} | {rows[1][key]} |")


def _approach_run(work: Path, seq: Path, cfg, swing, fast: bool) -> dict[str, str]:
    import lcm

    url = "udpm://239.255.76.67:7701?ttl=0"
    lc = lcm.LCM(url)
    got: list[terrain_t] = []
    lc.subscribe("STEREO_TERRAIN", lambda ch, data: got.append(terrain_t.decode(data)))
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            if select.select([lc.fileno()], [], [], 0.02)[0]:
                lc.handle()

    th = threading.Thread(target=spin, daemon=True)
    th.start()
    log_path = work / "approach.lcmlog"
    log_path.unlink(missing_ok=True)
    # A process group: the wheel's lcm-logger is a wrapper whose child is the real logger.
    logger = subprocess.Popen(
        [str(BIN / "lcm-logger"), "-q", "-l", url, str(log_path)], start_new_session=True
    )
    time.sleep(1.0)
    summary_path = work / "approach_replay.json"
    cmd = [str(BIN / "stereo-terrain"), "replay", str(seq), "--quiet", "--lcm-url", url]
    subprocess.run(cmd + ["--summary-json", str(summary_path)] + (["--as-fast"] if fast else []), check=True)
    time.sleep(1.0)
    os.killpg(logger.pid, signal.SIGINT)
    logger.wait(10)
    stop.set()
    th.join(1)
    summary = json.loads(summary_path.read_text())
    logged = [e for e in lcm.EventLog(str(log_path), "r") if e.channel == "STEREO_TERRAIN"]
    n = cfg.frame_count
    x_of_frame = {i: cfg.speed_mps * i / cfg.fps for i in range(n)}
    res = evaluate_approach(cfg, swing, got, x_of_frame)
    if fast:  # the figure of docs/figures/live_approach.png
        from stereo_terrain.viz.approach import save_approach_figure

        save_approach_figure(res, work / "live_approach.png")
    s = res.summary()
    idx = [m.frame_index for m in got]
    in_order = idx == sorted(set(idx)) and len(idx) == summary["processed"]

    def legs(key: str) -> str:
        return ", ".join(f"{k} {100 * v:+.1f}" for k, v in sorted(s[key].items()))

    return {
        "frames in the recording": str(n),
        "pairs processed / superseded": f"{summary['processed']} / {summary['skipped']}",
        "processed fps; latency median / p99 ms": f"{summary['fps']:.1f}; "
        f"{summary['latency_median_ms']:.0f} / {summary['latency_p99_ms']:.0f}",
        "messages published / received / logged by lcm-logger": f"{summary['published']} / {len(got)} / "
        f"{len(logged)}",
        "every processed pair has its message, in order": str(in_order),
        "true first riser; d_buffer": f"{cfg.riser_x_m:.3f} m; {swing.buffer_m:.2f} m",
        "trigger at (body x)": f"{s['trigger_at_m']:.3f} m",
        "trigger - (d - d_buffer)": f"{100 * s['trigger_error_m']:+.1f} cm",
        "raised swing height": f"{s['swing_height_m']:.3f} m",
        "first riser edge clearance, perceived (cm)": legs("edge_clearance_sensed_m"),
        "first riser edge clearance, blind 0.15 m (cm)": legs("edge_clearance_blind_m"),
    }


def _loop(
    folder: Path,
    *,
    realtime: bool,
    duration: float,
    loop: bool,
    calib=None,
    rig=None,
    denoised_every: int | None = None,
) -> LiveLoop:
    calib = read_calibration(calib or folder / "calib.yaml")
    rig_path = rig or folder / "rig.yaml"
    pipeline = Pipeline(calib, load_rig(rig_path) if rig_path.is_file() else None)
    src = Paced(FolderPairs(folder, loop=loop), realtime=realtime)
    config = LoopConfig(max_duration_s=duration)
    if denoised_every is not None:
        config = dataclasses.replace(config, denoised_every=denoised_every)
    lp = LiveLoop(Capture(src), pipeline, lambda m: m.encode(), config=config)
    lp.warm_up()
    return lp


def section_throughput(work: Path, duration: float) -> None:
    seq = ensure_approach(work)
    print(f"\n## throughput and latency at 640x480 ({duration:.0f} s each)")
    print("| replay | processed fps | superseded | latency median ms | latency p99 ms | pipeline median ms |")
    print("| --- | --- | --- | --- | --- | --- |")
    for realtime, name in ((True, "real time 30 fps (newest pair)"), (False, "as fast as possible")):
        lp = _loop(seq, realtime=realtime, duration=duration, loop=True)
        stage: list[float] = []
        lp.on_result = lambda f, r, stage=stage: stage.append(r.timing_ms["total"])
        s = lp.run()
        print(
            f"| {name} | {s.fps:.1f} | {s.skipped} | {s.latency_ms(50):.1f} | {s.latency_ms(99):.1f} | "
            f"{np.median(stage):.1f} |"
        )


def section_memory(work: Path, duration: float, sample: float) -> None:
    seq = ensure_approach(work)
    lp = _loop(seq, realtime=True, duration=duration, loop=True)
    samples: list[tuple[float, float, int]] = []
    stop = threading.Event()
    t0 = time.monotonic()

    def watch() -> None:
        while not stop.is_set():
            samples.append((time.monotonic() - t0, rss_mb(), lp.summary.processed))
            stop.wait(sample)

    th = threading.Thread(target=watch, daemon=True)
    th.start()
    s = lp.run()
    stop.set()
    th.join(1)
    samples.append((time.monotonic() - t0, rss_mb(), s.processed))
    t = np.array([x[0] for x in samples])
    m = np.array([x[1] for x in samples])
    late = t >= 60.0
    slope = float(np.polyfit(t[late], m[late], 1)[0]) * 60.0 if late.sum() >= 3 else float("nan")
    print(f"\n## resident memory over a {duration / 60:.0f}-minute real-time replay (looped)")
    print(f"pairs processed {s.processed} ({s.fps:.1f} fps), latency median {s.latency_ms(50):.1f} ms, "
          f"p99 {s.latency_ms(99):.1f} ms, superseded {s.skipped}")  # fmt: skip
    print("| time s | RSS MB | pairs |\n| --- | --- | --- |")
    step = max(1, len(samples) // 12)
    for ts, mb, n in samples[::step] + ([samples[-1]] if (len(samples) - 1) % step else []):
        print(f"| {ts:.0f} | {mb:.1f} | {n} |")
    print(f"RSS after 1 min {m[late][0] if late.any() else m[0]:.1f} MB, max {m.max():.1f} MB, "
          f"last {m[-1]:.1f} MB; slope after the first minute {slope:+.2f} MB/min")  # fmt: skip


def section_real(work: Path, duration: float) -> None:
    data = ROOT.parent / "shared" / "data" / "oakd_lite"
    if not data.is_dir():
        print(f"\n(real data {data} absent: skipped)")
        return
    import cv2

    folder = work / "oakd_loop"
    scenes = ["corridor", "desk", "living_room"]
    if not (folder / "pairs.csv").is_file():
        frames = []
        for i, name in enumerate(scenes):
            left = cv2.imread(str(data / name / "left.png"), cv2.IMREAD_GRAYSCALE)
            right = cv2.imread(str(data / name / "right.png"), cv2.IMREAD_GRAYSCALE)
            frames.append(StereoFrame(left, right, i / 30, i / 30, i))
        write_pairs(folder, frames)
    calib = data / "corridor" / "stereodemo_calibration.json"
    # The denoised opinions on every pair that runs the second opinions (1) and on every
    # other one (2, the default), side by side.
    for every in (1, 2):
        lp = _loop(
            folder, realtime=True, duration=duration, loop=True, calib=calib, rig=folder / "none.yaml",
            denoised_every=every,
        )  # fmt: skip
        seen: dict[str, list[str]] = {n: [] for n in scenes}

        def note(f: StereoFrame, r, seen=seen) -> None:
            first = f":{r.terrain.steps[0].distance_m:.2f}" if r.terrain.steps else ""
            seen[scenes[f.index % 3]].append(f"{r.terrain.obstacle}:{r.gravity_source}{first}")

        lp.on_result = note
        s = lp.run()
        print(
            f"\n## real OAK-D Lite pairs looped at 30 fps ({duration:.0f} s, no rig: gravity from the "
            f"floor; denoised_every {every})"
        )
        print(f"processed {s.processed} ({s.fps:.1f} fps), latency median {s.latency_ms(50):.1f} ms, "
              f"p99 {s.latency_ms(99):.1f} ms, superseded {s.skipped}, failed {s.failed}")  # fmt: skip
        print("| scene | results (obstacle:gravity source[:first riser m]) |\n| --- | --- |")
        for name, got in seen.items():
            values, counts = np.unique(got, return_counts=True)
            print(f"| {name} | " + ", ".join(f"{v} x{c}" for v, c in zip(values, counts, strict=True)) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/bench_live"))
    ap.add_argument("--sections", nargs="+", default=["approach", "throughput", "real"],
                    choices=["approach", "throughput", "memory", "real"])  # fmt: skip
    ap.add_argument("--duration", type=float, default=30.0, help="seconds per throughput/real run")
    ap.add_argument("--memory", type=float, default=600.0, help="seconds of the memory run")
    ap.add_argument("--sample", type=float, default=10.0, help="seconds between memory samples")
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    now = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    print(f"# bench_live ({now} UTC, pid {os.getpid()}, {os.cpu_count()} cpus, shared machine)")
    for name in args.sections:
        if name == "approach":
            section_approach(args.work)
        elif name == "throughput":
            section_throughput(args.work, args.duration)
        elif name == "memory":
            section_memory(args.work, args.memory, args.sample)
        elif name == "real":
            section_real(args.work, args.duration)


if __name__ == "__main__":
    main()
