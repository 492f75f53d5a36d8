"""The three plane methods side by side on rendered scenes (issue 4).

Every scene goes through the whole pipeline once per method (``orientation``, ``contour``,
``auto``) on the same rendered pair. Three groups of scenes from the renderer's random
draw: textured, weakly textured (painted risers and sides, sometimes treads) and textured
with a strong left/right lighting difference (right camera gain 0.7 or 1.3 and an offset
of +-25 grey levels). Prints a markdown table; results are recorded in docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_planes.py [--per-group 15] [--seed 11]
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np

from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import PLANE_METHODS, Pipeline, PipelineConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene


def group_specs(rng: np.random.Generator, n: int) -> dict[str, list]:
    def kind(i: int) -> str:
        return ["stairs", "stairs", "stairs", "box", "stairs", "none"][i % 6]

    lighting = []
    for i in range(n):
        gain = 0.7 if i % 2 else 1.3
        offset = 25.0 if i % 3 else -25.0
        lighting.append(
            random_scene_spec(
                rng, kind=kind(i), weak_texture=False, right_gain=gain, right_offset_grey=offset
            )
        )
    return {
        "textured": [random_scene_spec(rng, kind=kind(i), weak_texture=False) for i in range(n)],
        "weakly textured": [random_scene_spec(rng, kind=kind(i), weak_texture=True) for i in range(n)],
        "left/right lighting": lighting,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-group", type=int, default=15)
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    groups = group_specs(rng, args.per_group)
    scores: dict[tuple[str, str], list] = {}
    plane_ms: dict[str, list[float]] = {m: [] for m in PLANE_METHODS}
    picks: dict[str, int] = {}
    for name, specs in groups.items():
        for spec in specs:
            scene = render_scene(spec)
            for method in PLANE_METHODS:
                pipe = Pipeline(scene.calibration, scene.rig, PipelineConfig(method=method))
                result = pipe.run(scene.left, scene.right)
                data = result.to_json_dict()
                scores.setdefault((method, name), []).append(score_result(data, scene.truth))
                plane_ms[method].append(result.timing_ms["planes"])
                if method == "auto":
                    used = data["plane_stage"]["method_used"]
                    picks[used] = picks.get(used, 0) + 1
    n_all = sum(len(s) for s in groups.values())
    print(f"{n_all} rendered 640x480 scenes (seed {args.seed}), {args.per_group} per group; errors absolute")
    print()
    print(
        "| method | scenes | n | detected | false pos. | step count right | rise median cm | rise p90 cm | "
        "run median cm | 1st riser distance median cm |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    cm = 100.0
    for method in PLANE_METHODS:
        rows = [(name, scores[(method, name)]) for name in groups]
        rows.append(("all", [s for name in groups for s in scores[(method, name)]]))
        for name, sc in rows:
            s = summarize(sc)
            print(
                f"| {method} | {name} | {len(sc)} | {s['detection_rate']:.0%} | "
                f"{s['false_positive_rate']:.0%} | {s['count_rate']:.0%} | {s['rise_median_m'] * cm:.1f} | "
                f"{s['rise_p90_m'] * cm:.1f} | {s['run_median_m'] * cm:.1f} | "
                f"{s['first_distance_median_m'] * cm:.1f} |"
            )
    print()
    print(
        "plane stage, median ms (shared machine, one run): "
        + ", ".join(f"{m} {statistics.median(v):.1f}" for m, v in plane_ms.items())
    )
    print("auto used: " + ", ".join(f"{k} {v}" for k, v in sorted(picks.items())))


if __name__ == "__main__":
    main()
