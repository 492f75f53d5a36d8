"""Argument types of the command line: each refuses a bad value with one line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, NoReturn

from ..errors import EXIT_USAGE

#: Disparity methods by name: backend and its options.
METHODS: dict[str, tuple[str, dict[str, Any]]] = {
    "opencv": ("opencv", {}),
    "opencv-sgbm": ("opencv", {"mode": "sgbm"}),
    "opencv-hh": ("opencv", {"mode": "hh"}),
    "sgm": ("sgm", {}),
    "sgm-4": ("sgm", {"paths": 4}),
}


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit code 2."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: error: {message} (see '{self.prog} --help')\n")
        raise SystemExit(EXIT_USAGE)


MAX_SIZE_PX = 4096


def size_arg(text: str) -> tuple[int, int]:
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


def _number(text: str, convert: Any, expected: str) -> Any:
    """``convert(text)``, or an argparse error saying what was expected."""
    try:
        return convert(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got '{text}'") from None


def positive_int(text: str) -> int:
    v = _number(text, int, "a positive integer")
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    if v > MAX_INT_OPTION:
        raise argparse.ArgumentTypeError(f"expected a positive integer up to {MAX_INT_OPTION}, got {v}")
    return v


def seed_arg(text: str) -> int:
    v = _number(text, int, "an integer >= 0")
    if not 0 <= v < 2**63:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, 2**63), got {v}")
    return v


FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def figure_path(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise argparse.ArgumentTypeError(
            f"a figure must end in one of {', '.join(FIGURE_SUFFIXES)}, got '{text}'"
        )
    return path


def nonneg_float(text: str) -> float:
    v = _number(text, float, "a number")
    if not v >= 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text}")
    return v


def positive_float(text: str) -> float:
    v = _number(text, float, "a number")
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text}")
    return v
