"""Commands on single pairs and offline sets: ``demo``, ``reconstruct``, ``render``,
``disparity`` and ``eval-disparity``."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any

from ..errors import EXIT_OK, InputError
from .options import METHODS, figure_path, positive_int, seed_arg, size_arg
from .outputs import (
    all_or_none,
    check_output_dir,
    check_output_file,
    check_output_files,
    make_dir,
    progress,
    replace_from_temp,
    require_viz,
    write_json,
)
from .sinks import add_output_options, check_outputs, single_sinks


def add_parsers(sub: Any) -> None:
    d = sub.add_parser("demo", help="render the built-in staircase, run everything, compare with truth")
    d.add_argument("--out", type=Path, default=Path("demo_out"), help="folder for the scene, JSON and figure")
    d.add_argument("--no-plot", action="store_true", help="skip the figure")

    r = sub.add_parser("reconstruct", help="stereo pair -> terrain JSON")
    r.add_argument("left", type=Path)
    r.add_argument("right", type=Path)
    r.add_argument(
        "--calib", type=Path, required=True, help="OpenCV YAML, Middlebury calib.txt or stereodemo JSON"
    )
    r.add_argument(
        "--rig",
        type=Path,
        help="rig YAML (T_body_camera, body_rpy); without it up comes from the scene's planes and lines",
    )
    r.add_argument("--config", type=Path, help="pipeline config YAML")
    r.add_argument("--max-disparity", type=positive_int, help="disparity range (multiple of 16)")
    r.add_argument(
        "--method",
        choices=["orientation", "contour", "auto"],
        help="plane extraction (default: the config's, else orientation); auto runs both, explains its pick",
    )
    r.add_argument("--json", type=Path, help="write the terrain result here ('-' for stdout)")
    r.add_argument("--plot", type=figure_path, help="write a figure (PNG)")
    add_output_options(r)

    dp = sub.add_parser("disparity", help="stereo pair -> disparity map file")
    dp.add_argument("left", type=Path)
    dp.add_argument("right", type=Path)
    dp.add_argument("--calib", type=Path, required=True)
    dp.add_argument("--method", choices=sorted(METHODS), default="opencv")
    dp.add_argument(
        "--max-disparity", type=positive_int, help="multiple of 16 (default: from the calibration)"
    )
    dp.add_argument("--out", type=Path, required=True, help="DISP.pfm | DISP.npy | DISP.png")

    ev = sub.add_parser("eval-disparity", help="bad-1/2/4, error and density on Middlebury-layout folders")
    ev.add_argument("root", type=Path, help="a scene folder or a folder of scene folders")
    ev.add_argument(
        "--method",
        action="append",
        choices=sorted(METHODS),
        help="repeat to compare (default: sgm and the three OpenCV modes)",
    )

    g = sub.add_parser("render", help="write synthetic stereo scenes with ground truth")
    g.add_argument("--out", type=Path, required=True)
    g.add_argument("--count", type=positive_int, default=1)
    g.add_argument("--seed", type=seed_arg, default=0)
    g.add_argument("--size", type=size_arg, default=(640, 480), help="WIDTHxHEIGHT (default 640x480)")
    g.add_argument("--kind", choices=["stairs", "box", "none"], help="obstacle kind (default: random)")
    g.add_argument(
        "--profile",
        choices=["default", "realistic"],  # synthetic.PROFILES, not imported at parse time
        default="default",
        help="scenes like the renderer's own (default) or like webcam photos of real stairs (realistic)",
    )


def read_pair(left_path: Path, right_path: Path, calib: Any, calib_path: Path) -> tuple[Any, Any]:
    """Both images, checked against each other and the calibration with the files named."""
    from ..rectify import read_image

    left, right = read_image(left_path), read_image(right_path)
    (hl, wl), (hr, wr) = left.shape[:2], right.shape[:2]
    if (wl, hl) != (wr, hr):
        raise InputError(
            f"{left_path} is {wl}x{hl} but {right_path} is {wr}x{hr}; the two images differ in size"
        )
    if (wl, hl) != calib.image_size:
        raise InputError(
            f"{left_path} is {wl}x{hl} but the calibration is for {calib.width}x{calib.height} "
            f"({calib_path}); "
            "use the calibration of this camera mode or resize the images"
        )
    return left, right


def _fmt(v: float | None, unit: str = "m") -> str:
    return "   -  " if v is None else f"{v:6.3f}{unit}"


def _print_steps(title: str, steps: list[dict[str, Any]]) -> None:
    print(title)
    for i, s in enumerate(steps, 1):
        print(
            f"  step {i}: rise {_fmt(s['rise'])}  run {_fmt(s['run'])}  distance {_fmt(s['distance'])}"
            f"  width {_fmt(s['width'])}"
        )


def _plot(result, target: Path, truth: dict | None = None) -> None:
    try:
        from ..viz.figure import save_result_figure
    except ImportError as exc:
        raise InputError(
            f"--plot needs matplotlib ({exc}); install with pip install 'stereo-terrain[viz]'"
        ) from None
    replace_from_temp(target, lambda tmp: save_result_figure(result, tmp, truth=truth))


def cmd_demo(args: argparse.Namespace) -> int:
    from ..pipeline import Pipeline
    from ..synthetic import default_scene_spec, render_scene, write_scene

    out: Path = args.out
    check_output_dir(out, "--out")
    if not args.no_plot:
        require_viz("the demo's figure", "--no-plot")
    make_dir(out, "--out")
    check_output_files(out, ("result.json",) + (() if args.no_plot else ("demo.png",)), "--out")
    check_output_dir(out / "scene", "--out")
    spec = default_scene_spec()
    scene = render_scene(spec)
    pipeline = Pipeline(scene.calibration, scene.rig)
    pipeline.run(scene.left, scene.right)  # warm-up: first-call allocations
    result = pipeline.run(scene.left, scene.right)
    data = result.to_json_dict()
    truth = scene.truth
    print(
        f"stereo-terrain demo: {spec.image_size[0]}x{spec.image_size[1]} rendered staircase, "
        f"disparity range {pipeline.max_disparity_px} px ({pipeline.backend.name})"
    )
    print(
        f"obstacle: found {data['obstacle']!r}, truth {truth['obstacle']!r}; "
        f"stair yaw {data['yaw']:+.3f} rad (truth {truth['yaw']:+.3f})"
    )
    _print_steps("recovered steps:", data["steps"])
    _print_steps("true steps:", truth["steps"])
    sw = data["swing"]
    trig = "-" if sw["trigger_distance"] is None else f"{sw['trigger_distance']:.3f} m"
    print(
        f"swing plan: height {sw['height']:.3f} m, raise after travelling {trig}, "
        f"traversable: {sw['traversable']}"
    )
    print("timing (ms): " + ", ".join(f"{k} {v:.1f}" for k, v in data["timing_ms"].items()))
    # Every output or none (found in review: a figure that could not be written left the
    # JSON written before it): the figure and the JSON go to temporary names and are renamed
    # onto theirs when the block ends without an error; the scene, written in place, comes
    # last, so a failed figure or JSON leaves no scene either.
    with all_or_none():
        if not args.no_plot:
            _plot(result, out / "demo.png", truth=truth)
        write_json(data, out / "result.json")
        write_scene(scene, out / "scene")
    print(f"wrote {out / 'result.json'} and the scene in {out / 'scene'}")
    if not args.no_plot:
        print(f"wrote {out / 'demo.png'}")
    return EXIT_OK


def cmd_reconstruct(args: argparse.Namespace) -> int:
    from ..calibration import read_calibration
    from ..frames import load_rig
    from ..pipeline import Pipeline, PipelineConfig

    check_output_file(args.json, "--json")
    check_output_file(args.plot, "--plot")
    if args.plot is not None:
        require_viz("--plot")
    check_outputs(args)
    calib = read_calibration(args.calib)
    rig = load_rig(args.rig) if args.rig else None
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    if args.max_disparity is not None:
        config = dataclasses.replace(config, max_disparity_px=args.max_disparity)
    if args.method is not None:
        config = dataclasses.replace(config, method=args.method)
    left, right = read_pair(args.left, args.right, calib, args.calib)
    pipeline = Pipeline(calib, rig, config)
    result = pipeline.run(left, right)
    data = result.to_json_dict()
    # Every output or none (found in review: a recording that could not be written left
    # the figure written before it): the message files are written first and closed whole
    # when the block ends, then the figure and the JSON, written to temporary names inside,
    # are renamed onto theirs. The JSON (the result itself) comes last on stdout too.
    # Stamped with the left image's modification time, the nearest thing to a capture time.
    stamp_s = args.left.stat().st_mtime
    with all_or_none(), single_sinks(args, pipeline, result, left, right, stamp_s):
        if args.plot is not None:
            _plot(result, args.plot)
        if args.json is not None and str(args.json) != "-":
            write_json(data, args.json)
    if str(args.json) == "-":
        write_json(data, args.json)
    if str(args.json) != "-":
        print(f"obstacle: {data['obstacle']} ({data['note']}); gravity from {data['gravity_source']}")
        ps = data["plane_stage"]
        print(f"planes: {len(data['planes'])} by {ps['method_used']} ({ps['reason']})")
        _print_steps("steps:", data["steps"])
        sw = data["swing"]
        print(
            f"swing: height {sw['height']:.3f} m, trigger {sw['trigger_distance']}, "
            f"traversable {sw['traversable']}; total {data['timing_ms']['total']:.1f} ms"
        )
    return EXIT_OK


def cmd_render(args: argparse.Namespace) -> int:
    from ..synthetic import render_scenes

    out: Path = args.out
    # A second render into the same folder would overwrite scene_000... and keep the scenes
    # past its count: one data set of two renders. Refused, as record refuses a recording.
    earlier = sorted(p.name for p in out.glob("scene_[0-9][0-9][0-9]*")) if out.is_dir() else []
    if earlier:
        names = ", ".join(earlier[:3]) + (", ..." if len(earlier) > 3 else "")
        raise InputError(f"--out {out} already holds rendered scenes ({names}); use a new or empty folder")
    make_dir(out, "--out")
    kw: dict[str, Any] = {"image_size": args.size}
    if args.kind:
        kw["kind"] = args.kind
    paths = render_scenes(out, args.count, args.seed, profile=args.profile, **kw)
    for p in paths:
        print(p)
    return EXIT_OK


def _pair_disparity(method: str, calib, left, right, max_disparity: int | None):
    import time

    from ..pipeline import PipelineConfig
    from ..rectify import compute_rectification, rectify
    from ..stereo import check_max_disparity, default_max_disparity, make_backend

    rect = compute_rectification(calib)
    pair = rectify(left, right, rect)
    if max_disparity is not None:
        n = check_max_disparity(max_disparity, calib.width)
    else:
        n = default_max_disparity(rect, PipelineConfig().min_depth_m)
    backend_name, options = METHODS[method]
    backend = make_backend(backend_name, **options)
    t0 = time.perf_counter()
    dm = backend.compute(pair, n)
    return dm, (time.perf_counter() - t0) * 1000.0


def cmd_disparity(args: argparse.Namespace) -> int:
    from ..calibration import read_calibration
    from ..stereo.io import write_disparity

    if args.out.suffix.lower() not in (".pfm", ".npy", ".png"):
        raise InputError(f"--out: unknown disparity file type '{args.out.suffix}'; use .pfm, .npy or .png")
    check_output_file(args.out, "--out")
    calib = read_calibration(args.calib)
    left, right = read_pair(args.left, args.right, calib, args.calib)
    dm, ms = _pair_disparity(args.method, calib, left, right, args.max_disparity)
    replace_from_temp(args.out, lambda tmp: write_disparity(tmp, dm.disparity))
    print(f"{args.method}: {dm.max_disparity_px} disparities, density {dm.density:.1%}, {ms:.0f} ms")
    print(f"wrote {args.out}")
    return EXIT_OK


def cmd_eval_disparity(args: argparse.Namespace) -> int:
    import numpy as np

    from ..evaluation import disparity_errors, middlebury_scene_dirs, read_middlebury_scene

    methods = args.method or ["sgm", "opencv", "opencv-sgbm", "opencv-hh"]
    dirs = middlebury_scene_dirs(args.root)
    rows = []
    total = len(dirs) * len(methods)
    for i, d in enumerate(dirs):
        scene = read_middlebury_scene(d)
        for j, m in enumerate(methods):
            progress(i * len(methods) + j + 1, total, f"{scene.name} {m}")
            dm, ms = _pair_disparity(m, scene.calibration, scene.left, scene.right, None)
            e_all = disparity_errors(dm.disparity, scene.truth)
            e_noc = (
                e_all
                if scene.nonoccluded is None
                else disparity_errors(dm.disparity, scene.truth, scene.nonoccluded)
            )
            rows.append((scene.name, m, e_noc, e_all, ms))
    print(
        "| scene | method | bad-1 nonocc | bad-2 nonocc | bad-4 nonocc | bad-2 all | avg err px | density "
        "| ms |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, m, en, ea, ms in rows:
        print(
            f"| {name} | {m} | {en['bad1']:.1%} | {en['bad2']:.1%} | {en['bad4']:.1%} | {ea['bad2']:.1%} | "
            f"{en['avgerr']:.2f} | {en['density']:.0%} | {ms:.0f} |"
        )
    for m in methods:
        sel = [r for r in rows if r[1] == m]

        def mean(get, sel=sel) -> float:
            return float(np.mean([get(r) for r in sel]))

        print(
            f"| mean | {m} | {mean(lambda r: r[2]['bad1']):.1%} | {mean(lambda r: r[2]['bad2']):.1%} | "
            f"{mean(lambda r: r[2]['bad4']):.1%} | {mean(lambda r: r[3]['bad2']):.1%} | "
            f"{mean(lambda r: r[2]['avgerr']):.2f} | {mean(lambda r: r[2]['density']):.0%} | "
            f"{mean(lambda r: r[4]):.0f} |"
        )
    return EXIT_OK


COMMANDS = {
    "demo": cmd_demo,
    "reconstruct": cmd_reconstruct,
    "render": cmd_render,
    "disparity": cmd_disparity,
    "eval-disparity": cmd_eval_disparity,
}
