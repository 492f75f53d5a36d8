"""Command line: ``stereo-terrain demo | reconstruct | render``.

Thin: parses arguments, calls the pipeline, maps errors to exit codes (0 success, 2 bad
input or usage with one line on stderr, 1 internal error).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path
from typing import Any, NoReturn

from .errors import InputError, StereoTerrainError

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE = 0, 1, 2
log = logging.getLogger("stereo_terrain")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit code 2."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: error: {message} (see '{self.prog} --help')\n")
        raise SystemExit(EXIT_USAGE)


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WIDTHxHEIGHT like 640x480, got '{text}'") from None
    if w < 32 or h < 32:
        raise argparse.ArgumentTypeError(f"size must be at least 32x32, got {text}")
    return w, h


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="stereo-terrain",
        description="Stairs and boxes ahead of a legged robot from a calibrated stereo pair.",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="log what each stage does")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

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
        "--rig", type=Path, help="rig YAML (T_body_camera, body_rpy); without it the floor is taken as level"
    )
    r.add_argument("--config", type=Path, help="pipeline config YAML")
    r.add_argument("--max-disparity", type=_positive_int, help="disparity range (multiple of 16)")
    r.add_argument("--json", type=Path, help="write the terrain result here ('-' for stdout)")
    r.add_argument("--plot", type=Path, help="write a figure (PNG)")

    g = sub.add_parser("render", help="write synthetic stereo scenes with ground truth")
    g.add_argument("--out", type=Path, required=True)
    g.add_argument("--count", type=_positive_int, default=1)
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--size", type=_size, default=(640, 480), help="WIDTHxHEIGHT (default 640x480)")
    g.add_argument("--kind", choices=["stairs", "box", "none"], help="obstacle kind (default: random)")
    return p


def _fmt(v: float | None, unit: str = "m") -> str:
    return "   -  " if v is None else f"{v:6.3f}{unit}"


def _print_steps(title: str, steps: list[dict[str, Any]]) -> None:
    print(title)
    for i, s in enumerate(steps, 1):
        print(
            f"  step {i}: rise {_fmt(s['rise'])}  run {_fmt(s['run'])}  distance {_fmt(s['distance'])}"
            f"  width {_fmt(s['width'])}"
        )


def _write_json(data: dict[str, Any], target: Path) -> None:
    text = json.dumps(data, indent=2)
    if str(target) == "-":
        print(text)
        return
    try:
        target.write_text(text + "\n")
    except OSError as exc:
        raise InputError(f"cannot write {target}: {exc.strerror}") from None


def _plot(result, target: Path, truth: dict | None = None) -> None:
    try:
        from .viz.figure import save_result_figure
    except ImportError as exc:
        raise InputError(
            f"--plot needs matplotlib ({exc}); install with pip install 'stereo-terrain[viz]'"
        ) from None
    try:
        save_result_figure(result, target, truth=truth)
    except OSError as exc:
        raise InputError(f"cannot write {target}: {exc.strerror}") from None


def cmd_demo(args: argparse.Namespace) -> int:
    from .pipeline import Pipeline
    from .synthetic import default_scene_spec, render_scene, write_scene

    out: Path = args.out
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {out}: {exc.strerror}") from None
    spec = default_scene_spec()
    scene = render_scene(spec)
    write_scene(scene, out / "scene")
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
    _write_json(data, out / "result.json")
    print(f"wrote {out / 'result.json'} and the scene in {out / 'scene'}")
    if not args.no_plot:
        _plot(result, out / "demo.png", truth=truth)
        print(f"wrote {out / 'demo.png'}")
    return EXIT_OK


def cmd_reconstruct(args: argparse.Namespace) -> int:
    from .calibration import read_calibration
    from .frames import load_rig
    from .pipeline import Pipeline, PipelineConfig
    from .rectify import read_image

    calib = read_calibration(args.calib)
    rig = load_rig(args.rig) if args.rig else None
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    if args.max_disparity is not None:
        import dataclasses

        config = dataclasses.replace(config, max_disparity_px=args.max_disparity)
    left = read_image(args.left)
    right = read_image(args.right)
    pipeline = Pipeline(calib, rig, config)
    result = pipeline.run(left, right)
    data = result.to_json_dict()
    if args.json is not None:
        _write_json(data, args.json)
    if str(args.json) != "-":
        print(f"obstacle: {data['obstacle']} ({data['note']}); gravity from {data['gravity_source']}")
        _print_steps("steps:", data["steps"])
        sw = data["swing"]
        print(
            f"swing: height {sw['height']:.3f} m, trigger {sw['trigger_distance']}, "
            f"traversable {sw['traversable']}; total {data['timing_ms']['total']:.1f} ms"
        )
    if args.plot is not None:
        _plot(result, args.plot)
    return EXIT_OK


def cmd_render(args: argparse.Namespace) -> int:
    from .synthetic import render_scenes

    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {args.out}: {exc.strerror}") from None
    kw: dict[str, Any] = {"image_size": args.size}
    if args.kind:
        kw["kind"] = args.kind
    paths = render_scenes(args.out, args.count, args.seed, **kw)
    for p in paths:
        print(p)
    return EXIT_OK


COMMANDS = {"demo": cmd_demo, "reconstruct": cmd_reconstruct, "render": cmd_render}


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s"
    )
    try:
        return COMMANDS[args.command](args)
    except StereoTerrainError as exc:
        sys.stderr.write(f"stereo-terrain {args.command}: error: {exc}\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write("stereo-terrain: interrupted\n")
        return 130
    except Exception as exc:  # an internal error: say so, keep the traceback for the log
        log.debug("internal error", exc_info=True)
        sys.stderr.write(
            f"stereo-terrain {args.command}: internal error: {type(exc).__name__}: {exc} "
            "(please report it; run with -v for details)\n"
        )
        if args.verbose:
            import traceback

            traceback.print_exc()
        return EXIT_INTERNAL


if __name__ == "__main__":
    raise SystemExit(main())
