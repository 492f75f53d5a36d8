"""Command line: ``stereo-terrain demo | reconstruct | render | disparity | eval-disparity |
calibrate | check-calib | record | run | replay | simulate``.

Thin: parses arguments, calls the pipeline, maps errors to exit codes through
:func:`stereo_terrain.errors.exit_code` (0 success, 2 bad input or usage with one line on
stderr, 1 internal error).

Before any work every command checks what it will write (a file's folder exists, a folder
is not a file, a recording folder is new) and the optional packages it needs (matplotlib
for figures, lcm for publishing), so that a mistake costs nothing and leaves nothing
behind: files are written to a temporary name and renamed, folders the command created
are removed again when it fails. Progress and status lines are drawn only on a terminal.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import logging
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, NoReturn

from .errors import EXIT_INTERNAL, EXIT_OK, EXIT_USAGE, InputError, exit_code

# Disparity methods by name: backend and its options.
_METHODS: dict[str, tuple[str, dict[str, Any]]] = {
    "opencv": ("opencv", {}),
    "opencv-sgbm": ("opencv", {"mode": "sgbm"}),
    "opencv-hh": ("opencv", {"mode": "hh"}),
    "sgm": ("sgm", {}),
    "sgm-4": ("sgm", {"paths": 4}),
}
log = logging.getLogger("stereo_terrain")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit code 2."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: error: {message} (see '{self.prog} --help')\n")
        raise SystemExit(EXIT_USAGE)


MAX_SIZE_PX = 4096


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WIDTHxHEIGHT like 640x480, got '{text}'") from None
    if w < 32 or h < 32:
        raise argparse.ArgumentTypeError(f"size must be at least 32x32, got {text}")
    if w > MAX_SIZE_PX or h > MAX_SIZE_PX:
        raise argparse.ArgumentTypeError(f"size must be at most {MAX_SIZE_PX}x{MAX_SIZE_PX}, got {text}")
    return w, h


#: Integers on the command line above this are typos (and overflow OpenCV's C int).
MAX_INT_OPTION = 1_000_000


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    if v > MAX_INT_OPTION:
        raise argparse.ArgumentTypeError(f"expected a positive integer up to {MAX_INT_OPTION}, got {v}")
    return v


def _seed(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got '{text}'") from None
    if not 0 <= v < 2**63:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, 2**63), got {v}")
    return v


_FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def _figure_path(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() not in _FIGURE_SUFFIXES:
        raise argparse.ArgumentTypeError(
            f"a figure must end in one of {', '.join(_FIGURE_SUFFIXES)}, got '{text}'"
        )
    return path


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
    r.add_argument(
        "--method",
        choices=["orientation", "contour", "auto"],
        help="plane extraction (default: the config's, else orientation); auto runs both, explains its pick",
    )
    r.add_argument("--json", type=Path, help="write the terrain result here ('-' for stdout)")
    r.add_argument("--plot", type=_figure_path, help="write a figure (PNG)")

    dp = sub.add_parser("disparity", help="stereo pair -> disparity map file")
    dp.add_argument("left", type=Path)
    dp.add_argument("right", type=Path)
    dp.add_argument("--calib", type=Path, required=True)
    dp.add_argument("--method", choices=sorted(_METHODS), default="opencv")
    dp.add_argument(
        "--max-disparity", type=_positive_int, help="multiple of 16 (default: from the calibration)"
    )
    dp.add_argument("--out", type=Path, required=True, help="DISP.pfm | DISP.npy | DISP.png")

    ev = sub.add_parser("eval-disparity", help="bad-1/2/4, error and density on Middlebury-layout folders")
    ev.add_argument("root", type=Path, help="a scene folder or a folder of scene folders")
    ev.add_argument(
        "--method",
        action="append",
        choices=sorted(_METHODS),
        help="repeat to compare (default: sgm and the three OpenCV modes)",
    )

    c = sub.add_parser(
        "calibrate", help="checkerboard stereo calibration -> calibration YAML + quality report"
    )
    c.add_argument("--left", required=True, help="glob of the left images, quoted: 'calib/left*.png'")
    c.add_argument(
        "--right", required=True, help="glob of the right images (paired with the left in sorted order)"
    )
    c.add_argument("--pattern", required=True, help="inner corners COLSxROWS, e.g. 9x6")
    c.add_argument("--square", type=float, required=True, help="square side in metres, e.g. 0.025")
    c.add_argument("--out", type=Path, required=True, help="calibration YAML to write")
    c.add_argument(
        "--figure", type=_figure_path, help="write a figure of the coverage and per-view errors (PNG)"
    )

    k = sub.add_parser(
        "check-calib", help="how far a rig has drifted from its calibration (vertical disparity)"
    )
    k.add_argument(
        "images",
        type=Path,
        nargs="+",
        metavar="LEFT RIGHT",
        help="a raw pair; more pairs (different views) pool their matches and can confirm a yaw",
    )
    k.add_argument("--calib", type=Path, required=True)

    g = sub.add_parser("render", help="write synthetic stereo scenes with ground truth")
    g.add_argument("--out", type=Path, required=True)
    g.add_argument("--count", type=_positive_int, default=1)
    g.add_argument("--seed", type=_seed, default=0)
    g.add_argument("--size", type=_size, default=(640, 480), help="WIDTHxHEIGHT (default 640x480)")
    g.add_argument("--kind", choices=["stairs", "box", "none"], help="obstacle kind (default: random)")
    g.add_argument(
        "--profile",
        choices=["default", "realistic"],  # synthetic.PROFILES, not imported at parse time
        default="default",
        help="scenes like the renderer's own (default) or like webcam photos of real stairs (realistic)",
    )
    _add_runtime_commands(sub)
    return p


def _nonneg_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
    if not v >= 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text}")
    return v


# ----------------------------------------------------------------- outputs, extras, progress

# Folders this command created (removed again, when still empty, if it fails).
_CREATED: list[Path] = []
# A progress line is drawn and not yet ended (an error must start on a fresh line).
_PROGRESS_OPEN = [False]


def _is_terminal(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def _check_output_file(path: Path | None, option: str) -> None:
    """Refuse, before any work, an output file that cannot be written."""
    if path is None or str(path) == "-":
        return
    if path.is_dir():
        raise InputError(f"cannot write {option} {path}: it is a folder; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"cannot write {option} {path}: the folder {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise InputError(f"cannot write {option} {path}: permission denied")


def _check_output_dir(path: Path, option: str) -> None:
    """Refuse, before any work, an output folder that cannot be created or written."""
    if path.exists() and not path.is_dir():
        raise InputError(f"{option} {path} exists and is not a folder")
    existing = path
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"{option} {path}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: {existing} is not writable")


def _make_dir(path: Path, option: str) -> None:
    """Create an output folder (and its parents); remembered so a failure removes them."""
    _check_output_dir(path, option)
    top = path
    while not top.parent.exists() and top.parent != top:
        top = top.parent
    created = not top.exists()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create {option} folder {path}: {exc.strerror}") from None
    if created:
        _CREATED.append(top)


def _remove_created() -> None:
    """Remove the folders this command created when they hold no file."""
    while _CREATED:
        top = _CREATED.pop()
        try:
            for root, dirs, files in os.walk(top, topdown=False):
                if files:
                    return
                for d in dirs:
                    (Path(root) / d).rmdir()
            top.rmdir()
        except OSError:
            pass


def _replace_from_temp(target: Path, write: Any) -> None:
    """``write(tmp_path)`` then rename onto ``target``: an existing file is replaced only by a
    whole new one, and a failed write leaves nothing behind."""
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix, dir=target.parent or ".")
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, target)
    except OSError as exc:
        raise InputError(f"cannot write {target}: {exc.strerror}") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _require(module: str, extra: str, what: str, skip: str = "") -> None:
    """An optional dependency, checked before any work."""
    try:
        importlib.import_module(module)
    except ImportError:
        alt = f", or pass {skip}" if skip else ""
        raise InputError(
            f"{what} needs the Python package '{module}', which is not installed: "
            f"pip install 'stereo-terrain[{extra}]'{alt}"
        ) from None


def _require_viz(what: str, skip: str = "") -> None:
    _require("matplotlib", "viz", what, skip)


def _require_lcm(what: str, skip: str = "") -> None:
    _require("lcm", "lcm", what, skip)


def _end_progress() -> None:
    if _PROGRESS_OPEN[0]:
        sys.stderr.write("\n")
        sys.stderr.flush()
        _PROGRESS_OPEN[0] = False


def _add_runtime_commands(sub: Any) -> None:
    """record | run | replay | simulate (the live side, ``runtime/``)."""

    def loop_options(q: argparse.ArgumentParser) -> None:
        q.add_argument("--config", type=Path, help="pipeline config YAML")
        q.add_argument(
            "--lcm-url", default=None, help="LCM provider URL (default udpm://239.255.76.67:7667?ttl=0)"
        )
        q.add_argument("--channel", default="STEREO_TERRAIN", help="LCM channel of the terrain messages")
        q.add_argument("--no-lcm", action="store_true", help="do not publish (no LCM needed)")
        q.add_argument("--max-skew-ms", type=_nonneg_float, default=15.0, help="drop pairs skewed more (ms)")
        q.add_argument(
            "--stall-timeout", type=_nonneg_float, default=0.5, help="seconds without a pair = stall"
        )
        q.add_argument("--frames", type=_positive_int, help="stop after this many processed pairs")
        q.add_argument("--duration", type=_nonneg_float, help="stop after this many seconds")
        q.add_argument("--quiet", action="store_true", help="no live status line")
        q.add_argument("--summary-json", type=Path, help="write the exit summary as JSON here")

    rec = sub.add_parser("record", help="save synchronized stereo pairs with timestamps for replay")
    rec.add_argument("--left", required=True, help="camera index, /dev/videoN or a video file")
    rec.add_argument("--right", required=True, help="camera index, /dev/videoN or a video file")
    rec.add_argument("--out", type=Path, required=True, help="new folder for pairs.csv and the images")
    rec.add_argument("--frames", type=_positive_int, help="stop after this many pairs")
    rec.add_argument("--duration", type=_nonneg_float, help="stop after this many seconds")
    rec.add_argument("--max-skew-ms", type=_nonneg_float, default=15.0, help="drop pairs skewed more (ms)")

    run = sub.add_parser("run", help="live loop on two cameras: terrain messages over LCM")
    run.add_argument("--left", required=True, help="camera index, /dev/videoN or a video file")
    run.add_argument("--right", required=True, help="camera index, /dev/videoN or a video file")
    run.add_argument("--calib", type=Path, required=True)
    run.add_argument("--rig", type=Path, help="rig YAML; body attitude from here unless --state-channel")
    run.add_argument("--state-channel", help="LCM channel of body_state_t (body pose and odometry)")
    loop_options(run)

    rp = sub.add_parser("replay", help="live loop on a recorded folder of pairs")
    rp.add_argument("folder", type=Path, help="folder with pairs.csv (from record or simulate --record)")
    rp.add_argument("--calib", type=Path, help="default: FOLDER/calib.yaml")
    rp.add_argument("--rig", type=Path, help="default: FOLDER/rig.yaml if present")
    rp.add_argument("--as-fast", action="store_true", help="every pair, as fast as it goes (no pacing)")
    rp.add_argument("--speed", type=_nonneg_float, default=1.0, help="playback speed (real time = 1)")
    rp.add_argument("--loop", action="store_true", help="repeat the recording until stopped")
    loop_options(rp)

    si = sub.add_parser(
        "simulate", help="a trotting robot approaches a staircase: trigger and foot clearance"
    )
    si.add_argument("--out", type=Path, required=True, help="folder for the plot and summary.json")
    si.add_argument("--rise", type=_nonneg_float, default=0.21, help="step rise, m (default 0.21)")
    si.add_argument("--run", dest="run_m", type=_nonneg_float, default=0.28, help="step run, m")
    si.add_argument("--start", type=_nonneg_float, default=2.2, help="first riser distance at the start, m")
    si.add_argument("--speed", type=_nonneg_float, default=0.5, help="walking speed, m/s")
    si.add_argument("--fps", type=_nonneg_float, default=30.0, help="camera frame rate")
    si.add_argument("--size", type=_size, default=(640, 480), help="WIDTHxHEIGHT (default 640x480)")
    si.add_argument("--record", type=Path, help="also write the rendered frames here for 'replay'")
    si.add_argument("--lcm-url", default=None, help="also publish the messages on this LCM URL")
    si.add_argument("--channel", default="STEREO_TERRAIN")
    si.add_argument("--no-plot", action="store_true")


def _read_pair(left_path: Path, right_path: Path, calib: Any, calib_path: Path) -> tuple[Any, Any]:
    """Both images, checked against each other and the calibration with the files named."""
    from .rectify import read_image

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


def _write_json(data: dict[str, Any], target: Path) -> None:
    text = json.dumps(data, indent=2)
    if str(target) == "-":
        print(text)
        return
    _replace_from_temp(target, lambda tmp: tmp.write_text(text + "\n"))


def _plot(result, target: Path, truth: dict | None = None) -> None:
    try:
        from .viz.figure import save_result_figure
    except ImportError as exc:
        raise InputError(
            f"--plot needs matplotlib ({exc}); install with pip install 'stereo-terrain[viz]'"
        ) from None
    _replace_from_temp(target, lambda tmp: save_result_figure(result, tmp, truth=truth))


def cmd_demo(args: argparse.Namespace) -> int:
    from .pipeline import Pipeline
    from .synthetic import default_scene_spec, render_scene, write_scene

    out: Path = args.out
    _check_output_dir(out, "--out")
    if not args.no_plot:
        _require_viz("the demo's figure", "--no-plot")
    _make_dir(out, "--out")
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

    _check_output_file(args.json, "--json")
    _check_output_file(args.plot, "--plot")
    if args.json is not None and args.plot is not None and args.json.resolve() == args.plot.resolve():
        raise InputError(f"--json and --plot name the same file {args.json}")
    if args.plot is not None:
        _require_viz("--plot")
    calib = read_calibration(args.calib)
    rig = load_rig(args.rig) if args.rig else None
    config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
    if args.max_disparity is not None:
        config = dataclasses.replace(config, max_disparity_px=args.max_disparity)
    if args.method is not None:
        config = dataclasses.replace(config, method=args.method)
    left, right = _read_pair(args.left, args.right, calib, args.calib)
    pipeline = Pipeline(calib, rig, config)
    result = pipeline.run(left, right)
    data = result.to_json_dict()
    if args.json is not None:
        _write_json(data, args.json)
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
    if args.plot is not None:
        _plot(result, args.plot)
    return EXIT_OK


def cmd_render(args: argparse.Namespace) -> int:
    from .synthetic import render_scenes

    _make_dir(args.out, "--out")
    kw: dict[str, Any] = {"image_size": args.size}
    if args.kind:
        kw["kind"] = args.kind
    paths = render_scenes(args.out, args.count, args.seed, profile=args.profile, **kw)
    for p in paths:
        print(p)
    return EXIT_OK


def _pair_disparity(method: str, calib, left, right, max_disparity: int | None):
    import time

    from .pipeline import PipelineConfig
    from .rectify import compute_rectification, rectify
    from .stereo import check_max_disparity, default_max_disparity, make_backend

    rect = compute_rectification(calib)
    pair = rectify(left, right, rect)
    if max_disparity is not None:
        n = check_max_disparity(max_disparity, calib.width)
    else:
        n = default_max_disparity(rect, PipelineConfig().min_depth_m)
    backend_name, options = _METHODS[method]
    backend = make_backend(backend_name, **options)
    t0 = time.perf_counter()
    dm = backend.compute(pair, n)
    return dm, (time.perf_counter() - t0) * 1000.0


def cmd_disparity(args: argparse.Namespace) -> int:
    from .calibration import read_calibration
    from .stereo.io import write_disparity

    if args.out.suffix.lower() not in (".pfm", ".npy", ".png"):
        raise InputError(f"--out: unknown disparity file type '{args.out.suffix}'; use .pfm, .npy or .png")
    _check_output_file(args.out, "--out")
    calib = read_calibration(args.calib)
    left, right = _read_pair(args.left, args.right, calib, args.calib)
    dm, ms = _pair_disparity(args.method, calib, left, right, args.max_disparity)
    _replace_from_temp(args.out, lambda tmp: write_disparity(tmp, dm.disparity))
    print(f"{args.method}: {dm.max_disparity_px} disparities, density {dm.density:.1%}, {ms:.0f} ms")
    print(f"wrote {args.out}")
    return EXIT_OK


def _progress(done: int, total: int, text: str) -> None:
    """A one-line progress bar on stderr when it is a terminal (a newline when done)."""
    if not _is_terminal(sys.stderr):
        return
    bar = "#" * (20 * done // max(total, 1))
    sys.stderr.write(f"\r[{bar:<20}] {done}/{total} {text:<60}")
    _PROGRESS_OPEN[0] = True
    if done == total:
        _end_progress()
    sys.stderr.flush()


def cmd_calibrate(args: argparse.Namespace) -> int:
    from .calibrate import (
        MAX_EPIPOLAR_RMS_PX,
        BoardConfig,
        calibrate_from_globs,
        parse_pattern,
        quality_report,
    )
    from .calibration import write_opencv_yaml

    cols, rows = parse_pattern(args.pattern)
    board = BoardConfig(cols, rows, args.square)
    if args.out.suffix.lower() not in (".yaml", ".yml", ".xml"):
        raise InputError(f"--out must be a .yaml, .yml or .xml file (OpenCV FileStorage), got {args.out}")
    # Fail before the detection work, not after it.
    _check_output_file(args.out, "--out")
    _check_output_file(args.figure, "--figure")
    if args.figure is not None:
        _require_viz("--figure")

    def progress(done: int, total: int, name: str, reason: str | None) -> None:
        _progress(done, total, f"{name}: {'board found' if reason is None else 'skipped, ' + reason}")

    result = calibrate_from_globs(args.left, args.right, board, progress=progress)
    for line in quality_report(result):
        print(line)
    if not result.quality.usable:
        raise InputError(
            f"calibration unusable: the rectified corners are {result.quality.epipolar_rms_px:.1f} px "
            f"apart vertically (RMS; good rigs give < {MAX_EPIPOLAR_RMS_PX} px), "
            f"so {args.out} was not written; "
            "use distinct views of the board moved around the image, paired left/right in the same order"
        )
    _replace_from_temp(args.out, lambda tmp: write_opencv_yaml(result.calibration, tmp))
    print(f"wrote {args.out}")
    if args.figure is not None:
        try:
            from .viz.calibration import save_calibration_figure
        except ImportError as exc:
            raise InputError(
                f"--figure needs matplotlib ({exc}); install with pip install 'stereo-terrain[viz]'"
            ) from None
        _replace_from_temp(args.figure, lambda tmp: save_calibration_figure(result, tmp))
        print(f"wrote {args.figure}")
    return EXIT_OK


def cmd_check_calib(args: argparse.Namespace) -> int:
    import numpy as np

    from .calibration import read_calibration
    from .drift import DriftConfig, check_calibration
    from .rectify import compute_rectification, rectify

    if len(args.images) % 2:
        raise InputError(
            f"check-calib takes pairs of images (LEFT RIGHT [LEFT RIGHT ...]), got {len(args.images)} files"
        )
    calib = read_calibration(args.calib)
    rect = compute_rectification(calib)
    pairs = [
        rectify(*_read_pair(left, right, calib, args.calib), rect)
        for left, right in zip(args.images[::2], args.images[1::2], strict=True)
    ]
    cfg = DriftConfig()
    c = check_calibration(pairs, cfg)
    print(f"pairs: {c.n_pairs}, matches: {c.n_matches}")
    if c.n_matches:
        print(
            f"vertical disparity y_left - y_right: median {c.median_px:+.3f} px, spread {c.spread_px:.3f} px "
            f"(1.4826 MAD), |.| 90th percentile {c.p90_abs_px:.3f} px"
        )
    if c.rotation is not None:
        deg, se = np.degrees(c.rotation.rotvec_rad), np.degrees(c.rotation.stderr_rad)
        parts = ", ".join(
            f"{a} {d:+.3f}" + (f" (+-{s:.3f})" if np.isfinite(s) else "")
            for a, d, s in zip("xyz", deg, se, strict=True)
        )
        print(f"right camera drift to undo (deg, rectified frame; 0 = not significant): {parts}")
        if not c.yaw_confirmed:
            print(
                f"  yaw (y) held at 0: it needs {cfg.yaw_frames} pairs of different views that agree on it "
                "(one view cannot tell a yaw from a lens-distortion residual)"
            )
        print(
            f"worst error it causes over the image: vertical {c.vertical_error_px:.2f} px, "
            f"disparity {c.disparity_error_px:.2f} px"
        )
    if c.verdict == "unknown":
        print(
            f"verdict: unknown (fewer than {cfg.min_matches} matches; point the cameras at a textured "
            "scene a metre or more away)"
        )
    else:
        print(
            f"verdict: {c.verdict} (drift {c.drift_px:.2f} px; ok < {cfg.ok_px} px <= degraded < "
            f"{cfg.recalibrate_px} px <= recalibrate)"
        )
    return EXIT_OK


def cmd_eval_disparity(args: argparse.Namespace) -> int:
    import numpy as np

    from .evaluation import disparity_errors, middlebury_scene_dirs, read_middlebury_scene

    methods = args.method or ["sgm", "opencv", "opencv-sgbm", "opencv-hh"]
    dirs = middlebury_scene_dirs(args.root)
    rows = []
    total = len(dirs) * len(methods)
    for i, d in enumerate(dirs):
        scene = read_middlebury_scene(d)
        for j, m in enumerate(methods):
            _progress(i * len(methods) + j + 1, total, f"{scene.name} {m}")
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


def cmd_record(args: argparse.Namespace) -> int:
    from .runtime.capture import PAIRS_FILE, Capture, open_devices, record_pairs

    source = open_devices(args.left, args.right)
    try:
        _check_output_dir(args.out, "--out")
        if (args.out / PAIRS_FILE).exists():
            raise InputError(f"--out {args.out} already holds a recording ({PAIRS_FILE}); use a new folder")
    except InputError:
        source.close()
        raise
    capture = Capture(source, args.max_skew_ms / 1000.0)
    try:
        n = record_pairs(capture, args.out, max_pairs=args.frames or 0, max_duration_s=args.duration or 0.0)
    finally:
        capture.close()
    st = capture.stats
    if n == 0:
        why = (
            f"every pair was dropped ({st.unreadable} unreadable, {st.skew_dropped} for skew; the first: "
            f"{st.first_problem}); check the sources (same size, --max-skew-ms)"
            if st.first_problem
            else "no pair arrived before the recording stopped (empty or unreadable videos, cameras that "
            "deliver nothing, or a stop before the first frame)"
        )
        raise InputError(f"recorded no pairs in {args.out}: {why}")
    print(
        f"recorded {n} pairs in {args.out}; dropped for skew {st.skew_dropped}, unreadable {st.unreadable}, "
        f"superseded {st.skipped}"
    )
    return EXIT_OK


def _pipeline(calib_path: Path, rig_path: Path | None, config_path: Path | None):
    from .calibration import read_calibration
    from .frames import load_rig
    from .pipeline import Pipeline, PipelineConfig

    calib = read_calibration(calib_path)
    rig = load_rig(rig_path) if rig_path else None
    config = PipelineConfig.from_yaml(config_path) if config_path else PipelineConfig()
    return Pipeline(calib, rig, config)


def _run_loop(args: argparse.Namespace, source, pipeline, pose=None) -> int:
    from .runtime.capture import Capture
    from .runtime.loop import LiveLoop, LoopConfig

    publish: Any = lambda msg: None  # noqa: E731
    _check_output_file(args.summary_json, "--summary-json")
    if not args.no_lcm:
        from .runtime.lcm_io import DEFAULT_URL, LcmPublisher

        publish = LcmPublisher(args.lcm_url or DEFAULT_URL, args.channel)
    config = LoopConfig(
        max_skew_s=args.max_skew_ms / 1000.0,
        stall_timeout_s=args.stall_timeout,
        max_frames=args.frames or 0,
        max_duration_s=args.duration or 0.0,
    )
    loop = LiveLoop(
        Capture(source),
        pipeline,
        publish,
        pose=pose,
        config=config,
        status=None if args.quiet or not _is_terminal(sys.stderr) else sys.stderr,
    )
    loop.warm_up()
    summary = loop.run()
    print(summary.format())
    if args.summary_json is not None:
        data = {k: v for k, v in dataclasses.asdict(summary).items() if k not in ("latencies_s", "periods_s")}
        data.update(
            fps=summary.fps, latency_median_ms=summary.latency_ms(50), latency_p99_ms=summary.latency_ms(99)
        )
        _write_json(data, args.summary_json)
    return EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    from .runtime.capture import open_devices
    from .runtime.loop import rig_pose

    _check_output_file(args.summary_json, "--summary-json")
    if not args.no_lcm or args.state_channel:
        _require_lcm("publishing terrain messages" if not args.no_lcm else "--state-channel", "--no-lcm")
    pipeline = _pipeline(args.calib, args.rig, args.config)
    pose = rig_pose(pipeline.rig)
    listener = None
    if args.state_channel:
        from .runtime.lcm_io import DEFAULT_URL, LcmStateListener

        listener = LcmStateListener(args.lcm_url or DEFAULT_URL, args.state_channel)

        def pose(frame):  # the latest body state; the rig's attitude until one arrives
            got = listener.latest()
            return (None, pipeline.rig.body_rpy if pipeline.rig else None) if got is None else got[:2]

    source = open_devices(args.left, args.right)
    try:
        return _run_loop(args, source, pipeline, pose)
    finally:
        if listener is not None:
            listener.close()


def cmd_replay(args: argparse.Namespace) -> int:
    from .runtime.capture import FolderPairs, Paced

    folder: Path = args.folder
    if not folder.exists():
        raise InputError(f"recorded pairs folder not found: {folder}")
    if not folder.is_dir():
        raise InputError(f"{folder} is not a folder of recorded pairs (pairs.csv and the images)")
    _check_output_file(args.summary_json, "--summary-json")
    if not args.no_lcm:
        _require_lcm("publishing terrain messages", "--no-lcm")
    calib = args.calib or folder / "calib.yaml"
    if args.calib is None and not calib.is_file():
        raise InputError(f"no --calib given and {calib} does not exist")
    rig = args.rig or (folder / "rig.yaml" if (folder / "rig.yaml").is_file() else None)
    if args.speed <= 0:
        raise InputError("--speed must be > 0")
    pipeline = _pipeline(calib, rig, args.config)
    source = Paced(FolderPairs(folder, loop=args.loop), realtime=not args.as_fast, speed=args.speed)
    return _run_loop(args, source, pipeline)


# The simulate options behind the configuration fields that check them, so that an error
# names the option the user typed.
_SIMULATE_OPTIONS = {
    "ApproachConfig.rise_m": "--rise",
    "StairSpec.rise_m": "--rise",
    "ApproachConfig.run_m": "--run",
    "StairSpec.run_m": "--run",
    "ApproachConfig.start_distance_m": "--start",
    "ApproachConfig.speed_mps": "--speed",
    "ApproachConfig.fps": "--fps",
}


def _in_option_names(exc: InputError) -> InputError:
    message = str(exc)
    for field_name, option in _SIMULATE_OPTIONS.items():
        message = message.replace(field_name, option)
    return type(exc)(message)


def cmd_simulate(args: argparse.Namespace) -> int:
    from .runtime.simulate import ApproachConfig, approach_spec, simulate_approach

    try:
        cfg = ApproachConfig(
            rise_m=args.rise, run_m=args.run_m, start_distance_m=args.start, speed_mps=args.speed,
            fps=args.fps, image_size=args.size,
        )  # fmt: skip
        approach_spec(cfg, 0.0, 0.0)  # the stairs' own checks, before any work
    except InputError as exc:
        raise _in_option_names(exc) from None
    from .runtime.capture import PAIRS_FILE

    _check_output_dir(args.out, "--out")
    if args.record is not None:
        _check_output_dir(args.record, "--record")
        if (args.record / PAIRS_FILE).exists():
            raise InputError(f"--record {args.record} already holds a recording ({PAIRS_FILE})")
    if not args.no_plot:
        _require_viz("the approach figure", "--no-plot")
    publish = None
    if args.lcm_url:
        _require_lcm("--lcm-url")
        from .runtime.lcm_io import LcmPublisher

        publish = LcmPublisher(args.lcm_url, args.channel)
    _make_dir(args.out, "--out")

    def progress(k: int, n: int) -> None:
        if not _is_terminal(sys.stderr):
            return
        sys.stderr.write(f"\rrendering and processing frame {k}/{n}")
        _PROGRESS_OPEN[0] = True
        if k == n:
            _end_progress()

    result = simulate_approach(cfg, publish=publish, record_to=args.record, progress=progress)
    summary = result.summary()
    _write_json(summary, args.out / "summary.json")
    err = summary["trigger_error_m"]
    raised = (
        "swing never raised"
        if err is None
        else f"swing raised at {summary['trigger_at_m']:.3f} m ({100 * err:+.1f} cm from d - d_buffer), "
        f"height {summary['swing_height_m']:.3f} m"
    )
    print(
        f"{summary['frames']} frames, riser at {cfg.riser_x_m:.3f} m, "
        f"d_buffer {result.swing.buffer_m:.2f} m: {raised}"
    )
    if summary["not_traversable_reported"]:
        print("stairs reported NOT traversable (a step above the leg's reach): the swing stays nominal")
    for name, key in (("perceived", "edge_clearance_sensed_m"), ("blind", "edge_clearance_blind_m")):
        legs = ", ".join(f"{k} {100 * v:+.1f} cm" for k, v in sorted(summary[key].items()))
        print(f"first riser edge clearance, {name} swing: {legs}")
    if not args.no_plot:
        try:
            from .viz.approach import save_approach_figure
        except ImportError as exc:
            raise InputError(
                f"the plot needs matplotlib ({exc}); pip install 'stereo-terrain[viz]'"
            ) from None
        _replace_from_temp(args.out / "approach.png", lambda tmp: save_approach_figure(result, tmp))
        print(f"wrote {args.out / 'approach.png'}")
    print(f"wrote {args.out / 'summary.json'}" + (f" and the frames in {args.record}" if args.record else ""))
    return EXIT_OK


COMMANDS = {
    "record": cmd_record,
    "run": cmd_run,
    "replay": cmd_replay,
    "simulate": cmd_simulate,
    "demo": cmd_demo,
    "reconstruct": cmd_reconstruct,
    "render": cmd_render,
    "disparity": cmd_disparity,
    "eval-disparity": cmd_eval_disparity,
    "calibrate": cmd_calibrate,
    "check-calib": cmd_check_calib,
}


def _error_line(command: str, exc: BaseException) -> str:
    """The one line a failed command prints."""
    if isinstance(exc, KeyboardInterrupt):
        return "stereo-terrain: interrupted"
    code = exit_code(exc)
    if code == EXIT_USAGE and isinstance(exc, OSError):
        return f"stereo-terrain {command}: error: cannot use {exc.filename}: {exc.strerror or exc}"
    text = " ".join(str(exc).split())  # one line, whatever the message held
    if code == EXIT_USAGE:
        return f"stereo-terrain {command}: error: {text}"
    return (
        f"stereo-terrain {command}: internal error: {type(exc).__name__}: {text[:500]} "
        "(please report it; run with -v for details)"
    )


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s"
    )
    # Python warnings go through logging (one format), and only with -v.
    logging.captureWarnings(True)
    logging.getLogger("py.warnings").setLevel(logging.WARNING if args.verbose else logging.ERROR)
    from .native import silence_opencv_logging

    silence_opencv_logging()
    _CREATED.clear()
    _PROGRESS_OPEN[0] = False
    try:
        return COMMANDS[args.command](args)
    except (Exception, KeyboardInterrupt) as exc:
        code = exit_code(exc)
        _end_progress()
        _remove_created()
        if code == EXIT_INTERNAL:
            log.debug("internal error", exc_info=True)
        sys.stderr.write(_error_line(args.command, exc) + "\n")
        if code == EXIT_INTERNAL and args.verbose:
            import traceback

            traceback.print_exc()
        return code
    finally:
        _CREATED.clear()


if __name__ == "__main__":
    raise SystemExit(main())
