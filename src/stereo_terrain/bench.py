"""Timing and accuracy of the whole pipeline over a folder of scenes (``stereo-terrain bench``).

A scene folder is the ``render`` layout (:func:`stereo_terrain.synthetic.write_scene`):
``left.png``, ``right.png``, ``calib.yaml``, optionally ``rig.yaml`` and ``truth.json``
(the result contract's ``obstacle`` and ``steps[].rise/run/distance``).

Per scene, in one process: the first call of a new :class:`~stereo_terrain.pipeline.Pipeline`
(its construction, which warms the compiled kernels up, is timed apart), then ``repeat``
warm calls interleaved with OpenCV's StereoSGBM 3-way alone on the same rectified pair at
the calibration's disparity range, so that the ratio of the two holds on a noisy machine.
Accuracy is scored against ``truth.json`` by :func:`stereo_terrain.evaluation.score_result`
on the first call's result. :func:`score_with_ray` spreads the accuracy runs (not the
timing) over a Ray cluster.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .calibration import StereoCalibration, read_calibration
from .checks import load_json_file
from .errors import InputError
from .evaluation import SceneScore, score_result, summarize
from .frames import Rig, load_rig
from .pipeline import Pipeline, PipelineConfig
from .rectify import read_image

#: Files every scene folder must hold.
SCENE_FILES = ("left.png", "right.png", "calib.yaml")
#: Stages of ``timing_ms`` reported per stage (the pipeline's laps and its total; and the
#: second opinions, ``PipelineConfig.rematch``, ``far_planes_sigmas``, ``redraw_planes`` and
#: the denoising of ``rematch_denoised``, each a median over the frames that ran it).
STAGES = (
    "rectify", "disparity", "cloud", "gravity", "planes", "polytope",
    "rematch", "far_planes", "redraw", "denoise", "total",
)  # fmt: skip
_OBSTACLES = ("stairs", "box", "none")


@dataclass(frozen=True)
class BenchScene:
    """One scene folder, read.

    Attributes
    ----------
    name : str
    calibration : StereoCalibration
    rig : Rig or None
    left, right : (H, W) uint8, raw images
    truth : dict or None
        ``truth.json`` (checked by :func:`check_truth`), None when absent.
    """

    name: str
    calibration: StereoCalibration = field(repr=False)
    rig: Rig | None = field(repr=False)
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    truth: dict[str, Any] | None = field(repr=False)


@dataclass(frozen=True)
class SceneTiming:
    """Times of one scene, milliseconds.

    Attributes
    ----------
    construct_ms : float
        ``Pipeline(...)`` (rectification maps, kernel warm-up).
    first_frame_ms : float
        The first ``run`` of the new pipeline (wall time around the call).
    frames_ms : list of float
        ``timing_ms["total"]`` of each warm call.
    stages_ms : dict of stage -> list of float
        Each warm call's ``timing_ms`` per stage.
    opencv_3way_ms : list of float
        OpenCV StereoSGBM 3-way alone on the same rectified pair, one call before each warm
        pipeline call.
    """

    construct_ms: float
    first_frame_ms: float
    frames_ms: list[float]
    stages_ms: dict[str, list[float]]
    opencv_3way_ms: list[float]

    @property
    def ratios(self) -> list[float]:
        """Each warm frame over the 3-way call just before it."""
        return [f / o for f, o in zip(self.frames_ms, self.opencv_3way_ms, strict=True) if o > 0]


@dataclass(frozen=True)
class SceneOutcome:
    """What the bench measured on one scene.

    Attributes
    ----------
    name : str
    result : dict
        The first call's terrain result (JSON contract).
    score : SceneScore or None
        Against ``truth.json``; None without one.
    timing : SceneTiming or None
        None when timing was not measured (``--ray``).
    """

    name: str
    result: dict[str, Any] = field(repr=False)
    score: SceneScore | None
    timing: SceneTiming | None = None


def scene_dirs(root: str | Path) -> list[Path]:
    """``root`` itself when it holds a scene, else its sub-folders, sorted; every one must
    be a scene folder (:data:`SCENE_FILES`), else :class:`InputError` naming what is
    missing."""
    root = Path(root)
    if not root.exists():
        raise InputError(f"scenes folder {root} does not exist")
    if not root.is_dir():
        raise InputError(f"scenes folder {root} is not a folder")
    if any((root / n).exists() for n in SCENE_FILES):
        dirs = [root]
    else:
        dirs = sorted(d for d in root.iterdir() if d.is_dir() and not d.name.startswith("."))
    if not dirs:
        raise InputError(f"no scene folders in {root} (each needs {', '.join(SCENE_FILES)})")
    for d in dirs:
        missing = [n for n in SCENE_FILES if not (d / n).is_file()]
        if missing:
            raise InputError(
                f"scene folder {d} has no {', '.join(missing)} (a scene needs {', '.join(SCENE_FILES)})"
            )
    return dirs


def _number(value: Any, where: str, *, optional: bool = False) -> None:
    if value is None and optional:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        expected = "a finite number or null" if optional else "a finite number"
        raise InputError(f"{where} must be {expected}, got {value!r}")


def check_truth(data: Any, path: str | Path) -> dict[str, Any]:
    """Check a truth dict: ``obstacle`` one of stairs/box/none and ``steps`` a list of
    ``{"rise", "run" (or null), "distance"}`` numbers; :class:`InputError` naming ``path``
    otherwise. Returns ``data``."""
    if not isinstance(data, dict):
        raise InputError(f"{path}: truth must be a JSON object, got {type(data).__name__}")
    if data.get("obstacle") not in _OBSTACLES:
        raise InputError(
            f"{path}: 'obstacle' must be one of {', '.join(_OBSTACLES)}, got {data.get('obstacle')!r}"
        )
    steps = data.get("steps", [])
    if not isinstance(steps, list):
        raise InputError(f"{path}: 'steps' must be a list, got {type(steps).__name__}")
    for i, s in enumerate(steps):
        if not isinstance(s, dict):
            raise InputError(f"{path}: steps[{i}] must be an object, got {type(s).__name__}")
        for key in ("rise", "distance"):
            _number(s.get(key), f"{path}: steps[{i}].{key}")
        _number(s.get("run"), f"{path}: steps[{i}].run", optional=True)
    if "yaw" in data:
        _number(data["yaw"], f"{path}: 'yaw'", optional=True)
    return data


def read_truth(path: str | Path) -> dict[str, Any]:
    """Read and check ``truth.json`` (:func:`check_truth`); :class:`InputError` for a file
    that is not UTF-8 JSON (:func:`~.checks.load_json_file`)."""
    return check_truth(load_json_file(path, "truth file"), path)


def read_bench_scene(folder: str | Path, *, use_rig: bool = True) -> BenchScene:
    """Read one scene folder (images checked against the calibration's size); its
    ``rig.yaml`` is left unread with ``use_rig=False`` (gravity from the scene, as a user
    without a rig file runs the pipeline)."""
    folder = Path(folder)
    calib = read_calibration(folder / "calib.yaml")
    rig = load_rig(folder / "rig.yaml") if use_rig and (folder / "rig.yaml").is_file() else None
    left, right = read_image(folder / "left.png"), read_image(folder / "right.png")
    for name, img in (("left.png", left), ("right.png", right)):
        if (img.shape[1], img.shape[0]) != calib.image_size:
            raise InputError(
                f"{folder / name} is {img.shape[1]}x{img.shape[0]} but {folder / 'calib.yaml'} "
                f"says {calib.image_size[0]}x{calib.image_size[1]}"
            )
    truth = read_truth(folder / "truth.json") if (folder / "truth.json").is_file() else None
    return BenchScene(folder.name, calib, rig, left, right, truth)


def check_scene_truths(dirs: Iterable[Path]) -> None:
    """Check every ``truth.json`` before any work, so a bad one stops the run at once."""
    for d in dirs:
        if (d / "truth.json").is_file():
            read_truth(d / "truth.json")


def _score(result: dict[str, Any], truth: dict[str, Any] | None) -> SceneScore | None:
    return None if truth is None else score_result(result, truth)


def evaluate_scene(scene: BenchScene, config: PipelineConfig) -> SceneOutcome:
    """The first call of a new pipeline on ``scene``, scored (no timing)."""
    result = Pipeline(scene.calibration, scene.rig, config).run(scene.left, scene.right).to_json_dict()
    return SceneOutcome(scene.name, result, _score(result, scene.truth))


def time_scene(scene: BenchScene, config: PipelineConfig, repeat: int) -> SceneOutcome:
    """Time ``scene`` (see the module docstring) and score the first call's result."""
    from .stereo import default_max_disparity
    from .stereo.opencv import create_sgbm

    t0 = time.perf_counter()
    pipeline = Pipeline(scene.calibration, scene.rig, config)
    construct_ms = (time.perf_counter() - t0) * 1000.0
    t0 = time.perf_counter()
    first = pipeline.run(scene.left, scene.right)
    first_ms = (time.perf_counter() - t0) * 1000.0
    result = first.to_json_dict()
    # The reference: OpenCV 3-way with the pipeline's matching parameters, at the disparity
    # range of the calibration (not the pipeline's own choice), on the pair it matched.
    n = config.max_disparity_px or default_max_disparity(pipeline.rectification, config.min_depth_m)
    left, right = first.rectified.left, first.rectified.right
    matcher = create_sgbm(config.sgbm, n, mode="sgbm_3way", width=left.shape[1])
    matcher.compute(left, right)  # its own first call (allocations) is not timed
    frames: list[float] = []
    stages: dict[str, list[float]] = {}
    ref: list[float] = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        matcher.compute(left, right)
        ref.append((time.perf_counter() - t0) * 1000.0)
        timing = pipeline.run(scene.left, scene.right).timing_ms
        frames.append(timing["total"])
        for k, v in timing.items():
            stages.setdefault(k, []).append(v)
    timing_ = SceneTiming(construct_ms, first_ms, frames, stages, ref)
    return SceneOutcome(scene.name, result, _score(result, scene.truth), timing_)


def iter_bench(
    dirs: list[Path], config: PipelineConfig, repeat: int, *, timed: bool = True, use_rig: bool = True
) -> Iterator[SceneOutcome]:
    """Each scene folder's outcome in turn (scenes read one at a time; ``use_rig=False``:
    without their ``rig.yaml``)."""
    for d in dirs:
        scene = read_bench_scene(d, use_rig=use_rig)
        yield time_scene(scene, config, repeat) if timed else evaluate_scene(scene, config)


def _ray_evaluate(folder: str, config: dict[str, Any], use_rig: bool = True) -> dict[str, Any]:
    """A Ray task: read the scene on the worker, run it, return the JSON result."""
    scene = read_bench_scene(folder, use_rig=use_rig)
    return evaluate_scene(scene, PipelineConfig.from_dict(config)).result


def score_with_ray(
    dirs: list[Path],
    config: dict[str, Any],
    address: str | None = None,
    *,
    num_cpus: int = 2,
    on_done: Callable[[int, str], None] | None = None,
    use_rig: bool = True,
) -> list[SceneOutcome]:
    """Accuracy of every scene, computed by Ray tasks (one per scene).

    Parameters
    ----------
    dirs : list of Path
        Scene folders; the workers read them at the same absolute paths (a shared or
        copied folder on a cluster).
    config : dict
        The pipeline config as a mapping (:meth:`PipelineConfig.from_dict`).
    address : str, optional
        A running cluster (``ray://host:10001`` or ``host:6379``); None starts a local Ray
        with ``num_cpus`` workers, shut down again at the end.
    on_done : callable(done, name), optional
        Called as each scene finishes (a progress bar).
    use_rig : bool
        False: the scenes' ``rig.yaml`` files are not read (gravity from the scene).

    Returns
    -------
    list of SceneOutcome, in the order of ``dirs`` (no timing).
    """
    try:
        import ray
    except ImportError:
        raise InputError(
            "bench --ray needs the Python package 'ray', which is not installed: "
            "pip install 'stereo-terrain[ray]'"
        ) from None
    started = not ray.is_initialized()
    if started and address is not None:
        check_reachable(address)
    if started:
        src = str(Path(__file__).resolve().parents[1])  # workers import this very package
        env = {"env_vars": {"PYTHONPATH": src}}
        kwargs: dict[str, Any] = {"runtime_env": env, "include_dashboard": False, "log_to_driver": False}
        if address is None:
            kwargs["num_cpus"] = num_cpus
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, ValueError, RuntimeError) as exc:
            raise InputError(f"bench --ray: cannot connect to Ray at {address}: {exc}") from None
    try:
        task = ray.remote(num_cpus=1)(_ray_evaluate)
        pending = {task.remote(str(d.resolve()), config, use_rig): i for i, d in enumerate(dirs)}
        results: list[dict[str, Any] | None] = [None] * len(dirs)
        done = 0
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            i = pending.pop(ready[0])
            results[i] = ray.get(ready[0])
            done += 1
            if on_done is not None:
                on_done(done, dirs[i].name)
    finally:
        if started:
            ray.shutdown()
    outcomes = []
    for d, res in zip(dirs, results, strict=True):
        assert res is not None
        truth = read_truth(d / "truth.json") if (d / "truth.json").is_file() else None
        outcomes.append(SceneOutcome(d.name, res, _score(res, truth)))
    return outcomes


def check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Refuse at once a Ray address (``host:port`` or ``ray://host:port``) that nothing
    answers on (``ray.init`` would retry for minutes); other forms (``auto``) are left to
    Ray."""
    import socket

    hostport = address.removeprefix("ray://")
    host, sep, port = hostport.rpartition(":")
    if not sep or not port.isdigit():
        return
    try:
        socket.create_connection((host or "localhost", int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise InputError(f"bench --ray: nothing answers at {address} ({exc.strerror or exc})") from None


def _median(values: list[float]) -> float | None:
    return float(statistics.median(values)) if values else None


def _percentile(values: list[float], q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def _finite(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def accuracy_summary(outcomes: list[SceneOutcome]) -> dict[str, float | None]:
    """Detection rate, step-count accuracy and rise error (cm) over the scenes with a
    truth, as :func:`stereo_terrain.evaluation.summarize` computes them (None where
    nothing was measured)."""
    s = summarize([o.score for o in outcomes if o.score is not None])

    def cm(x: float) -> float | None:
        v = _finite(x)
        return None if v is None else v * 100.0

    return {
        "detection_rate": _finite(s["detection_rate"]),
        "step_count_accuracy": _finite(s["count_rate"]),
        "rise_err_median_cm": cm(s["rise_median_m"]),
        "rise_err_p90_cm": cm(s["rise_p90_m"]),
    }


def bench_summary(outcomes: list[SceneOutcome], *, rigs_read: bool = True) -> dict[str, Any]:
    """The ``bench --json`` document (the shape of issue 13, and ``rigs_read``: whether
    the scenes' ``rig.yaml`` files were read, false with ``--no-rig``). Timing statistics
    pool the warm frames of all scenes; ``first_frame_ms`` is the median over scenes;
    timing values are null when not measured."""
    timed = [o.timing for o in outcomes if o.timing is not None]
    frames = [f for t in timed for f in t.frames_ms]
    stages: dict[str, float | None] = {}
    for k in STAGES:
        stages[k] = _median([v for t in timed for v in t.stages_ms.get(k, [])])
    rematched = sum(len(t.stages_ms.get("rematch", [])) for t in timed)
    return {
        "scenes": len(outcomes),
        "frame_ms": {"median": _median(frames), "p90": _percentile(frames, 90)},
        "first_frame_ms": {"median": _median([t.first_frame_ms for t in timed])},
        "stages_ms": stages,
        "opencv_sgbm_3way_ms": {"median": _median([v for t in timed for v in t.opencv_3way_ms])},
        "ratio_to_opencv_3way": {"median": _median([r for t in timed for r in t.ratios])},
        # Share of the warm frames that ran the rematch (null when nothing was timed).
        "rematch_share": rematched / len(frames) if frames else None,
        "accuracy": accuracy_summary(outcomes),
        "rigs_read": rigs_read,
    }


def _f(x: float | None, fmt: str = "{:.1f}") -> str:
    return "-" if x is None else fmt.format(x)


def bench_table(outcomes: list[SceneOutcome], summary: dict[str, Any]) -> list[str]:
    """Markdown table lines: one row per scene, then the summary."""
    lines = [
        "| scene | first ms | frame ms | 3-way ms | ratio | obstacle (truth) | steps (truth) | rise err cm |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for o in outcomes:
        t = o.timing
        truth_obstacle = "?"
        truth_steps = "?"
        rise = None
        if o.score is not None:
            truth_obstacle = "yes" if o.score.has_obstacle else "none"
            rise = _median([e * 100.0 for e in o.score.rise_errors_m])
            truth_steps = "right" if o.score.count_right else "wrong"
        lines.append(
            f"| {o.name} | {_f(None if t is None else t.first_frame_ms)} | "
            f"{_f(None if t is None else _median(t.frames_ms))} | "
            f"{_f(None if t is None else _median(t.opencv_3way_ms))} | "
            f"{_f(None if t is None else _median(t.ratios), '{:.2f}')} | "
            f"{o.result['obstacle']} ({truth_obstacle}) | {len(o.result['steps'])} ({truth_steps}) | "
            f"{_f(rise, '{:.2f}')} |"
        )
    acc = summary["accuracy"]
    fm = summary["frame_ms"]
    lines += [
        "",
        f"scenes {summary['scenes']}: frame median {_f(fm['median'])} ms (p90 {_f(fm['p90'])}, "
        f"{_f(None if not fm['median'] else 1000.0 / fm['median'], '{:.0f}')} Hz), "
        f"first frame {_f(summary['first_frame_ms']['median'])} ms, "
        f"OpenCV 3-way alone {_f(summary['opencv_sgbm_3way_ms']['median'])} ms, "
        f"ratio {_f(summary['ratio_to_opencv_3way']['median'], '{:.2f}')}",
        "stages (median ms): "
        + ", ".join(f"{k} {_f(v)}" for k, v in summary["stages_ms"].items() if v is not None)
        + (
            f" (the rematch in {summary['rematch_share']:.0%} of the frames)"
            if summary.get("rematch_share")
            else ""
        ),
        f"accuracy: detected {_f(acc['detection_rate'], '{:.0%}')}, step count right "
        f"{_f(acc['step_count_accuracy'], '{:.0%}')}, rise error median "
        f"{_f(acc['rise_err_median_cm'], '{:.2f}')} cm, p90 {_f(acc['rise_err_p90_cm'], '{:.2f}')} cm",
    ]
    return lines
