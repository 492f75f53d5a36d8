"""record | run | replay | simulate on the command line: success paths and one-line errors."""

import json

import pytest

from stereo_terrain.calibration import write_opencv_yaml
from stereo_terrain.frames import save_rig
from stereo_terrain.runtime.capture import StereoFrame, write_pairs
from stereo_terrain.runtime.simulate import ApproachConfig, approach_spec
from stereo_terrain.synthetic import render_scene

from .cli_run import run_cli


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    cfg = ApproachConfig(image_size=(320, 240), supersample=1, start_distance_m=1.2)
    scene = render_scene(approach_spec(cfg, 0.0, 0.0))
    folder = tmp_path_factory.mktemp("rec") / "r"
    write_pairs(folder, [StereoFrame(scene.left, scene.right, i / 30, i / 30, i) for i in range(3)])
    write_opencv_yaml(scene.calibration, folder / "calib.yaml")
    save_rig(scene.rig, folder / "rig.yaml")
    return folder


def test_replay_without_lcm(recording, tmp_path, capsys):
    summary = tmp_path / "s.json"
    code, out, err = run_cli(
        ["replay", recording, "--no-lcm", "--as-fast", "--quiet", "--summary-json", summary], capsys
    )
    assert code == 0, err
    assert out.startswith("done: 3 pairs")
    data = json.loads(summary.read_text())
    assert data["processed"] == 3 and data["latency_median_ms"] > 0


def test_replay_status_line_goes_to_stderr(recording, capsys, monkeypatch):
    import stereo_terrain.cli.live

    # the status line is drawn on a terminal only
    monkeypatch.setattr(stereo_terrain.cli.live, "is_terminal", lambda stream: True)
    code, out, err = run_cli(["replay", recording, "--no-lcm", "--as-fast", "--frames", "2"], capsys)
    assert code == 0 and "\r" in err and "pairs" in err and out.startswith("done: 2 pairs")


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["replay", "{tmp}/nope", "--no-lcm", "--calib", "{rec}/calib.yaml"], "pairs folder not found"),
        (["replay", "{tmp}", "--no-lcm"], "{tmp} is not a recording: it has no pairs.csv"),
        (["replay", "{rec}", "--no-lcm", "--speed", "0"], "--speed: expected a finite number > 0, got 0"),
        (["replay", "{rec}", "--no-lcm", "--speed", "-1"], "--speed: expected a finite number > 0, got -1"),
        (["replay", "{rec}", "--no-lcm", "--speed", "nan"], "--speed: expected a finite number > 0, got nan"),
        (["replay", "{rec}", "--lcm-url", "bogus://x"], "cannot open LCM"),
        (["run", "--left", "{tmp}/l.avi", "--right", "{tmp}/r.avi", "--calib", "{rec}/calib.yaml",
          "--no-lcm"], "left video not found"),
        (["record", "--left", "{tmp}/l.avi", "--right", "{tmp}/r.avi", "--out", "{rec}"], "video not found"),
        (["simulate", "--out", "{tmp}/sim", "--start", "0.3"], "must start further than"),
        (["simulate", "--out", "{tmp}/sim", "--fps", "1e9"], "lower --fps"),
        (["simulate", "--out", "{tmp}/sim", "--rise", "5"], "--rise must be <= 1 m"),
        (["simulate", "--out", "{tmp}/sim", "--fps", "0"], "--fps must be > 0"),
        (["record", "--left", "98", "--right", "99", "--out", "{tmp}/r"], "cannot open left camera/video 98"),
        (["replay", "{rec}", "--max-skew-ms", "-3"], "expected a finite number >= 0"),
        (["replay", "{rec}", "--no-lcm", "--denoised-every", "0"], "--denoised-every"),
        (["run", "--left", "98", "--right", "99", "--calib", "{rec}/calib.yaml", "--no-lcm", "--as-fast"],
         "--as-fast needs two video files"),
    ],
)  # fmt: skip
def test_mistakes_are_one_line_exit_2(recording, tmp_path, capsys, argv, match):
    argv = [a.format(tmp=tmp_path, rec=recording) for a in argv]
    code, out, err = run_cli(argv, capsys)
    assert code == 2
    assert match.format(tmp=tmp_path) in err and err.count("\n") == 1 and "Traceback" not in err


def test_replay_takes_the_denoised_opinions_schedule(recording, capsys, monkeypatch):
    """``--denoised-every N`` reaches the loop's config; without it, the config's default."""
    import stereo_terrain.runtime.loop as loop

    given = []
    real = loop.LiveLoop.__init__

    def init(self, *args, **kwargs):
        given.append(kwargs["config"].denoised_every)
        real(self, *args, **kwargs)

    monkeypatch.setattr(loop.LiveLoop, "__init__", init)
    for extra in ([], ["--denoised-every", "1"]):
        code, _, _ = run_cli(["replay", recording, "--no-lcm", "--as-fast", "--frames", "1", *extra], capsys)
        assert code == 0
    assert given == [loop.LoopConfig().denoised_every, 1]


def test_replay_of_a_recording_without_calib_yaml_asks_for_calib(recording, tmp_path, capsys):
    """What record writes (pairs.csv and the images, no calib.yaml) is a recording: the
    message is then about the calibration."""
    rec = tmp_path / "rec"
    rec.mkdir()
    for p in recording.iterdir():
        if p.name not in ("calib.yaml", "rig.yaml"):
            (rec / p.name).write_bytes(p.read_bytes())
    code, _, err = run_cli(["replay", rec, "--no-lcm", "--as-fast"], capsys)
    assert code == 2 and err.count("\n") == 1
    assert f"no --calib given and {rec / 'calib.yaml'} does not exist; pass --calib" in err


def test_one_camera_and_one_file_is_refused(recording, tmp_path, capsys):
    (tmp_path / "l.avi").write_bytes(b"")
    code, _, err = run_cli(
        [
            "run",
            "--left",
            tmp_path / "l.avi",
            "--right",
            "0",
            "--calib",
            recording / "calib.yaml",
            "--no-lcm",
        ],
        capsys,
    )
    assert code == 2 and "not one of each" in err


def test_simulate_writes_summary_and_plot(tmp_path, capsys):
    out = tmp_path / "sim"
    code, text, err = run_cli(
        [
            "simulate",
            "--out",
            out,
            "--size",
            "160x120",
            "--start",
            "0.65",
            "--fps",
            "10",
            "--record",
            out / "seq",
        ],
        capsys,
    )
    assert code == 0, err
    data = json.loads((out / "summary.json").read_text())
    assert data["frames"] == 5 and data["messages"] == 5
    assert set(data["edge_clearance_blind_m"]) == {"FL", "FR", "RL", "RR"}
    assert (out / "approach.png").stat().st_size > 20_000
    assert (out / "seq" / "pairs.csv").read_text().count("\n") == 6
    assert "first riser edge clearance, blind swing" in text


def _write_video(path, frames):
    import cv2

    h, w = frames[0].shape[:2] if frames else (240, 320)
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))
    if not out.isOpened():
        pytest.skip("OpenCV has no MJPG writer here")
    for f in frames:
        out.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
    out.release()


def test_record_of_unusable_sources_is_an_error_and_leaves_nothing(tmp_path, capsys):
    import numpy as np

    img = np.random.default_rng(0).integers(0, 255, (240, 320), dtype=np.uint8)
    _write_video(tmp_path / "l.avi", [img] * 3)
    _write_video(tmp_path / "small.avi", [img[:120, :160].copy()] * 3)
    code, out, err = run_cli(
        [
            "record",
            "--left",
            tmp_path / "l.avi",
            "--right",
            tmp_path / "small.avi",
            "--out",
            tmp_path / "rec",
        ],
        capsys,
    )
    assert code == 2 and err.count("\n") == 1, err
    assert "recorded no pairs" in err and "left image 320x240 and right image 160x120 differ in size" in err
    assert not (tmp_path / "rec").exists()  # nothing left that a second try would refuse
    # Same sizes: recorded.
    _write_video(tmp_path / "r.avi", [img] * 3)
    code, out, err = run_cli(
        ["record", "--left", tmp_path / "l.avi", "--right", tmp_path / "r.avi", "--out", tmp_path / "rec"],
        capsys,
    )
    assert code == 0 and "recorded 3 pairs" in out


def test_simulate_takes_the_realistic_profile(tmp_path, capsys):
    out = tmp_path / "sim"
    argv = ["simulate", "--out", out, "--size", "160x120", "--start", "1.0", "--fps", "4", "--no-plot"]
    code, _, err = run_cli([*argv, "--profile", "realistic", "--seed", "3", "--record", out / "seq"], capsys)
    assert code == 0, err
    data = json.loads((out / "summary.json").read_text())
    assert data["frames"] == 5 and set(data["edge_clearance_blind_m"]) == {"FL", "FR", "RL", "RR"}
    saved = json.loads((out / "seq" / "approach.json").read_text())["approach"]
    assert saved["profile"] == "realistic" and saved["seed"] == 3
    code, _, err = run_cli([*argv, "--profile", "photoreal"], capsys)
    assert code == 2 and "--profile" in err and err.count("\n") == 1
