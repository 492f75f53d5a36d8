"""The bag and CameraInfo readers on malformed input: a result or one InputError, never
another exception (hypothesis)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags")

from stereo_terrain.errors import InputError  # noqa: E402
from stereo_terrain.ros.bag import BagPairs, calibration_from_camera_info, decode_image  # noqa: E402

from .ros_bags import bag_messages, write_mcap_ros2  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

numbers = st.floats(allow_nan=True, allow_infinity=True, width=64) | st.integers(-5, 5)


class Msg:
    def __init__(self, **fields):
        self.__dict__.update(fields)


def _good_info(side: str) -> dict:
    fx, cx, cy, b = 300.0, 160.0, 120.0, 0.1
    return {
        "width": 320,
        "height": 240,
        "distortion_model": "plumb_bob",
        "d": [0.01, -0.02, 0.0, 0.0, 0.0],
        "k": [fx, 0, cx, 0, fx, cy, 0, 0, 1],
        "r": [1, 0, 0, 0, 1, 0, 0, 0, 1],
        "p": [fx, 0, cx, -fx * b if side == "right" else 0.0, 0, fx, cy, 0, 0, 0, 1, 0],
    }


info_fields = st.fixed_dictionaries(
    {},
    optional={
        "width": st.integers(-10, 5000) | st.just("x"),
        "height": st.integers(-10, 5000),
        "distortion_model": st.sampled_from(["plumb_bob", "rational_polynomial", "equidistant", "", "foo"]),
        "d": st.lists(numbers, max_size=15),
        "k": st.lists(numbers, max_size=12),
        "r": st.lists(numbers, max_size=12),
        "p": st.lists(numbers, max_size=14),
    },
)


@given(left=info_fields, right=info_fields)
def test_camera_info_malformed_is_input_error(left, right):
    a, b = _good_info("left"), _good_info("right")
    a.update(left)
    b.update(right)
    try:
        calib = calibration_from_camera_info(Msg(**a), Msg(**b))
    except InputError as exc:
        assert "\n" not in str(exc)
    else:
        assert calib.baseline_m > 0


def test_camera_info_good_pair_and_swapped_topics():
    calib = calibration_from_camera_info(Msg(**_good_info("left")), Msg(**_good_info("right")))
    assert np.allclose(calib.T, [-0.1, 0, 0]) and np.allclose(calib.R, np.eye(3))
    with pytest.raises(InputError, match="swapped"):
        calibration_from_camera_info(Msg(**_good_info("right")), Msg(**_good_info("left")))


@given(
    encoding=st.sampled_from(
        ["mono8", "mono16", "bgr8", "rgb8", "bgra8", "rgba8", "8UC3", "yuv422", "yuv422_yuy2", "nv12", "x"]
    ),
    height=st.integers(-2, 9),
    width=st.integers(-2, 9),
    step=st.integers(-2, 40),
    big=st.booleans(),
    data=st.binary(max_size=400),
)
def test_image_decode_malformed_is_input_error(encoding, height, width, step, big, data):
    msg = Msg(
        encoding=encoding,
        height=height,
        width=width,
        step=step,
        is_bigendian=big,
        data=np.frombuffer(data, dtype=np.uint8),
    )
    try:
        img = decode_image(msg, "sensor_msgs/msg/Image")
    except InputError as exc:
        assert "\n" not in str(exc)
    else:
        assert img.dtype == np.uint8 and img.shape[:2] == (height, width) and img.ndim in (2, 3)


@given(data=st.binary(max_size=200), fmt=st.sampled_from(["jpeg", "png", ""]))
def test_compressed_decode_garbage_is_input_error(data, fmt):
    msg = Msg(format=fmt, data=np.frombuffer(data, dtype=np.uint8))
    try:
        img = decode_image(msg, "sensor_msgs/msg/CompressedImage")
    except InputError:
        return
    assert img.dtype == np.uint8


@pytest.fixture(scope="module")
def good_mcap(tmp_path_factory) -> bytes:
    class Scene:
        left = np.tile(np.arange(32, dtype=np.uint8), (24, 1))
        right = left

    ts, msgs = bag_messages(Scene, 2)
    path = tmp_path_factory.mktemp("bag") / "b.mcap"
    write_mcap_ros2(path, ts, msgs)
    return path.read_bytes()


@settings(max_examples=25)
@given(cut=st.floats(0.0, 1.0), flip=st.integers(0, 10**6), junk=st.binary(max_size=64))
def test_damaged_mcap_is_input_error(good_mcap, tmp_path_factory, cut, flip, junk):
    data = bytearray(good_mcap[: int(cut * len(good_mcap))]) + junk
    if data:
        data[flip % len(data)] ^= 0xFF
    path = tmp_path_factory.mktemp("bad") / "bad.mcap"
    path.write_bytes(bytes(data))
    try:
        pairs = BagPairs(path, "/stereo/left/image_raw", "/stereo/right/image_raw")
    except InputError as exc:
        assert "\n" not in str(exc)
        return
    try:
        while (ev := pairs.read()).status != "end":
            assert ev.status in ("frame", "unreadable")
    except InputError as exc:  # damage found while streaming
        assert "\n" not in str(exc)
    finally:
        pairs.close()


def test_not_a_bag(tmp_path):
    (tmp_path / "x.mcap").write_bytes(b"not an mcap file at all")
    with pytest.raises(InputError, match="cannot read the ROS bag"):
        BagPairs(tmp_path / "x.mcap", "/l", "/r")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "metadata.yaml").write_text("rosbag2_bagfile_information: [")
    with pytest.raises(InputError, match="cannot read the ROS bag"):
        BagPairs(tmp_path / "d", "/l", "/r")


# --------------------------------------------------------------------------- the extras


def _without(modules: list[str], argv: list[str]) -> subprocess.CompletedProcess:
    """Run the CLI with ``modules`` unimportable (as if their extra were not installed)."""
    code = textwrap.dedent(
        f"""
        import sys
        for name in {modules!r}:
            sys.modules[name] = None
        from stereo_terrain.cli import main
        sys.exit(main({argv!r}))
        """
    )
    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)


OPTIONAL = ["mcap", "mcap_ros2", "rosbags", "rerun", "lcm", "matplotlib"]


@pytest.fixture(scope="module")
def tiny_rec(tmp_path_factory):
    from .ros_bags import render_recording

    folder = tmp_path_factory.mktemp("rec") / "rec"
    render_recording(folder, 1)
    return folder


def test_base_install_runs_without_any_extra(tiny_rec, tmp_path):
    done = _without(OPTIONAL, ["replay", str(tiny_rec), "--no-lcm", "--as-fast", "--quiet"])
    assert done.returncode == 0, done.stderr
    assert "done: 1 pairs" in done.stdout
    js = tmp_path / "r.json"
    argv = ["reconstruct", str(tiny_rec / "left_000000.png"), str(tiny_rec / "right_000000.png")]
    done = _without(OPTIONAL, [*argv, "--calib", str(tiny_rec / "calib.yaml"), "--json", str(js)])
    assert done.returncode == 0 and js.is_file(), done.stderr


@pytest.mark.parametrize(
    "hidden, option, extra",
    [
        (["mcap"], ["--mcap", "OUT/o.mcap"], "ros"),
        (["rosbags"], ["--mcap", "OUT/o.mcap"], "ros"),
        (["rerun"], ["--view-save", "OUT/o.rrd"], "view"),
        (["rerun"], ["--view"], "view"),
        (["lcm"], [], "lcm"),
    ],
)
def test_missing_extra_is_one_line_before_any_work(tiny_rec, tmp_path, hidden, option, extra):
    option = [o.replace("OUT", str(tmp_path)) for o in option]
    lcm = ["--no-lcm"] if extra != "lcm" else []
    done = _without(hidden, ["replay", str(tiny_rec), "--as-fast", "--quiet", *lcm, *option])
    assert done.returncode == 2
    assert f"pip install 'stereo-terrain[{extra}]'" in done.stderr and done.stderr.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_missing_viz_extra_for_plot(tiny_rec, tmp_path):
    argv = ["reconstruct", str(tiny_rec / "left_000000.png"), str(tiny_rec / "right_000000.png")]
    done = _without(
        ["matplotlib"], [*argv, "--calib", str(tiny_rec / "calib.yaml"), "--plot", str(tmp_path / "p.png")]
    )
    assert done.returncode == 2 and "pip install 'stereo-terrain[viz]'" in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_yuv422_and_rgb_decode_to_the_same_grey():
    import cv2

    rng = np.random.default_rng(0)
    bgr = cv2.GaussianBlur(rng.integers(0, 255, (8, 12, 3), dtype=np.uint8), (3, 3), 0)
    yuyv = cv2.cvtColor(bgr, cv2.COLOR_BGR2YUV_YUYV) if hasattr(cv2, "COLOR_BGR2YUV_YUYV") else None
    rgb = Msg(
        encoding="rgb8", height=8, width=12, step=36, is_bigendian=False, data=bgr[:, :, ::-1].reshape(-1)
    )
    assert np.array_equal(decode_image(rgb, "sensor_msgs/msg/Image"), bgr)
    if yuyv is None:
        pytest.skip("this OpenCV cannot encode YUYV")
    msg = Msg(encoding="yuv422_yuy2", height=8, width=12, step=24, is_bigendian=False, data=yuyv.reshape(-1))
    got = decode_image(msg, "sensor_msgs/msg/Image")
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY).astype(int)
    assert got.shape == (8, 12, 3) and np.abs(cv2.cvtColor(got, cv2.COLOR_BGR2GRAY) - grey).max() <= 12


# --------------------------------------------------------------------------- pairing


@given(
    tl=st.lists(st.floats(0, 100, allow_nan=False), max_size=30),
    tr=st.lists(st.floats(0, 100, allow_nan=False), max_size=30),
)
def test_match_stamps_pairs_mutual_nearest_one_to_one(tl, tr):
    from stereo_terrain.runtime.capture import match_stamps

    a, b = np.sort(np.array(tl)), np.sort(np.array(tr))
    pairs = match_stamps(a, b)
    assert len({i for i, _ in pairs}) == len(pairs) == len({j for _, j in pairs})
    assert [i for i, _ in pairs] == sorted(i for i, _ in pairs)
    for i, j in pairs:  # each is (one of) the other's nearest
        assert abs(a[i] - b[j]) <= np.min(np.abs(b - a[i])) + 1e-12
        assert abs(a[i] - b[j]) <= np.min(np.abs(a - b[j])) + 1e-12
    if len(a) and len(b):
        assert pairs  # the globally closest pair is always mutual


class _Scene:
    rng = np.random.default_rng(1)
    left = rng.integers(0, 255, (24, 32), dtype=np.uint8)
    right = rng.integers(0, 255, (24, 32), dtype=np.uint8)


def _rosbag(tmp_path, msgs, ts, *, big_endian=False):
    from rosbags.rosbag2 import StoragePlugin, Writer

    conns = {}
    with Writer(tmp_path / "bag", version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        for topic, typ, t, msg in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typ, typestore=ts)
            writer.write(conns[topic], t, ts.serialize_cdr(msg, typ, little_endian=not big_endian))
    return tmp_path / "bag"


def _frames(bag):
    pairs = BagPairs(bag, "/stereo/left/image_raw", "/stereo/right/image_raw")
    out = []
    while (ev := pairs.read()).status != "end":
        out.append(ev.frame)
    pairs.close()
    return pairs, out


@pytest.mark.parametrize("big_endian", [False, True])
def test_bag_pairs_dropped_image_and_byte_order(tmp_path, big_endian):
    ts, msgs = bag_messages(_Scene, 4)
    msgs = [m for m in msgs if not (m[0].startswith("/stereo/right") and m is msgs[5])]  # drop one right
    bag = _rosbag(tmp_path, msgs, ts, big_endian=big_endian)
    pairs, frames = _frames(bag)
    assert len(frames) == 3 and all(np.array_equal(f.left, _Scene.left) for f in frames)
    assert all(abs(f.t_right_s - f.t_left_s - 0.002) < 1e-6 for f in frames)
    assert [f.stamp_s for f in frames] == sorted(f.stamp_s for f in frames)


def test_zero_header_stamps_use_receive_times(tmp_path):
    ts, msgs = bag_messages(_Scene, 3)
    for _, _, _, msg in msgs:
        msg.header.stamp.sec, msg.header.stamp.nanosec = 0, 0
    _, frames = _frames(_rosbag(tmp_path, msgs, ts))
    from .ros_bags import T0_S

    assert len(frames) == 3 and abs(frames[0].t_left_s - T0_S) < 1e-6


def test_long_pause_in_a_bag_is_replayed_short(tmp_path, caplog):
    from stereo_terrain.runtime.capture import MAX_REPLAY_GAP_S

    ts, msgs = bag_messages(_Scene, 3)
    for _, _, t, msg in msgs:  # the third pair an hour later
        if t > msgs[3][2]:
            msg.header.stamp.sec += 3600
    _, frames = _frames(_rosbag(tmp_path, msgs, ts))
    gaps = np.diff([f.t_left_s for f in frames])
    assert gaps[1] == pytest.approx(MAX_REPLAY_GAP_S, abs=1e-6)
    assert frames[2].stamp_s - frames[1].stamp_s == pytest.approx(3600.1, abs=1e-6)  # output keeps the bag's
    assert "pause" in caplog.text


def test_view_without_a_display_is_refused_before_any_work(tiny_rec, tmp_path):
    pytest.importorskip("rerun")
    import socket

    with socket.socket() as probe:
        if probe.connect_ex(("127.0.0.1", 9876)) == 0:
            pytest.skip("a Rerun viewer is listening on this machine")
    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}  # no DISPLAY
    done = subprocess.run(
        [sys.executable, "-m", "stereo_terrain.cli", "replay", str(tiny_rec), "--no-lcm", "--view"],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2 and "--view needs a display" in done.stderr
    assert done.stderr.count("\n") == 1 and done.stdout == ""


def test_sigterm_stops_the_loop_with_a_complete_mcap(tiny_rec, tmp_path):
    import signal
    import time

    from .ros_bags import read_mcap

    out = tmp_path / "live.mcap"
    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}
    argv = [sys.executable, "-m", "stereo_terrain.cli", "replay", str(tiny_rec), "--no-lcm", "--loop"]
    proc = subprocess.Popen([*argv, "--quiet", "--mcap", str(out)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(".live.mcap.*.part")) and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(3.0)  # warm-up, then a few looped pairs
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode in (0, 130), stderr
    assert [p.name for p in tmp_path.iterdir()] == ["live.mcap"]
    decoded = read_mcap(out)  # complete: it has its summary and every message decodes
    assert len(decoded["/tf"]) == len(decoded["/stereo_terrain/cloud"])


def test_replay_outputs_beside_and_over_its_inputs(tiny_rec, good_mcap, tmp_path, capsys):
    """A new file in the recording folder may be written, and written again; a recorded
    image, or the bag itself (``replay BAG --mcap BAG`` wrote over the recording), may not."""
    from .cli_run import run_cli

    summary = tiny_rec / "summary.json"
    replay = ["replay", tiny_rec, "--no-lcm", "--as-fast"]
    for _ in range(2):
        code, _, err = run_cli([*replay, "--summary-json", summary], capsys)
        assert code == 0, err
    summary.unlink()
    image = sorted(tiny_rec.glob("left_*.png"))[0]
    before = image.read_bytes()
    code, _, err = run_cli([*replay, "--summary-json", image], capsys)
    assert code == 2 and "one of the inputs" in err and image.read_bytes() == before
    bag = tmp_path / "b.mcap"
    bag.write_bytes(good_mcap)
    code, _, err = run_cli(["replay", bag, "--no-lcm", "--as-fast", "--mcap", bag], capsys)
    assert code == 2 and "one of the inputs" in err and bag.read_bytes() == good_mcap
