"""``replay --jsonl``: every published message as one JSON line with the LCM field names,
with tracking (the default) and without; terrain_t version 2 (issue 14)."""

import json

import pytest

from stereo_terrain.calibration import write_opencv_yaml
from stereo_terrain.frames import save_rig
from stereo_terrain.runtime.capture import StereoFrame, write_pairs
from stereo_terrain.runtime.messages import message_to_dict, terrain_t
from stereo_terrain.runtime.simulate import ApproachConfig, approach_spec, true_x
from stereo_terrain.swing import Odometry
from stereo_terrain.synthetic import render_scene

from .cli_run import run_cli

FRAMES = 5
#: terrain_t's fingerprint; version 1 (before issue 14) was b4f18593195ae88d.
FINGERPRINT_V2 = "c1cf689eec0e473d"


@pytest.fixture(scope="module")
def approach_rec(tmp_path_factory):
    """Five frames of a walk toward a staircase, with the odometry of each."""
    cfg = ApproachConfig(image_size=(320, 240), supersample=1, start_distance_m=1.6, fps=5.0)
    frames, scene = [], None
    for k in range(FRAMES):
        t = k / cfg.fps
        x = true_x(cfg, t)
        scene = render_scene(approach_spec(cfg, x, 0.0))
        frames.append(
            StereoFrame(scene.left, scene.right, t, t, k, Odometry((x, 0.0, 0.0), 0.0), (0.0, 0.0, 0.0))
        )
    folder = tmp_path_factory.mktemp("rec") / "r"
    write_pairs(folder, frames)
    write_opencv_yaml(scene.calibration, folder / "calib.yaml")
    save_rig(scene.rig, folder / "rig.yaml")
    return folder, cfg


def _lines(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_jsonl_with_tracking(approach_rec, tmp_path, capsys):
    rec, cfg = approach_rec
    out = tmp_path / "m.jsonl"
    code, _, err = run_cli(["replay", rec, "--as-fast", "--no-lcm", "--quiet", "--jsonl", out], capsys)
    assert code == 0, err
    msgs = _lines(out)
    assert len(msgs) == FRAMES
    assert list(msgs[0]) == list(terrain_t.__slots__)  # the LCM field names, in order
    states = [m["track_state"] for m in msgs]
    assert states[0] == terrain_t.TRACK_TENTATIVE and states[-1] == terrain_t.TRACK_CONFIRMED
    for k, m in enumerate(msgs):
        assert m["num_steps"] == len(m["rise_m"]) == len(m["rise_sigma_m"]) == len(m["distance_sigma_m"])
        assert m["rise_sigma_m"][0] > 0 and m["yaw_sigma_rad"] > 0
        d = cfg.start_distance_m - true_x(cfg, k / cfg.fps)
        assert abs(m["distance_m"][0] - d) < 0.1
        assert abs(m["rise_m"][0] - cfg.rise_m) < 0.02


def test_jsonl_without_tracking(approach_rec, tmp_path, capsys):
    rec, _ = approach_rec
    config = tmp_path / "off.yaml"
    config.write_text("tracking: {enabled: false}\n")
    out = tmp_path / "m.jsonl"
    argv = ["replay", rec, "--as-fast", "--no-lcm", "--quiet", "--config", config, "--jsonl", out]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    msgs = _lines(out)
    assert len(msgs) == FRAMES
    assert {m["track_state"] for m in msgs} == {terrain_t.TRACK_NONE}
    assert all(m["rise_sigma_m"][0] > 0 for m in msgs)


@pytest.mark.parametrize(
    ("target", "match"),
    [("{tmp}/nowhere/m.jsonl", "does not exist"), ("{tmp}", "it is a folder"), ("-", "needs a file name")],
)
def test_bad_jsonl_path_is_one_line_exit_2_before_any_work(approach_rec, tmp_path, capsys, target, match):
    rec, _ = approach_rec
    code, out, err = run_cli(
        ["replay", rec, "--as-fast", "--no-lcm", "--jsonl", target.format(tmp=tmp_path)], capsys
    )
    assert code == 2 and match in err and len(err.strip().splitlines()) == 1
    assert "done:" not in out  # nothing was processed


def test_message_v2_fields_and_fingerprint():
    msg = terrain_t()
    msg.num_steps = 1
    msg.rise_m, msg.run_m, msg.distance_m, msg.width_m = [0.17], [float("nan")], [1.2], [1.0]
    msg.rise_sigma_m, msg.run_sigma_m = [0.004], [float("nan")]
    msg.distance_sigma_m, msg.width_sigma_m = [0.01], [0.05]
    msg.yaw_sigma_rad, msg.track_state = 0.01, terrain_t.TRACK_COASTING
    back = terrain_t.decode(msg.encode())
    assert back.track_state == terrain_t.TRACK_COASTING and back.rise_sigma_m[0] == pytest.approx(0.004)
    d = message_to_dict(back)
    assert d["run_sigma_m"] == [None] and d["run_m"] == [None]  # NaN -> null
    json.dumps(d, allow_nan=False)
    assert terrain_t._get_packed_fingerprint().hex() == FINGERPRINT_V2
    assert terrain_t.VERSION == 2
