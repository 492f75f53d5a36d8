"""Two versions of the pipeline's results side by side, scene by scene (issue 11).

A change to a stage is judged on everything it changes: the rendered staircases it finds
or loses, the real rooms where it makes or removes a false step, the real `Staircase` runs
it keeps or loses. ``capture`` runs the pipeline (default settings, or ``--config``) on one
set of scenes and writes one JSON line per run: the result without its timings (its steps'
``measured_rise`` and ``measured_run`` where they report the staircase's common ones), the
note, and the truth where there is one. ``compare`` reads two captures of the same set and
prints the issue's columns for each (and the stair axis's error, deg, where an obstacle is
found: the direction the robot turns to), on rendered sets how many step counts the change made
right and made wrong scene by scene (a rate's change hides wins cancelled by losses: on
the lab-like seeds any change moves a third of the runs), and the runs whose result
changed, those whose count it made right or wrong marked so. A run's steps are listed with
their measured rises (``*`` inferred); where only the rises it reports changed (a common
rise taken otherwise), those are added.
Another version of the package (a worktree, a patched copy) is captured by putting its
``src`` first on ``PYTHONPATH``; the captures themselves are compared here.

    .venv/bin/python benchmarks/bench_ab.py capture SET OUT.jsonl [--config CFG.yaml] [--rig-only]
    .venv/bin/python benchmarks/bench_ab.py compare BEFORE.jsonl AFTER.jsonl

Sets (every rendered scene is run with its true rig and without one; ``--rig-only``, a
change that only the rig's runs see, with its rig alone):

- ``realistic:SEED:N``, ``default:SEED:N``: the profile's own mix of staircases, boxes
  and empty views, as ``random_scene_spec(rng, profile=...)`` draws them from ``SEED``;
- ``boxes:SEED:N``: realistic boxes;
- ``landings:SEED:N``: realistic staircases whose landing is short (0.25-0.45 m) with a
  wall at its end: the wall stands in the image of the riser a step beyond the top would
  have, where the terrain stage asks whether a landing goes on;
- ``lab:SEED:N``: the wooden lab stairs of ``bench_far_stairs.py --lab``;
- ``far:SEED:N``: the OAK-D-like stairs 2-4 m ahead of ``bench_far_stairs.py --oakd``
  (the same draws for the same seed);
- ``rooms:SEEDS``: the 11 real rooms without stairs at webcam quality
  (``bench_staircase_webcam.py --rooms``'s degradations, ``SEEDS`` noise seeds a row);
- ``staircase:SEEDS``: the real Middlebury `Staircase` at webcam quality (the same
  degradations; the issue's check on reported and measured rises).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_far_stairs import lab_spec, oakd_spec  # noqa: E402
from bench_real_stairs import real_pairs  # noqa: E402
from bench_staircase_webcam import _degraded_pairs, passes  # noqa: E402


def _fail(message: str) -> NoReturn:
    """One line on stderr and exit status 2 (a bad input, as the package's commands)."""
    print(f"bench_ab.py: {message}", file=sys.stderr)
    sys.exit(2)


def _record(result, **extra: Any) -> dict[str, Any]:
    """One run's line: the result without its timings (which holds each step's measured
    rise and run where it reports the staircase's common ones), its note."""
    data = result.to_json_dict()
    data.pop("timing_ms", None)
    return {**extra, "result": data, "note": result.terrain.note}


def _measured(line: dict[str, Any]) -> list[tuple[float, float | None, bool]]:
    """Each step's own rise and run (``measured_rise``, ``measured_run`` where it reports
    the common ones) and whether it was inferred."""
    return [
        (
            s["rise"] if s["measured_rise"] is None else s["measured_rise"],
            s["run"] if s["measured_run"] is None else s["measured_run"],
            s["rise_inferred"] or s["position_inferred"],
        )
        for s in line["result"]["steps"]
    ]


def _short_landing(spec: Any, rng: np.random.Generator) -> Any:
    """``spec`` (a staircase) with a landing of 0.25-0.45 m and a back wall at its end."""
    from stereo_terrain.synthetic.spec import _obstacle_far_end

    stairs = dataclasses.replace(spec.obstacle, landing_m=float(rng.uniform(0.25, 0.45)))
    return dataclasses.replace(spec, obstacle=stairs, back_wall_m=_obstacle_far_end(stairs) + 1e-3)


def _rendered(kind: str, seed: int, n: int) -> Iterator[tuple[int, Any]]:
    """``(index, scene)`` of a rendered set (module docstring)."""
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    rng = np.random.default_rng(seed)
    for i in range(n):
        if kind in ("realistic", "default"):
            spec = random_scene_spec(rng, profile=kind)
        elif kind == "boxes":
            spec = random_scene_spec(rng, profile="realistic", kind="box")
        elif kind == "landings":
            spec = _short_landing(random_scene_spec(rng, profile="realistic", kind="stairs"), rng)
        elif kind == "far":  # bench_far_stairs.py --oakd's draw
            spec = oakd_spec(rng)
        else:  # lab: bench_far_stairs.py --lab's draw
            spec = lab_spec(rng)
        yield i, render_scene(spec)


#: The sets and the arguments each takes after its name.
SETS = {
    "realistic": "SEED:N",
    "default": "SEED:N",
    "boxes": "SEED:N",
    "landings": "SEED:N",
    "lab": "SEED:N",
    "far": "SEED:N",
    "rooms": "SEEDS",
    "staircase": "SEEDS",
}


def parse_set(set_name: str) -> tuple[str, list[int]]:
    """``(kind, its integer arguments)`` of a set's name; ValueError naming the problem."""
    kind, *args = set_name.split(":")
    if kind not in SETS:
        raise ValueError(f"unknown set {kind!r}: one of {', '.join(SETS)}")
    want = SETS[kind].count(":") + 1
    try:
        numbers = [int(a) for a in args]
    except ValueError:
        numbers = []
    if len(numbers) != want or any(x < 0 for x in numbers):
        raise ValueError(f"give {kind}:{SETS[kind]} (whole numbers), got {set_name}")
    return kind, numbers


def _runs(
    kind: str, numbers: list[int], config: PipelineConfig, rig_only: bool = False
) -> Iterator[dict[str, Any]]:
    """Each run's line of a set (module docstring); ``rig_only``: a rendered scene's run
    with its rig alone."""
    if kind in ("rooms", "staircase"):
        from stereo_terrain.rectify import to_grey

        for name, calibration, left, right in real_pairs(kind == "rooms"):
            if (name == "Staircase") != (kind == "staircase") or name == "Classroom2":
                continue
            pipeline = Pipeline(calibration, None, config)
            for degradation, seed, lf, rt in _degraded_pairs(to_grey(left), to_grey(right), numbers[0]):
                yield _record(pipeline.run(lf, rt), key=f"{name} | {degradation} | {seed}", mode="no rig")
        return
    for i, scene in _rendered(kind, numbers[0], numbers[1]):
        for mode, rig in (("rig", scene.rig), ("no rig", None))[: 1 if rig_only else 2]:
            pipeline = Pipeline(scene.calibration, rig, config, warm_up=False)
            result = pipeline.run(scene.left, scene.right)
            yield _record(result, key=f"{i} {mode}", mode=mode, truth=scene.truth)


def capture(kind: str, numbers: list[int], out: Path, config: PipelineConfig, rig_only: bool = False) -> int:
    """Write the set's lines to ``out`` (through a temporary file: a capture cut short
    leaves none); how many runs. ``rig_only``: as :func:`_runs`."""
    tmp = out.with_name(out.name + ".part")
    count = 0
    try:
        with tmp.open("w") as fh:
            for line in _runs(kind, numbers, config, rig_only):
                fh.write(json.dumps(line) + "\n")
                count += 1
    except BaseException:  # (an interrupt too: no half-written capture is left)
        tmp.unlink(missing_ok=True)
        raise
    if count == 0:
        tmp.unlink()
        _fail("no real scenes under ../shared/data: the shared data folder is needed")
    tmp.replace(out)
    return count


def _read(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _steps(line: dict[str, Any]) -> str:
    """A run's result in one short string: its kind and measured rises (cm; * inferred)."""
    result = line["result"]
    if result["obstacle"] == "none":
        return "none"
    rises = ", ".join(f"{100 * rise:.1f}{'*' if inferred else ''}" for rise, _, inferred in _measured(line))
    return f"{result['obstacle']} [{rises}]"


def _reported(line: dict[str, Any]) -> str:
    """The rises a run reports (cm), where a staircase's common rise replaces measured ones."""
    return "[" + ", ".join(f"{100 * s['rise']:.1f}" for s in line["result"]["steps"]) + "]"


def _columns(lines: list[dict[str, Any]]) -> str:
    scores = [score_result(line["result"], line["truth"]) for line in lines]
    s = summarize(scores)
    # the stair axis's error where an obstacle is found (deg; a yaw's turn wrapped to +-180)
    yaw = np.degrees(
        [abs(math.remainder(x.yaw_error_rad, 2 * math.pi)) for x in scores if x.yaw_error_rad is not None]
    )
    yaw_cols = f"{np.median(yaw):.2f} / {np.percentile(yaw, 90):.2f}" if len(yaw) else "-"

    def pct(x: float) -> str:
        return "-" if x != x else f"{100 * x:.0f}%"

    def cm(a: float, b: float) -> str:
        return f"{100 * a:.2f} / {100 * b:.2f}"

    return (
        f"{pct(s['detection_rate'])} | {pct(s['count_rate'])} | {pct(s['false_positive_rate'])} | "
        f"{cm(s['rise_median_m'], s['rise_p90_m'])} | {cm(s['run_median_m'], s['run_p90_m'])} | {yaw_cols}"
    )


def _count_right(line: dict[str, Any]) -> bool:
    """Whether a rendered run's step count is the truth's (scenes without an obstacle
    count as right when nothing is reported)."""
    return bool(score_result(line["result"], line["truth"]).count_right)


def _staircase_check(line: dict[str, Any]) -> tuple[bool, bool]:
    """The issue's `Staircase` check on the reported and on the measured rises."""
    result = line["result"]
    if result["obstacle"] != "stairs":
        return False, False
    reported = [(s["rise"], s["run"]) for s in result["steps"]]
    measured = [(rise, run) for rise, run, _ in _measured(line)]
    return passes(reported), passes(measured)


def compare(before_path: Path, after_path: Path) -> None:
    before, after = _read(before_path), _read(after_path)
    if not before or not after:
        _fail(f"{before_path if not before else after_path} holds no runs: capture it again")
    # a rig-only capture (``--rig-only``) is compared on the runs it shares with the other
    modes = [{x["mode"] for x in lines} for lines in (before, after)]
    if modes[0] != modes[1]:
        shared = modes[0] & modes[1]
        before = [b for b in before if b["mode"] in shared]
        after = [a for a in after if a["mode"] in shared]
    if [b["key"] for b in before] != [a["key"] for a in after]:
        _fail("the two captures are not of the same set (their runs differ)")
    rendered = "truth" in before[0]
    # each run's step count right before and after (rendered sets), scored once
    counts = [
        (_count_right(b), _count_right(a)) if rendered else (True, True)
        for b, a in zip(before, after, strict=True)
    ]
    if rendered:
        print(
            "| gravity from | version | detected | step count | false pos. "
            "| rise cm median / p90 | run cm median / p90 | yaw deg median / p90 |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- | --- |")
        for mode in ("rig", "no rig"):
            if not any(x["mode"] == mode for x in before):
                continue
            for name, lines in (("before", before), ("after", after)):
                print(f"| {mode} | {name} | {_columns([x for x in lines if x['mode'] == mode])} |")
        print()
        for mode in ("rig", "no rig"):
            pairs = [c for c, b in zip(counts, before, strict=True) if b["mode"] == mode]
            if not pairs:
                continue
            won = sum(after_right and not before_right for before_right, after_right in pairs)
            lost = sum(before_right and not after_right for before_right, after_right in pairs)
            print(f"Step count, {mode}, scene by scene: {won} made right, {lost} made wrong.")
    else:
        for name, lines in (("before", before), ("after", after)):
            flagged = sum(x["result"]["obstacle"] != "none" for x in lines)
            print(f"{name}: {flagged} of {len(lines)} runs report an obstacle", end="")
            if all(x["key"].startswith("Staircase") for x in lines):
                checks = [_staircase_check(x) for x in lines]
                print(
                    f"; the issue's check passes on the reported rises in {sum(c[0] for c in checks)}, "
                    f"on the measured ones in {sum(c[1] for c in checks)}",
                    end="",
                )
            print()
    runs = [
        (b, a, _steps(b), _steps(a), _reported(b), _reported(a), c)
        for b, a, c in zip(before, after, counts, strict=True)
    ]
    changed = [r for r in runs if r[2] != r[3] or r[4] != r[5]]
    print(f"\n{len(changed)} of {len(before)} runs changed:")
    for b, _, steps_b, steps_a, reported_b, reported_a, (before_right, after_right) in changed:
        truth = b.get("truth")
        told = "" if truth is None else f" (truth: {truth['obstacle']}, {len(truth.get('steps', []))} steps)"
        flip = ""
        if before_right != after_right:
            flip = " [count made right]" if after_right else " [count made wrong]"
        reported = "" if reported_b == reported_a else f" (reported {reported_b} -> {reported_a})"
        print(f"- {b['key']}{told}: {steps_b} -> {steps_a}{reported}{flip}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    cap = sub.add_parser("capture", help="run one set of scenes and write its results")
    cap.add_argument(
        "set",
        help=(
            "realistic:SEED:N, default:SEED:N, boxes:SEED:N, landings:SEED:N, lab:SEED:N, "
            "far:SEED:N, rooms:SEEDS, staircase:SEEDS"
        ),
    )
    cap.add_argument("out", type=Path, help="JSON lines file to write")
    cap.add_argument("--config", type=Path, help="pipeline config YAML (default settings without)")
    cap.add_argument(
        "--rig-only",
        action="store_true",
        help=(
            "rendered sets: only the runs with the scene's rig (half the time; "
            "compare takes the runs both share)"
        ),
    )
    cmp = sub.add_parser("compare", help="compare two captures of the same set")
    cmp.add_argument("before", type=Path)
    cmp.add_argument("after", type=Path)
    args = ap.parse_args()
    if args.command == "capture":
        try:
            kind, numbers = parse_set(args.set)
        except ValueError as e:
            ap.error(str(e))
        config = PipelineConfig.from_yaml(args.config) if args.config else PipelineConfig()
        print(f"{capture(kind, numbers, args.out, config, args.rig_only)} runs written to {args.out}")
    else:
        for path in (args.before, args.after):
            if not path.is_file():
                _fail(f"{path}: no such capture (write one with: bench_ab.py capture SET {path})")
        try:
            compare(args.before, args.after)
        except BrokenPipeError:  # the reader left (``| head``): nothing more to print, no traceback
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (json.JSONDecodeError, KeyError, UnicodeDecodeError) as e:
            _fail(f"not a capture of bench_ab.py ({type(e).__name__}: {e}); capture both again")


if __name__ == "__main__":
    main()
