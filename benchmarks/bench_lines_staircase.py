"""Issue 11: what the staircases the pipeline asks for last cost a frame: that of the first
riser the image's lines show (``--step lines``, the default; ``TerrainConfig.lines_first_riser``,
:func:`stereo_terrain.terrain.staircase_from_lines`, where every pass found nothing and the
floor is known), or that of the risers' ends (``--step ends``;
``TerrainConfig.ends_staircase``, :func:`stereo_terrain.terrain.staircase_from_ends`, where
the result is a staircase or a step and the floor is known), or, without a rig, that of
the staircase found again with the floor a rise lower (``--step floor``;
``PipelineConfig.floor_a_step_below``, where the result is a staircase standing on its
"floor"; the frames it ran in are those where it looked for the first riser's samples
under that floor), or that of the first riser standing where the floor the matcher holds
ends (``--step edge``; ``TerrainConfig.floor_edge_foot``, where nothing else, the risers'
ends included, found anything and the floor is known). Results are recorded in
docs/benchmarks.md ("Forty-first session", "Forty-third session", "Forty-fourth session",
"Forty-eighth session"); their accuracy is ``bench_ab.py``'s (the same draws with and
without them).

    .venv/bin/python benchmarks/bench_lines_staircase.py [--seed 23] [--n 60] [--no-rig] \
        [--step ends|floor|edge]

Runs the pipeline (default settings) on the realistic profile's draws and prints, over
the frames where the step ran: how many, how many it found a staircase in, the step's time
(``timing_ms["lines_staircase"]``, ``timing_ms["ends_staircase"]``,
``timing_ms["floor_below"]`` or ``timing_ms["floor_edge_staircase"]``, ms, median / p90 /
max) and the whole frame's (median / p90), side by side in the same run.
"""

from __future__ import annotations

import argparse

import numpy as np

from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene

#: Each step: its key in ``timing_ms`` and what the note of a staircase it found says.
STEPS = {
    "lines": ("lines_staircase", "from the image's lines"),
    "ends": ("ends_staircase", "from the risers' ends both images place"),
    "floor": ("floor_below", "(floor_a_step_below)"),
    "edge": ("floor_edge_staircase", "from the floor's edge"),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=23)
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--no-rig", action="store_true", help="gravity and the floor from the scene")
    ap.add_argument("--step", choices=sorted(STEPS), default="lines", help="which staircase's cost")
    args = ap.parse_args()
    key, marker = STEPS[args.step]
    rng = np.random.default_rng(args.seed)
    step_ms, frame_ms, found = [], [], 0
    for _ in range(args.n):
        scene = render_scene(random_scene_spec(rng, profile="realistic"))
        rig = None if args.no_rig else scene.rig
        result = Pipeline(scene.calibration, rig, PipelineConfig(), warm_up=False).run(
            scene.left, scene.right
        )
        took = result.timing_ms.get(key)
        if took is None:
            continue
        step_ms.append(took)
        frame_ms.append(result.timing_ms["total"])
        found += marker in result.terrain.note
    print(
        "| set | frames it ran in | staircases found | step ms median / p90 / max | frame ms median / p90 |"
    )
    print("| --- | --- | --- | --- | --- |")
    name = f"realistic {args.seed} ({args.n}), {'no rig' if args.no_rig else 'rig'}, {args.step}"
    if not step_ms:
        print(f"| {name} | 0 | 0 | | |")
        return
    s, f = np.asarray(step_ms), np.asarray(frame_ms)
    print(
        f"| {name} | {len(s)} | {found} | {np.median(s):.0f} / {np.percentile(s, 90):.0f} / {s.max():.0f} "
        f"| {np.median(f):.0f} / {np.percentile(f, 90):.0f} |"
    )


if __name__ == "__main__":
    main()
