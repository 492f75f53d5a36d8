"""Command line: ``stereo-terrain demo | reconstruct | render | disparity | eval-disparity |
calibrate | check-calib | record | run | replay | simulate``.

Thin: parses arguments, calls the stages, and maps every error to an exit code in one
place (:func:`main`, through :func:`stereo_terrain.errors.exit_code`): 0 success, 2 bad
input or usage with one line on stderr, 1 internal error.

One module per command family: ``scene`` (single pairs and offline sets), ``calib``
(calibration and drift), ``live`` (cameras, recordings, the simulated approach);
``options`` holds the argument types and ``outputs`` what every command shares about its
outputs: checked before any work, written whole or not at all, optional packages named by
their extra, progress bars only on a terminal.
"""

from __future__ import annotations

import argparse
import glob
import logging
import os
import sys
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import EXIT_INTERNAL, EXIT_USAGE, exit_code
from . import bench, calib, live, scene
from .options import Parser
from .outputs import CREATED, INPUTS, OUTPUTS, end_progress, remove_created

log = logging.getLogger("stereo_terrain")

_FAMILIES = (scene, calib, live, bench)
COMMANDS = {name: cmd for family in _FAMILIES for name, cmd in family.COMMANDS.items()}


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog="stereo-terrain",
        description="Stairs and boxes ahead of a legged robot from a calibrated stereo pair.",
    )
    p.add_argument("-v", "--verbose", action="store_true", help="log what each stage does")
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    for family in _FAMILIES:
        family.add_parsers(sub)
    for command in sub.choices.values():  # -v after the command too (the error line says "run with -v")
        command.add_argument(
            "-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="log what each stage does"
        )
    return p


#: Arguments that name files a command reads.
_INPUT_ARGS = ("left", "right", "calib", "rig", "config")


#: Files a recording folder (``replay FOLDER``) is read from, besides its images.
_RECORDING_FILES = ("pairs.csv", "calib.yaml", "rig.yaml", "approach.json")
#: Files a ``bench`` scene folder is read from.
_SCENE_FILES = ("left.png", "right.png", "calib.yaml", "rig.yaml", "truth.json")
#: The images of a recording folder (its ``pairs.csv`` names them).
_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".pnm", ".webp")


def _input_files(args: argparse.Namespace) -> list[Path]:
    """The files the command's arguments name as inputs (for :data:`.outputs.INPUTS`): the
    files named; what a folder argument is read from (a recording's ``replay FOLDER``: its
    index, calibration, rig, approach and images; ``bench``'s scenes: each scene's images,
    calibration, rig and truth), or the file itself (a bag); what a glob matches
    (``calibrate --left 'left*.png'``) and a video given as a camera (``run``,
    ``record``). No output may be one of them: it would be overwritten by what was made
    from it. A new file beside them (``--summary-json REC/summary.json``) may be written,
    and written again. What cannot be listed is left to the command, which says so."""
    files: list[Any] = [getattr(args, name, None) for name in _INPUT_ARGS]
    try:
        folder = getattr(args, "folder", None)
        if isinstance(folder, Path) and folder.is_file():
            files.append(folder)  # a bag: replay BAG --mcap BAG wrote over it
        elif isinstance(folder, Path) and folder.is_dir():
            files += [folder / name for name in _RECORDING_FILES]
            files += [f for f in folder.iterdir() if f.suffix.lower() in _IMAGE_SUFFIXES]
        scenes = getattr(args, "scenes", None)
        if isinstance(scenes, Path) and scenes.is_dir():
            for d in [scenes, *(d for d in scenes.iterdir() if d.is_dir())]:
                files += [d / name for name in _SCENE_FILES]
    except OSError:
        pass
    for name in ("left", "right"):
        value = getattr(args, name, None)
        if isinstance(value, str):  # a glob (calibrate) or a camera: index, device or video file
            files += [Path(value), *(Path(p) for p in glob.glob(value))]
    return [f for f in files if isinstance(f, Path)]


class _StdoutReaderMayLeave:
    """``sys.stdout`` while a command runs. When the reader of stdout goes away (``...
    --json - | head -1``), what the command prints after that is dropped and the command
    goes on: its files are still written and its exit code stands. Stdout is pointed at the
    null device then, so that the interpreter's last flush does not fail again."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self.reader_gone = False

    def write(self, text: str) -> int:
        if not self.reader_gone:
            try:
                return int(self._stream.write(text))
            except BrokenPipeError:
                self._reader_left()
        return len(text)

    def flush(self) -> None:
        if not self.reader_gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._reader_left()

    def _reader_left(self) -> None:
        self.reader_gone = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
        except (OSError, ValueError):
            pass

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


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
    from ..native import silence_opencv_logging

    silence_opencv_logging()
    CREATED.clear()
    OUTPUTS.clear()
    INPUTS[:] = _input_files(args)
    end_progress()
    stdout = sys.stdout
    sys.stdout = _StdoutReaderMayLeave(stdout)  # type: ignore[assignment]
    try:
        code = COMMANDS[args.command](args)
        sys.stdout.flush()
        return code
    except (Exception, KeyboardInterrupt) as exc:
        code = exit_code(exc)
        end_progress()
        remove_created()
        if code == EXIT_INTERNAL:
            log.debug("internal error", exc_info=True)
        sys.stderr.write(_error_line(args.command, exc) + "\n")
        if code == EXIT_INTERNAL and args.verbose:
            import traceback

            traceback.print_exc()
        return code
    finally:
        sys.stdout = stdout
        CREATED.clear()
        OUTPUTS.clear()
        INPUTS.clear()
