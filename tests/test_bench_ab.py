"""benchmarks/bench_ab.py, the A/B tool of issue 11's measurements: a capture and its
comparison end to end on one rendered scene, and its errors in one line."""

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_ab.py"


def _run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300, cwd=cwd
    )


def _as_result(true_step: dict) -> dict:
    """A truth's step as a result reports it."""
    extra = ("measured_rise", "measured_run", "rise_sigma", "run_sigma", "distance_sigma", "width_sigma")
    return dict(true_step, rise_inferred=False, position_inferred=False, **dict.fromkeys(extra))


def test_a_capture_compared_with_itself_and_with_its_counts_turned_over(tmp_path):
    out = tmp_path / "lab.jsonl"
    done = _run("capture", "lab:77:1", str(out))
    assert done.returncode == 0, done.stderr
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    assert [x["key"] for x in lines] == ["0 rig", "0 no rig"]
    assert all(x["truth"]["obstacle"] == "stairs" and "timing_ms" not in x["result"] for x in lines)
    assert not list(tmp_path.glob("*.part"))
    same = _run("compare", str(out), str(out))
    assert same.returncode == 0, same.stderr
    assert "| rig | before |" in same.stdout and "0 of 2 runs changed" in same.stdout
    assert "yaw deg median / p90 |" in same.stdout
    assert "Step count, rig, scene by scene: 0 made right, 0 made wrong." in same.stdout
    # each run's count turned over: a right one reports nothing, a wrong one the truth's steps
    right = {x["key"]: len(x["result"]["steps"]) == len(x["truth"]["steps"]) for x in lines}
    turned = [
        dict(x, result=dict(x["result"], obstacle="none", steps=[]))
        if right[x["key"]]
        else dict(
            x, result=dict(x["result"], obstacle="stairs", steps=[_as_result(t) for t in x["truth"]["steps"]])
        )
        for x in lines
    ]
    (tmp_path / "turned.jsonl").write_text("".join(json.dumps(x) + "\n" for x in turned))
    both = _run("compare", str(out), str(tmp_path / "turned.jsonl"))
    assert both.returncode == 0, both.stderr
    for mode in ("rig", "no rig"):
        was = [right[x["key"]] for x in lines if x["mode"] == mode]
        said = f"{mode}, scene by scene: {was.count(False)} made right, {was.count(True)} made wrong."
        assert f"Step count, {said}" in both.stdout
    assert both.stdout.count("[count made wrong]") == sum(right.values())
    assert both.stdout.count("[count made right]") == len(right) - sum(right.values())


def test_a_run_whose_reported_rises_alone_changed_is_listed(tmp_path):
    """A common rise taken otherwise changes the rises a run reports, not its measured
    ones: the run is listed, with both."""
    truth = {"obstacle": "stairs", "steps": [{"rise": 0.17, "run": 0.3, "distance": 1.0, "width": 1.0}] * 2}
    own = [_as_result(dict(t, rise=r)) for t, r in zip(truth["steps"], (0.12, 0.22), strict=True)]
    pooled = [dict(s, rise=0.17, measured_rise=s["rise"]) for s in own]
    for name, steps in (("own", own), ("pooled", pooled)):
        line = {
            "key": "0 rig",
            "mode": "rig",
            "truth": truth,
            "result": {"obstacle": "stairs", "steps": steps},
        }
        (tmp_path / f"{name}.jsonl").write_text(json.dumps(line) + "\n")
    done = _run("compare", str(tmp_path / "own.jsonl"), str(tmp_path / "pooled.jsonl"))
    assert done.returncode == 0, done.stderr
    assert "1 of 1 runs changed" in done.stdout
    assert "stairs [12.0, 22.0] -> stairs [12.0, 22.0] (reported [12.0, 22.0] -> [17.0, 17.0])" in done.stdout


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (("capture", "stairs:1:2", "x.jsonl"), "unknown set 'stairs'"),
        (("capture", "lab:77", "x.jsonl"), "give lab:SEED:N"),
        (("compare", "missing.jsonl", "missing.jsonl"), "no such capture"),
        (("compare", "garbage.jsonl", "garbage.jsonl"), "not a capture"),
        (("compare", "empty.jsonl", "empty.jsonl"), "holds no runs"),
    ],
)
def test_bad_arguments_get_one_line_and_exit_2(tmp_path, args, says):
    (tmp_path / "garbage.jsonl").write_text("not json\n")
    (tmp_path / "empty.jsonl").write_text("")
    done = _run(*args, cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert says in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "x.jsonl").exists()


def _bench_ab():
    """The script, imported as a module."""
    spec = importlib.util.spec_from_file_location("bench_ab", SCRIPT)
    assert spec is not None and spec.loader is not None
    bench_ab = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench_ab)
    return bench_ab


def test_the_landings_set_draws_short_landings_ending_at_a_wall():
    ((_, scene),) = list(_bench_ab()._rendered("landings", 5, 1))
    stairs = scene.truth["spec"]["obstacle"]
    assert 0.25 <= stairs["landing_m"] <= 0.45
    planes = {p["name"]: p for p in scene.truth["planes"]}
    last = planes[f"riser_{stairs['n_steps']}"]["offset"]
    assert planes["back_wall"]["offset"] == pytest.approx(last + stairs["landing_m"], abs=0.01)


def test_the_far_set_draws_the_oakd_staircases_of_bench_far_stairs():
    """``far:SEED:N`` is ``bench_far_stairs.py --oakd``'s draw: stairs 2-4 m ahead, a
    7.5 cm baseline, an OAK-D's sensor (no JPEG, both images alike)."""
    scenes = [scene for _, scene in _bench_ab()._rendered("far", 77, 2)]
    for scene in scenes:
        spec = scene.truth["spec"]
        assert 2.0 <= spec["obstacle"]["distance_m"] <= 4.0
        assert spec["baseline_m"] == pytest.approx(0.075)
        assert spec["jpeg_quality"] is None and spec["blur_sigma_px"] == spec["right_blur_sigma_px"]
    first, second = (scene.truth["spec"]["obstacle"]["distance_m"] for scene in scenes)
    assert first != second


def test_a_reader_that_leaves_early_gets_no_traceback(tmp_path):
    """``compare ... | head`` : the reader closes the pipe after a line; the script stops
    quietly (exit status 0, nothing on stderr) instead of a BrokenPipeError traceback."""
    out = tmp_path / "lab.jsonl"
    assert _run("capture", "lab:77:1", str(out)).returncode == 0
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    many = [dict(x, key=f"{i} {x['mode']}") for i in range(2000) for x in lines]
    gone = [dict(x, result=dict(x["result"], obstacle="none", steps=[])) for x in many]
    before, after = tmp_path / "before.jsonl", tmp_path / "after.jsonl"
    before.write_text("".join(json.dumps(x) + "\n" for x in many))
    after.write_text("".join(json.dumps(x) + "\n" for x in gone))
    proc = subprocess.Popen(
        [sys.executable, str(SCRIPT), "compare", str(before), str(after)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    with proc.stdout, proc.stderr:
        first = proc.stdout.readline()
        proc.stdout.close()
        err = proc.stderr.read().decode()
        status = proc.wait(timeout=300)
    assert first.startswith(b"| gravity from |")
    assert status == 0, err
    assert "Traceback" not in err
