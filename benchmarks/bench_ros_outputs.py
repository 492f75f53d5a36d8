"""Cost per pair of the ROS 2 / Rerun outputs (issue 15) beside the pipeline itself.

Renders the default staircase, runs the pipeline on it, and times, interleaved in one
process so that the ratios are fair: the pipeline (``Pipeline.run``), the MCAP sink
(``McapSink.write_result``: building, serialising and zstd-compressing the cloud, markers,
tf, rectified image, camera info, disparity and terrain messages) and the Rerun view
(``RerunView.log_result`` into a saved recording). Prints medians and the bytes per pair.

    .venv/bin/python benchmarks/bench_ros_outputs.py [--size 640x480] [--pairs 20]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from stereo_terrain.pipeline import Pipeline
from stereo_terrain.ros.mcap_out import McapSink
from stereo_terrain.synthetic import default_scene_spec, render_scene
from stereo_terrain.viz.rerun_view import RerunView


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--pairs", type=int, default=20)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    import dataclasses

    scene = render_scene(dataclasses.replace(default_scene_spec(), image_size=(w, h)))
    pipeline = Pipeline(scene.calibration, scene.rig)
    result = pipeline.run(scene.left, scene.right)  # warm-up
    times: dict[str, list[float]] = {"pipeline": [], "mcap": [], "rerun": []}
    with tempfile.TemporaryDirectory() as tmp:
        mcap_path, rrd_path = Path(tmp) / "b.mcap", Path(tmp) / "b.rrd"
        sink = McapSink(mcap_path)
        view = RerunView(rrd_path)
        sink.write_result(result, 0)
        view.log_result(result, 0)
        for k in range(1, args.pairs + 1):
            t0 = time.perf_counter()
            result = pipeline.run(scene.left, scene.right)
            t1 = time.perf_counter()
            sink.write_result(result, k * 33_000_000)
            t2 = time.perf_counter()
            view.log_result(result, k * 33_000_000, k)
            t3 = time.perf_counter()
            times["pipeline"].append(t1 - t0)
            times["mcap"].append(t2 - t1)
            times["rerun"].append(t3 - t2)
        sink.close()
        view.close()
        sizes = {"mcap": mcap_path.stat().st_size, "rerun": rrd_path.stat().st_size}
    base = float(np.median(times["pipeline"]))
    print(f"| {w}x{h} | step | median ms | p90 ms | / pipeline | bytes per pair |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for name, values in times.items():
        med, p90 = float(np.median(values)), float(np.percentile(values, 90))
        size = "-" if name == "pipeline" else f"{sizes[name] / (args.pairs + 1) / 1024:.0f} KiB"
        print(f"| | {name} | {1e3 * med:.1f} | {1e3 * p90:.1f} | {med / base:.2f} | {size} |")


if __name__ == "__main__":
    main()
