"""Scoring terrain results and disparity maps against ground truth (used by tests,
benchmarks and ``eval-disparity``).

Terrain: both sides are the JSON contract of CONVENTIONS.md (the renderer's truth has the
same keys); recovered steps are matched to true steps by riser distance. Disparity:
Middlebury 2014 folders (:func:`middlebury_scene_dirs`, :func:`read_middlebury_scene`)
and :func:`disparity_errors`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .calibration import StereoCalibration, read_calibration
from .errors import InputError
from .rectify import read_image
from .stereo.io import read_pfm


@dataclass(frozen=True)
class SceneScore:
    """How one result compares with its truth.

    Attributes
    ----------
    has_obstacle : bool
        The truth has an obstacle.
    detected : bool
        The result has one.
    count_right : bool
        Same number of steps (and both ``none`` counts as right).
    rise_errors_m, run_errors_m : list of float
        Absolute errors of matched steps (run only where both are known).
    first_distance_error_m : float or None
        Absolute error of the first riser's distance, when both have one.
    """

    has_obstacle: bool
    detected: bool
    count_right: bool
    rise_errors_m: list[float] = field(default_factory=list)
    run_errors_m: list[float] = field(default_factory=list)
    first_distance_error_m: float | None = None
    yaw_error_rad: float | None = None


def matched_steps(
    result: dict[str, Any], truth: dict[str, Any], *, match_tol_m: float = 0.12
) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """``(result step, true step)`` pairs: each true step, nearest first in its order, with
    the unused result step whose riser distance is nearest to its own, within
    ``match_tol_m`` (none where neither side has an obstacle)."""
    t_steps = truth.get("steps", []) if truth.get("obstacle", "none") != "none" else []
    r_steps = result.get("steps", []) if result.get("obstacle", "none") != "none" else []
    pairs: list[tuple[dict[str, Any], dict[str, Any]]] = []
    used: set[int] = set()
    for ts in t_steps:
        best, best_d = None, match_tol_m
        for j, rs in enumerate(r_steps):
            dd = abs(rs["distance"] - ts["distance"])
            if j not in used and dd <= best_d:
                best, best_d = j, dd
        if best is not None:
            used.add(best)
            pairs.append((r_steps[best], ts))
    return pairs


def score_result(result: dict[str, Any], truth: dict[str, Any], *, match_tol_m: float = 0.12) -> SceneScore:
    """Compare one result with its truth; steps matched by nearest riser distance
    (:func:`matched_steps`)."""
    t_steps = truth.get("steps", []) if truth.get("obstacle", "none") != "none" else []
    r_steps = result.get("steps", []) if result.get("obstacle", "none") != "none" else []
    has, det = bool(t_steps), bool(r_steps)
    count_right = len(t_steps) == len(r_steps)
    rises: list[float] = []
    runs: list[float] = []
    for rs, ts in matched_steps(result, truth, match_tol_m=match_tol_m):
        rises.append(abs(rs["rise"] - ts["rise"]))
        if rs.get("run") is not None and ts.get("run") is not None:
            runs.append(abs(rs["run"] - ts["run"]))
    first = None
    yaw_err = None
    if has and det:
        first = abs(r_steps[0]["distance"] - t_steps[0]["distance"])
        # A truth.json's yaw may be null (bench.check_truth allows it): no yaw error then.
        # (One without a yaw key is compared as 0, the frame's x axis, as before.)
        if truth.get("yaw", 0.0) is not None and result.get("yaw", 0.0) is not None:
            yaw_err = abs(float(result.get("yaw", 0.0)) - float(truth.get("yaw", 0.0)))
    return SceneScore(has, det, count_right, rises, runs, first, yaw_err)


def summarize(scores: Iterable[SceneScore]) -> dict[str, float]:
    """Rates and error statistics over many scenes (metres; NaN where nothing to measure)."""
    scores = list(scores)
    pos = [s for s in scores if s.has_obstacle]
    neg = [s for s in scores if not s.has_obstacle]
    rises = np.array([e for s in pos for e in s.rise_errors_m])
    runs = np.array([e for s in pos for e in s.run_errors_m])
    firsts = np.array([s.first_distance_error_m for s in pos if s.first_distance_error_m is not None])

    def stat(a: np.ndarray, q: float) -> float:
        return float(np.percentile(a, q)) if len(a) else float("nan")

    return {
        "scenes": float(len(scores)),
        "detection_rate": float(np.mean([s.detected for s in pos])) if pos else float("nan"),
        "false_positive_rate": float(np.mean([s.detected for s in neg])) if neg else float("nan"),
        "count_rate": float(np.mean([s.count_right for s in pos])) if pos else float("nan"),
        "rise_median_m": stat(rises, 50),
        "rise_p90_m": stat(rises, 90),
        "run_median_m": stat(runs, 50),
        "run_p90_m": stat(runs, 90),
        "first_distance_median_m": stat(firsts, 50),
        "first_distance_p90_m": stat(firsts, 90),
        "matched_steps": float(len(rises)),
    }


def disparity_errors(
    disparity: np.ndarray, truth: np.ndarray, mask: np.ndarray | None = None
) -> dict[str, float]:
    """Middlebury-style disparity metrics; a pixel without a disparity counts as bad.

    Parameters
    ----------
    disparity : (H, W) float32, NaN invalid
    truth : (H, W) float32, inf/NaN unknown
    mask : (H, W) bool, optional
        Pixels evaluated (e.g. non-occluded); always intersected with known truth.

    Returns
    -------
    ``bad1``, ``bad2``, ``bad4`` (fractions), ``avgerr`` (px, over pixels with a disparity),
    ``density`` (fraction of evaluated pixels with a disparity).
    """
    known = np.isfinite(truth)
    if mask is not None:
        known &= mask
    d = disparity[known]
    t = truth[known]
    have = np.isfinite(d)
    err = np.where(have, np.abs(d - t), np.inf)
    n = max(int(known.sum()), 1)
    return {
        "bad1": float(np.sum(err > 1.0) / n),
        "bad2": float(np.sum(err > 2.0) / n),
        "bad4": float(np.sum(err > 4.0) / n),
        "avgerr": float(np.mean(err[have])) if have.any() else float("nan"),
        "density": float(have.mean()) if len(have) else 0.0,
    }


MIDDLEBURY_FILES = ("im0.png", "im1.png", "calib.txt", "disp0GT.pfm")


def middlebury_scene_dirs(root: str | Path) -> list[Path]:
    """``root`` itself when it is a Middlebury 2014 scene folder (``MIDDLEBURY_FILES``), else
    its sub-folders that are, sorted; :class:`InputError` when there is none."""
    root = Path(root)
    if all((root / n).is_file() for n in MIDDLEBURY_FILES):
        return [root]
    dirs = (
        sorted(d for d in root.iterdir() if d.is_dir() and all((d / n).is_file() for n in MIDDLEBURY_FILES))
        if root.is_dir()
        else []
    )
    if not dirs:
        raise InputError(f"no Middlebury scene ({', '.join(MIDDLEBURY_FILES)}) in {root}")
    return dirs


@dataclass(frozen=True)
class MiddleburyScene:
    """One Middlebury 2014 scene: its pair, calibration and ground truth.

    Attributes
    ----------
    name : str
    calibration : StereoCalibration
    left, right : (H, W) uint8
    truth : (H, W) float32
        ``disp0GT.pfm`` (inf where unknown).
    nonoccluded : (H, W) bool or None
        ``mask0nocc.png == 255``; None when the folder has no mask.
    """

    name: str
    calibration: StereoCalibration = field(repr=False)
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    truth: np.ndarray = field(repr=False)
    nonoccluded: np.ndarray | None = field(repr=False)


def read_middlebury_scene(folder: str | Path) -> MiddleburyScene:
    """Read a scene folder of :func:`middlebury_scene_dirs`.

    :class:`InputError` when the images, ground truth and mask differ in size from the
    calibration, or the mask does not decode.
    """
    folder = Path(folder)
    calibration = read_calibration(folder / "calib.txt")
    left, right = read_image(folder / "im0.png"), read_image(folder / "im1.png")
    truth = read_pfm(folder / "disp0GT.pfm")
    size = calibration.image_size
    for name, a in (("im0.png", left), ("im1.png", right), ("disp0GT.pfm", truth)):
        if (a.shape[1], a.shape[0]) != size:
            raise InputError(
                f"{folder / name} is {a.shape[1]}x{a.shape[0]} but {folder / 'calib.txt'} says "
                f"{size[0]}x{size[1]}; every file of a scene must have the same resolution"
            )
    if not np.isfinite(truth).any():
        raise InputError(
            f"{folder / 'disp0GT.pfm'} has no known disparity (every pixel inf or NaN): "
            "nothing to score against"
        )
    mask_path = folder / "mask0nocc.png"
    nonoccluded = None
    if mask_path.is_file():
        try:
            mask = read_image(mask_path)
        except InputError as exc:
            raise InputError(f"non-occlusion mask {mask_path} is unreadable: {exc}") from None
        if (mask.shape[1], mask.shape[0]) != size:
            raise InputError(
                f"{mask_path} is {mask.shape[1]}x{mask.shape[0]} but the scene is {size[0]}x{size[1]}"
            )
        nonoccluded = mask == 255
        if not nonoccluded.any():
            raise InputError(f"{mask_path} marks no pixel as non-occluded (255): a wrong or corrupt mask")
    return MiddleburyScene(folder.name, calibration, left, right, truth, nonoccluded)
