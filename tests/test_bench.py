"""``stereo-terrain bench``: its JSON summary, accuracy as ``evaluation`` scores it, errors,
the Ray path, and the pipeline's kernel warm-up (no timed assertions)."""

import dataclasses
import json
import math
import subprocess
import sys

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereo_terrain.bench import (
    accuracy_summary,
    bench_summary,
    check_truth,
    iter_bench,
    read_bench_scene,
    scene_dirs,
)
from stereo_terrain.errors import InputError
from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.synthetic import render_scenes

from .cli_run import run_cli

KEYS = {
    "scenes",
    "frame_ms",
    "first_frame_ms",
    "stages_ms",
    "opencv_sgbm_3way_ms",
    "ratio_to_opencv_3way",
    "accuracy",
    "rigs_read",
    "rematch_share",
}
ACCURACY_KEYS = {"detection_rate", "step_count_accuracy", "rise_err_median_cm", "rise_err_p90_cm"}


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """Three small rendered scenes (two staircases and whatever the third draws)."""
    root = tmp_path_factory.mktemp("bench")
    render_scenes(root, 3, seed=5, image_size=(320, 240))
    return root


def _evaluation_accuracy(root, use_rig=True):
    """What ``evaluation`` says of a fresh pipeline's first call on each scene."""
    scores = []
    for d in scene_dirs(root):
        s = read_bench_scene(d)
        result = Pipeline(s.calibration, s.rig if use_rig else None).run(s.left, s.right).to_json_dict()
        scores.append(score_result(result, json.loads((d / "truth.json").read_text())))
    return summarize(scores)


def test_bench_json_has_the_issue_shape_and_the_evaluation_accuracy(scenes, tmp_path, capsys):
    out = tmp_path / "bench.json"
    code, text, err = run_cli(["bench", scenes, "--repeat", "2", "--json", out], capsys)
    assert code == 0, err
    data = json.loads(out.read_text())
    assert set(data) == KEYS
    assert data["scenes"] == 3 and data["rigs_read"] is True
    assert set(data["frame_ms"]) == {"median", "p90"}
    assert set(data["first_frame_ms"]) == {"median"}
    assert set(data["opencv_sgbm_3way_ms"]) == {"median"} and set(data["ratio_to_opencv_3way"]) == {"median"}
    assert {"rectify", "disparity", "cloud", "planes", "polytope", "total"} <= set(data["stages_ms"])
    assert data["frame_ms"]["p90"] >= data["frame_ms"]["median"] > 0
    assert data["stages_ms"]["total"] == pytest.approx(data["frame_ms"]["median"])
    # The rematch (PipelineConfig.rematch): its median time where it ran, and how often.
    assert 0.0 <= data["rematch_share"] <= 1.0
    assert (data["stages_ms"]["rematch"] is None) == (data["rematch_share"] == 0.0)
    assert set(data["accuracy"]) == ACCURACY_KEYS
    ref = _evaluation_accuracy(scenes)
    acc = data["accuracy"]
    assert acc["detection_rate"] == pytest.approx(ref["detection_rate"])
    assert acc["step_count_accuracy"] == pytest.approx(ref["count_rate"])
    for key, ref_key in (("rise_err_median_cm", "rise_median_m"), ("rise_err_p90_cm", "rise_p90_m")):
        if math.isnan(ref[ref_key]):
            assert acc[key] is None
        else:
            assert acc[key] == pytest.approx(100.0 * ref[ref_key])
    # The table: one row per scene and the summary lines.
    assert sum(line.startswith("| scene_") for line in text.splitlines()) == 3
    assert "ratio" in text and "accuracy:" in text


def test_bench_without_the_rigs_scores_gravity_from_the_scene(scenes, capsys):
    code, text, err = run_cli(["bench", scenes, "--repeat", "1", "--no-rig", "--json", "-"], capsys)
    assert code == 0, err
    data = json.loads(text)
    assert data["rigs_read"] is False
    acc, ref = data["accuracy"], _evaluation_accuracy(scenes, use_rig=False)
    assert acc["detection_rate"] == pytest.approx(ref["detection_rate"])
    assert acc["step_count_accuracy"] == pytest.approx(ref["count_rate"])
    (outcome,) = list(iter_bench([scenes / "scene_000"], PipelineConfig(), 1, timed=False, use_rig=False))
    assert outcome.result["gravity_source"] == "scene"
    assert read_bench_scene(scenes / "scene_000").rig is not None  # the folder has one
    # What a Ray worker runs for `bench --ray --no-rig` (without Ray).
    from stereo_terrain.bench import _ray_evaluate

    worker = _ray_evaluate(str(scenes / "scene_000"), dataclasses.asdict(PipelineConfig()), False)
    assert worker["gravity_source"] == "scene" and worker["steps"] == outcome.result["steps"]


def test_bench_json_to_stdout_is_json_only(scenes, capsys):
    code, text, err = run_cli(["bench", scenes / "scene_000", "--repeat", "1", "--json", "-"], capsys)
    assert code == 0, err
    assert json.loads(text)["scenes"] == 1


def test_summary_without_truth_or_timing_is_null_not_nan(scenes):
    (outcome,) = list(iter_bench([scenes / "scene_000"], PipelineConfig(), 1, timed=False))
    outcome = dataclasses.replace(outcome, score=None)
    summary = bench_summary([outcome])
    assert summary["frame_ms"] == {"median": None, "p90": None}
    assert all(v is None for v in summary["accuracy"].values())
    json.dumps(summary, allow_nan=False)


def test_bench_errors_are_one_line_exit_2(scenes, tmp_path, capsys):
    code, _, err = run_cli(["bench", tmp_path / "missing"], capsys)
    assert code == 2 and "does not exist" in err and len(err.strip().splitlines()) == 1
    bad = tmp_path / "bad"
    (bad / "scene_a").mkdir(parents=True)
    (bad / "scene_a" / "left.png").write_bytes((scenes / "scene_000" / "left.png").read_bytes())
    code, _, err = run_cli(["bench", bad], capsys)
    assert code == 2 and "right.png, calib.yaml" in err and len(err.strip().splitlines()) == 1
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in ("left.png", "right.png", "calib.yaml", "rig.yaml"):
        (broken / name).write_bytes((scenes / "scene_000" / name).read_bytes())
    for text, words in (
        ("{not json", "not valid JSON"),
        ('{"obstacle": "ramp", "steps": []}', "'obstacle'"),
        ('{"obstacle": "stairs", "steps": [{"rise": "high", "distance": 1}]}', "steps[0].rise"),
    ):
        (broken / "truth.json").write_text(text)
        out = tmp_path / "o.json"
        code, _, err = run_cli(["bench", broken, "--json", out], capsys)
        assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err
        assert not out.exists()


_JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


@given(
    st.one_of(
        _JSON,
        st.fixed_dictionaries(
            {
                "obstacle": st.sampled_from(["stairs", "box", "none", "x"]),
                "steps": st.lists(_JSON, max_size=3),
            }
        ),
    )
)
def test_check_truth_accepts_or_raises_input_error(data):
    try:
        assert check_truth(data, "truth.json") is data
    except InputError as exc:
        assert "truth.json" in str(exc)


def test_pipeline_construction_warms_every_kernel_its_stages_use():
    """In a fresh process: after ``Pipeline(...)`` (no frame run yet) every Numba kernel of
    the fill, cloud, plane and MSAC stages has a compiled signature."""
    code = """
from stereo_terrain.pipeline import Pipeline, PipelineConfig, _warm_up_scene
from stereo_terrain.msac import _kernels as mk
from stereo_terrain.planes import _kernels as pk
from stereo_terrain import _cloud_kernels as ck
from stereo_terrain.stereo import _regions as rk
from stereo_terrain.terrain import _kernels as tk
from stereo_terrain.stereo import _disparity_kernels as dk
from stereo_terrain.gravity import _kernels as gk
calib, rig, left, right = _warm_up_scene()
Pipeline(calib, rig, PipelineConfig(method="auto"))
# (the orientation method's scoring, inliers, refinement and triplets run inside oriented_round)
names = ["msac_costs"], ["region_msac", "oriented_round"], ["grid_cells_normals"], ["_label_stats"], [
    "riser_edge_slices"], ["disparity_from_fixed_point"], [
    "truncated_family_error_sums", "floor_inlier_counts"]
mods = (mk, pk, ck, rk, tk, dk, gk)
cold = [n for mod, ns in zip(mods, names) for n in ns if not getattr(mod, n).signatures]
print("cold:", cold)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "cold: []" in out.stdout, out.stdout


def _bench_in_a_process(argv: list[str]) -> subprocess.CompletedProcess:
    """``stereo-terrain ARGV`` in a process of its own, which prints whether Ray is still
    initialised when the command returns. Ray's client leaves gRPC threads behind in the
    process that started it; run in the test process, they stayed for every later test
    (one later run hung starting a thread)."""
    code = (
        "import sys, ray\n"
        "from stereo_terrain.cli import main\n"
        f"code = main({[str(a) for a in argv]!r})\n"
        "print('ray initialised after:', ray.is_initialized())\n"
        "sys.exit(code)\n"
    )
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)


def test_an_unreachable_ray_address_is_one_line_exit_2(scenes):
    import socket

    pytest.importorskip("ray", reason="the ray extra is not installed")
    with socket.socket() as s:  # a port nothing listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = _bench_in_a_process(["bench", scenes, "--ray", f"127.0.0.1:{port}"])
    err = out.stderr
    assert out.returncode == 2 and "nothing answers" in err and len(err.strip().splitlines()) == 1, err


def test_bench_ray_cli_reports_accuracy_and_no_timing(scenes, tmp_path):
    pytest.importorskip("ray", reason="the ray extra is not installed")
    out = tmp_path / "ray.json"
    run = _bench_in_a_process(["bench", scenes, "--ray", "--json", out])
    assert run.returncode == 0, run.stderr
    text = run.stdout
    data = json.loads(out.read_text())
    assert set(data) == KEYS and data["scenes"] == 3
    assert data["frame_ms"]["median"] is None and data["ratio_to_opencv_3way"]["median"] is None
    assert "ray initialised after: False" in text  # the local Ray it started is shut down again
    local = list(iter_bench(scene_dirs(scenes), PipelineConfig(), 1, timed=False))
    assert data["accuracy"] == accuracy_summary(local)  # the same numbers as the local run
    assert "timing is measured only without --ray" in text


@pytest.mark.filterwarnings("ignore:This process .* is multi-threaded:DeprecationWarning")
def test_a_forked_child_runs_the_pipeline(scenes):
    """The fill's worker thread does not survive a fork: a child must get its own (with the
    parent's executor it would wait forever)."""
    import multiprocessing

    s = read_bench_scene(scenes / "scene_000")
    pipeline = Pipeline(s.calibration, s.rig)
    expected = pipeline.run(s.left, s.right).to_json_dict()["steps"]  # the parent's thread exists now
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=lambda: send.send(pipeline.run(s.left, s.right).to_json_dict()["steps"]))
    child.start()
    try:
        assert receive.poll(120), "the forked child did not finish its frame"
        assert receive.recv() == expected
    finally:
        child.join(10)
        if child.is_alive():
            child.kill()


def test_a_truth_without_a_yaw_scores_no_yaw_error():
    """``check_truth`` lets ``"yaw": null`` through; the score then has no yaw error (it
    was ``float(None)``, an internal error from ``bench``)."""
    from stereo_terrain.evaluation import score_result

    step = {"rise": 0.2, "run": 0.3, "distance": 1.5, "width": 1.0}
    result = {"obstacle": "stairs", "steps": [step], "yaw": 0.1}
    for truth_yaw in (None, 0.05):
        truth = check_truth({"obstacle": "stairs", "steps": [step], "yaw": truth_yaw}, "truth.json")
        score = score_result(result, truth)
        assert score.detected and score.rise_errors_m == [0.0]
        assert (score.yaw_error_rad is None) == (truth_yaw is None)
