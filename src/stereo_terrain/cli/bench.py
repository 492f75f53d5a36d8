"""``bench``: timing and accuracy of the pipeline over a folder of scenes."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any

from ..errors import EXIT_OK, InputError
from .options import positive_int
from .outputs import check_output_file, progress, write_json


def add_parsers(sub: Any) -> None:
    b = sub.add_parser(
        "bench",
        help="time the pipeline per stage against OpenCV SGBM 3-way and score it over scene folders",
    )
    b.add_argument("scenes", type=Path, help="a folder of scene folders in the render layout (or one scene)")
    b.add_argument("--backend", choices=["opencv", "sgm"], help="disparity backend (default: the config's)")
    b.add_argument("--config", type=Path, help="pipeline config YAML")
    b.add_argument(
        "--method",
        choices=["orientation", "contour", "auto"],
        help="plane extraction (default: the config's)",
    )
    b.add_argument(
        "--no-rig",
        action="store_true",
        help="leave the scenes' rig.yaml unread: gravity and the floor from the scene, as without a rig file",
    )
    b.add_argument("--repeat", type=positive_int, default=5, help="warm calls per scene (default 5)")
    b.add_argument("--json", type=Path, help="write the summary here ('-' for stdout)")
    b.add_argument(
        "--ray",
        nargs="?",
        const="local",
        metavar="ADDRESS",
        help="accuracy only, spread over a Ray cluster at ADDRESS (none: a local Ray); no timing",
    )


def cmd_bench(args: argparse.Namespace) -> int:
    from ..bench import bench_summary, bench_table, check_scene_truths, iter_bench, scene_dirs, score_with_ray
    from ..pipeline import PipelineConfig

    check_output_file(args.json, "--json")
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    if args.backend is not None:
        config = dataclasses.replace(config, backend=args.backend)
    if args.method is not None:
        config = dataclasses.replace(config, method=args.method)
    dirs = scene_dirs(args.scenes)
    check_scene_truths(dirs)
    if args.ray is not None:
        from .outputs import require

        require("ray", "ray", "bench --ray")
        address = None if args.ray == "local" else args.ray
        outcomes = score_with_ray(
            dirs,
            dataclasses.asdict(config),
            address,
            on_done=lambda i, name: progress(i, len(dirs), name),
            use_rig=not args.no_rig,
        )
    else:
        outcomes = []
        for i, outcome in enumerate(iter_bench(dirs, config, args.repeat, use_rig=not args.no_rig)):
            outcomes.append(outcome)
            progress(i + 1, len(dirs), outcome.name)
    summary = bench_summary(outcomes, rigs_read=not args.no_rig)
    if args.json is not None:
        write_json(summary, args.json)
    if str(args.json) != "-":
        if args.no_rig:
            print("without the scenes' rig.yaml: gravity and the floor from the scene")
        if args.ray is not None:
            print(f"accuracy on Ray ({args.ray}); timing is measured only without --ray")
        print("\n".join(bench_table(outcomes, summary)))
    if not outcomes:
        raise InputError("no scene was benchmarked")
    return EXIT_OK


COMMANDS = {"bench": cmd_bench}
