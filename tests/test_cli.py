"""The command line: success paths and one-line, exit-2 errors for user mistakes."""

import json
import subprocess
import sys

import numpy as np
import pytest

from stereo_terrain.cli import main
from stereo_terrain.synthetic import default_scene_spec, render_scene, write_scene

from .cli_run import run_cli


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    return write_scene(render_scene(default_scene_spec()), tmp_path_factory.mktemp("scene") / "s")


def _reconstruct_args(d, *extra):
    return ["reconstruct", d / "left.png", d / "right.png", "--calib", d / "calib.yaml", *extra]


def test_reconstruct_writes_the_json_contract(scene_dir, tmp_path, capsys):
    out_json = tmp_path / "r.json"
    code, out, err = run_cli(
        _reconstruct_args(
            scene_dir, "--rig", scene_dir / "rig.yaml", "--json", out_json, "--plot", tmp_path / "r.png"
        ),
        capsys,
    )
    assert code == 0, err
    data = json.loads(out_json.read_text())
    assert data["version"] == 1 and data["frame"] == "yaw" and data["obstacle"] == "stairs"
    assert (tmp_path / "r.png").stat().st_size > 10_000
    assert "obstacle: stairs" in out


@pytest.mark.parametrize("method", ["contour", "auto"])
def test_reconstruct_method_is_reported(scene_dir, capsys, method):
    code, out, _ = run_cli(
        _reconstruct_args(scene_dir, "--rig", scene_dir / "rig.yaml", "--json", "-", "--method", method),
        capsys,
    )
    data = json.loads(out)
    assert code == 0 and data["plane_stage"]["method_requested"] == method
    assert data["plane_stage"]["method_used"] in ("orientation", "contour", "combined")
    assert data["plane_stage"]["reason"] and isinstance(data["plane_stage"]["parameters"], dict)


def test_reconstruct_json_to_stdout(scene_dir, capsys):
    code, out, _ = run_cli(
        _reconstruct_args(scene_dir, "--rig", scene_dir / "rig.yaml", "--json", "-"), capsys
    )
    assert code == 0 and json.loads(out)["obstacle"] == "stairs"


def test_render_writes_scenes(tmp_path, capsys):
    code, out, _ = run_cli(
        ["render", "--out", tmp_path, "--count", 2, "--seed", 3, "--size", "320x240"], capsys
    )
    assert code == 0
    for name in ("scene_000", "scene_001"):
        d = tmp_path / name
        assert {"left.png", "right.png", "calib.yaml", "rig.yaml", "truth.json"} <= {
            p.name for p in d.iterdir()
        }


def _assert_one_line_error(code, err, *words):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], lines[0]


def test_render_refuses_a_folder_with_earlier_scenes(tmp_path, capsys):
    """A second render would overwrite scene_000 and keep scene_001: one set of two renders."""
    out = tmp_path / "scenes"
    assert run_cli(["render", "--out", out, "--count", 2, "--seed", 3, "--size", "64x48"], capsys)[0] == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    code, stdout, err = run_cli(
        ["render", "--out", out, "--count", 1, "--seed", 9, "--size", "64x48"], capsys
    )
    _assert_one_line_error(code, err, "already holds rendered scenes", "scene_000", "new or empty folder")
    assert stdout == ""
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


def test_render_into_an_empty_or_new_folder(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("not a scene")  # no scene_NNN: nothing to mix
    for out in (tmp_path / "empty", tmp_path / "new" / "deeper", tmp_path / "other"):
        code, stdout, err = run_cli(["render", "--out", out, "--size", "64x48"], capsys)
        assert code == 0, err
        assert stdout.strip() == str(out / "scene_000") and (out / "scene_000" / "left.png").is_file()


def test_missing_image(scene_dir, tmp_path, capsys):
    code, _, err = run_cli(
        ["reconstruct", tmp_path / "nope.png", scene_dir / "right.png", "--calib", scene_dir / "calib.yaml"],
        capsys,
    )
    _assert_one_line_error(code, err, "not found", "nope.png")


def test_unreadable_image(scene_dir, tmp_path, capsys):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"\x89PNG garbage")
    code, _, err = run_cli(
        ["reconstruct", bad, scene_dir / "right.png", "--calib", scene_dir / "calib.yaml"], capsys
    )
    _assert_one_line_error(code, err, "cannot decode")


def test_size_mismatch(scene_dir, tmp_path, capsys):
    import cv2

    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((240, 320), np.uint8))
    code, _, err = run_cli(
        ["reconstruct", small, scene_dir / "right.png", "--calib", scene_dir / "calib.yaml"], capsys
    )
    _assert_one_line_error(code, err, "differ in size")
    code, _, err = run_cli(["reconstruct", small, small, "--calib", scene_dir / "calib.yaml"], capsys)
    _assert_one_line_error(code, err, "calibration is for 640x480")


def test_malformed_and_non_finite_calibration(scene_dir, tmp_path, capsys):
    bad = tmp_path / "calib.yaml"
    bad.write_text((scene_dir / "calib.yaml").read_text().replace("K1", "KX", 1))
    code, _, err = run_cli(_reconstruct_args(scene_dir)[:-1] + [bad], capsys)
    _assert_one_line_error(code, err, "K1")
    text = (scene_dir / "calib.yaml").read_text()
    start = text.index("data:", text.index("T:"))
    bad.write_text(text[:start] + "data: [ .nan, 0., 0. ]\n")
    code, _, err = run_cli(_reconstruct_args(scene_dir)[:-1] + [bad], capsys)
    _assert_one_line_error(code, err, "non-finite")


def test_non_invertible_rig(scene_dir, tmp_path, capsys):
    rig = tmp_path / "rig.yaml"
    rig.write_text("T_body_camera: [[0,0,0,0],[0,0,0,0],[0,0,0,0],[0,0,0,1]]\n")
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--rig", rig), capsys)
    _assert_one_line_error(code, err, "rotation")


def test_bad_config_and_disparity(scene_dir, tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("orientation: {angle_tol_deg: 100}\n")
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--config", cfg), capsys)
    _assert_one_line_error(code, err, "angle_tol_deg")
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--max-disparity", "50"), capsys)
    _assert_one_line_error(code, err, "multiple of 16")


def test_unwritable_output(scene_dir, tmp_path, capsys):
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--json", tmp_path / "no" / "dir" / "r.json"), capsys)
    _assert_one_line_error(code, err, "cannot write")


@pytest.mark.parametrize(
    "argv",
    [
        ["reconstruct"],
        ["frobnicate"],
        ["render", "--out", "x", "--count", "0"],
        ["render", "--out", "x", "--size", "big"],
        ["demo", "--bogus"],
        ["reconstruct", "l.png", "r.png", "--calib", "c.yaml", "--method", "hough"],
    ],
)
def test_usage_errors_are_one_line_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_console_script_runs_as_a_process(scene_dir):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "stereo_terrain.cli",
            "reconstruct",
            "missing.png",
            "missing.png",
            "--calib",
            str(scene_dir / "calib.yaml"),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1


def test_demo_runs(tmp_path, capsys):
    code, out, err = run_cli(["demo", "--out", tmp_path / "demo"], capsys)
    assert code == 0, err
    assert "recovered steps" in out and "swing plan" in out
    assert (tmp_path / "demo" / "demo.png").is_file() and (tmp_path / "demo" / "result.json").is_file()


def test_demo_figure_that_cannot_be_written_leaves_no_json(tmp_path, capsys, monkeypatch):
    """Found in review: ``demo`` whose figure failed (a full disk) left the JSON written
    before it. Every output or none: a new --out folder is removed again, an older JSON in
    an existing one is kept as it was, and no temporary file is left."""
    pytest.importorskip("matplotlib")
    import errno

    import stereo_terrain.viz.figure as viz_figure

    def fail(result, path, truth=None):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(viz_figure, "save_result_figure", fail)
    out = tmp_path / "demo"
    code, _, err = run_cli(["demo", "--out", out], capsys)
    assert code == 2 and "cannot write" in err and "demo.png" in err, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()
    out.mkdir()
    (out / "result.json").write_text("older result\n")
    code, _, err = run_cli(["demo", "--out", out], capsys)
    assert code == 2 and "No space left" in err, err
    assert sorted(p.name for p in out.iterdir()) == ["result.json"]
    assert (out / "result.json").read_text() == "older result\n"


def _calib_text(scene_dir):
    return (scene_dir / "calib.yaml").read_text()


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda t: "", "calibration"),
        (lambda t: "hello: [1, 2", "calibration"),
        (lambda t: t.replace("K1: !!opencv-matrix", 'K1: "hello"\nK1_old: !!opencv-matrix'), "K1"),
        (lambda t: t.replace("image_width: 640", "image_width: abc"), "image_width"),
    ],
)
def test_broken_opencv_calibrations(scene_dir, tmp_path, capsys, make, words):
    bad = tmp_path / "calib.yaml"
    bad.write_text(make(_calib_text(scene_dir)))
    code, _, err = run_cli(_reconstruct_args(scene_dir)[:-1] + [bad], capsys)
    _assert_one_line_error(code, err, words)


def test_baseline_in_millimetres_is_refused(scene_dir, tmp_path, capsys):
    from stereo_terrain.calibration import read_calibration, write_opencv_yaml

    c = read_calibration(scene_dir / "calib.yaml")
    import dataclasses

    bad = tmp_path / "mm.yaml"
    # Bypass validation to write what a careless user would.
    object.__setattr__(c, "T", c.T * 1000)
    write_opencv_yaml(c, bad)
    code, _, err = run_cli(_reconstruct_args(scene_dir)[:-1] + [bad], capsys)
    _assert_one_line_error(code, err, "millimetres")
    assert dataclasses.is_dataclass(c)


def test_plain_list_matrices_are_read(scene_dir, tmp_path):
    import re

    from stereo_terrain.calibration import read_calibration

    text = _calib_text(scene_dir)
    text = re.sub(r"T: !!opencv-matrix\n(?:   .*\n)*?   data: (\[[^\]]*\])", r"T: \1", text)
    p = tmp_path / "list.yaml"
    p.write_text(text)
    assert read_calibration(p).T.shape == (3,)


_MB_CAMS = "cam0=[500 0 320; 0 500 240; 0 0 1]\ncam1=[500 0 320; 0 500 240; 0 0 1]\n"


@pytest.mark.parametrize(
    "text, words",
    [
        (
            _MB_CAMS + "baseline=-\nwidth=640\nheight=480\n",
            "baseline",
        ),
        (
            _MB_CAMS + "baseline=-80\nwidth=640\nheight=480\n",
            "positive",
        ),
    ],
)
def test_broken_middlebury_calibrations(scene_dir, tmp_path, capsys, text, words):
    bad = tmp_path / "calib.txt"
    bad.write_text(text)
    code, _, err = run_cli(_reconstruct_args(scene_dir)[:-1] + [bad], capsys)
    _assert_one_line_error(code, err, words)


def test_negative_stereodemo_baseline(scene_dir, tmp_path, capsys):
    bad = tmp_path / "c.json"
    bad.write_text(
        '{"width": 640, "height": 480, "baseline_meters": -0.075, "fx": 450, "fy": 450, '
        '"cx0": 320, "cx1": 320, "cy": 240}'
    )
    code, _, err = run_cli(_reconstruct_args(scene_dir)[:-1] + [bad], capsys)
    _assert_one_line_error(code, err, "positive")


@pytest.mark.parametrize(
    "text, words",
    [
        ("min_depth_m: abc\n", "min_depth_m"),
        ("sgbm: {block_size_px: 4.5}\n", "block_size_px"),
        ("fill: {ring_px: -1}\n", "ring_px"),
        ("orientation: {max_rounds: 0}\n", "max_rounds"),
        ("terrain: {min_riser_points: abc}\n", "min_riser_points"),
        ("sgbm: 3\n", "mapping"),
    ],
)
def test_bad_config_values(scene_dir, tmp_path, capsys, text, words):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(text)
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--config", cfg), capsys)
    _assert_one_line_error(code, err, words)


def test_config_that_is_a_directory(scene_dir, tmp_path, capsys):
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--config", tmp_path), capsys)
    _assert_one_line_error(code, err, "config file")


def test_rig_error_message_said_once(scene_dir, tmp_path, capsys):
    rig = tmp_path / "rig.yaml"
    rig.write_text("T_body_camera: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\nbody_rpy: [0, 0]\n")
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--rig", rig), capsys)
    _assert_one_line_error(code, err, "body_rpy")
    assert err.count("rig file") == 1


@pytest.mark.parametrize(
    ("yaml_text", "match"),
    [
        ("contour: {seed: -5}", "seed"),
        ("drift: {lk_window_px: 100000}", "lk_window_px"),
        ("drift: {lk_window_px: 4}", "lk_window_px"),
        ("sgm: {speckle_window_px: 100000000000000000000000}", "speckle_window_px"),
        ("cloud: {max_depth_m: 1e1}", "write it as 1.0e-3"),
        ("contour: {max_hypotheses: 100000000}", "max_hypotheses"),
        ("contour: {min_area_frac: 2.0}", "min_area_frac"),
        ("terrain: {max_facing_angle_deg: 500}", "max_facing_angle_deg"),
    ],
)
def test_out_of_range_config_values_are_one_line_errors(scene_dir, tmp_path, capsys, yaml_text, match):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml_text + "\n")
    code, _, err = run_cli(_reconstruct_args(scene_dir, "--config", cfg), capsys)
    assert code == 2 and match in err and len(err.strip().splitlines()) == 1


def test_figure_format_is_checked_before_running(scene_dir, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in _reconstruct_args(scene_dir, "--plot", tmp_path / "p.txt")])
    assert exc.value.code == 2 and "a figure must end in one of" in capsys.readouterr().err
