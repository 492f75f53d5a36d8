"""LCM on loopback: publishing, lcm-logger, and the replay of a rendered approach.

Multicast on one host: ``udpm://239.255.76.67:PORT?ttl=0`` keeps the packets on the host
and works in this sandbox and on CI without a route on ``lo``; each test run uses its own
port so parallel runs on one machine do not hear each other.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from stereo_terrain.cli import main
from stereo_terrain.errors import InputError
from stereo_terrain.runtime.messages import body_state_t, terrain_t
from stereo_terrain.runtime.simulate import (
    ApproachConfig,
    evaluate_approach,
    load_approach,
    simulate_approach,
)

lcm = pytest.importorskip("lcm", reason="the lcm package (test extra) is not installed")

TRIGGER_TOL_M = 0.03  # the bound on |trigger - (d - d_buffer)|


def _url(offset):
    return f"udpm://239.255.76.67:{20000 + (os.getpid() * 7 + offset) % 20000}?ttl=0"


class Subscriber:
    """Collects decoded messages of one channel. Subscribed when made, so that the
    messages published after it wait in its socket; read when asked (:meth:`wait_for`), on
    the caller's thread: no thread of its own (a test once hung starting one)."""

    def __init__(self, url, channel="STEREO_TERRAIN", kind=terrain_t):
        self.lc = lcm.LCM(url)
        self.got = []
        self.lc.subscribe(channel, lambda ch, data: self.got.append(kind.decode(data)))

    def wait_for(self, n, timeout=5.0):
        end = time.monotonic() + timeout
        while len(self.got) < n and time.monotonic() < end:
            self.lc.handle_timeout(20)
        while self.lc.handle_timeout(0) > 0:  # and whatever else has arrived
            pass
        return self.got


@pytest.fixture(scope="module")
def approach(tmp_path_factory):
    """A short rendered approach (320x240, 17 frames) recorded for replay."""
    folder = tmp_path_factory.mktemp("approach") / "seq"
    cfg = ApproachConfig(image_size=(320, 240), supersample=1, start_distance_m=1.0, fps=15.0)
    result = simulate_approach(cfg, record_to=folder)
    return folder, cfg, result


def test_publisher_reaches_a_subscriber_on_loopback():
    from stereo_terrain.runtime.lcm_io import LcmPublisher

    url = _url(1)
    sub = Subscriber(url)
    pub = LcmPublisher(url, "STEREO_TERRAIN")
    msg = terrain_t()
    msg.frame_index = 42
    for _ in range(3):
        pub(msg)
    got = sub.wait_for(3)
    assert [m.frame_index for m in got] == [42, 42, 42]


def test_state_listener_reads_the_body_pose():
    from stereo_terrain.runtime.lcm_io import LcmStateListener

    url = _url(2)
    listener = LcmStateListener(url, "STATE")
    try:
        st = body_state_t()
        st.utime, st.position_m, st.rpy_rad = 5, [1.0, 2.0, 0.3], [0.01, -0.02, 0.5]
        lc = lcm.LCM(url)
        end = time.monotonic() + 3.0
        while listener.latest() is None and time.monotonic() < end:
            lc.publish("STATE", st.encode())
            time.sleep(0.02)
        odo, rpy, utime = listener.latest()
        assert odo.position_m == (1.0, 2.0, 0.3) and odo.yaw_rad == 0.5 and rpy == (0.01, -0.02, 0.5)
    finally:
        listener.close()


def test_lcm_logger_records_terrain_messages(tmp_path):
    logger = Path(sys.executable).parent / "lcm-logger"
    if not logger.exists():
        logger = shutil.which("lcm-logger")
    if logger is None:
        pytest.skip("lcm-logger is not installed with the lcm package here")
    url = _url(3)
    log_path = tmp_path / "terrain.lcmlog"
    # The wheel's lcm-logger is a Python wrapper around the real binary, its child: signal
    # the whole process group, as Ctrl-C in a terminal does, or the child keeps running.
    proc = subprocess.Popen(
        [str(logger), "-q", "-l", url, str(log_path)], stdout=subprocess.DEVNULL, start_new_session=True
    )
    try:
        lc = lcm.LCM(url)
        msg = terrain_t()
        msg.num_steps, msg.rise_m, msg.run_m, msg.distance_m, msg.width_m = 1, [0.2], [0.3], [1.4], [1.0]
        # terrain_t v2 (issue 14): every per-step array has num_steps entries
        msg.rise_sigma_m, msg.run_sigma_m = [0.005], [0.01]
        msg.distance_sigma_m, msg.width_sigma_m = [0.02], [0.05]
        time.sleep(0.5)  # let the logger join the group
        for i in range(5):
            msg.frame_index = i
            lc.publish("STEREO_TERRAIN", msg.encode())
        time.sleep(0.3)
    finally:
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the logger flushes and closes the log
        proc.wait(5)
    events = [e for e in lcm.EventLog(str(log_path), "r") if e.channel == "STEREO_TERRAIN"]
    decoded = [terrain_t.decode(e.data) for e in events]
    assert [m.frame_index for m in decoded] == [0, 1, 2, 3, 4] and decoded[0].distance_m[0] == pytest.approx(
        1.4
    )


def test_missing_lcm_is_a_clear_error(monkeypatch):
    from stereo_terrain.runtime import lcm_io

    monkeypatch.setitem(sys.modules, "lcm", None)
    with pytest.raises(InputError, match=r"pip install 'stereo-terrain\[lcm\]'"):
        lcm_io.LcmPublisher("udpm://239.255.76.67:7667?ttl=0")


def test_bad_lcm_url_is_a_clear_error():
    from stereo_terrain.runtime.lcm_io import LcmPublisher

    with pytest.raises(InputError, match="cannot open LCM"):
        LcmPublisher("nonsense://x")


def test_replay_over_lcm_triggers_on_time_and_the_feet_clear(approach, tmp_path, capsys):
    """The issue's must-show, small: replay -> LCM -> subscriber -> trigger and feet."""
    folder, cfg, sim = approach
    url = _url(4)
    sub = Subscriber(url)
    summary_path = tmp_path / "summary.json"
    # A pair's terrain is stale when it took longer than --stall-timeout; 30 s here, so
    # that a loaded machine (the suite beside other work) does not fail the check below.
    argv = ["replay", str(folder), "--as-fast", "--quiet", "--lcm-url", url, "--stall-timeout", "30"]
    code = main([*argv, "--summary-json", str(summary_path)])
    assert code == 0, capsys.readouterr().err
    summary = json.loads(summary_path.read_text())
    n = cfg.frame_count
    got = sub.wait_for(n)
    # Every pair processed, every processed pair one message, in order.
    assert summary["processed"] == n and summary["published"] == n
    assert [m.frame_index for m in got] == list(range(n))
    assert not any(m.stale for m in got)
    cfg2, swing = load_approach(folder)
    assert cfg2 == cfg
    x_of_frame = {i: cfg.speed_mps * i / cfg.fps for i in range(n)}
    res = evaluate_approach(cfg, swing, got, x_of_frame)
    assert res.trigger_error_m is not None and abs(res.trigger_error_m) < TRIGGER_TOL_M
    sensed, blind = res.edge_clearances(res.sensed), res.edge_clearances(res.blind)
    assert set(sensed) == set(blind) == {"FL", "FR", "RL", "RR"}
    assert all(v > 0 for v in sensed.values())  # the raised swing clears the first riser's edge
    assert all(v < 0 for v in blind.values())  # the blind 0.15 m swing hits the 0.21 m step
    # The replay gives what the simulation itself saw.
    assert res.trigger_x_m == pytest.approx(sim.trigger_x_m, abs=0.005)


def test_run_takes_the_body_pose_from_the_state_channel(approach, tmp_path, capsys):
    """``run`` on two video files with the body state on LCM: attitude and odometry used.
    Every pair of the files (``--as-fast``): played in real time, a loaded machine
    processed too few of them to track the staircase."""
    import cv2

    folder, cfg, _ = approach
    paths = []
    for side in ("left", "right"):
        path = tmp_path / f"{side}.avi"
        w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, cfg.image_size)
        if not w.isOpened():
            pytest.skip("OpenCV has no MJPG writer here")
        for i in range(6):
            w.write(cv2.cvtColor(cv2.imread(str(folder / f"{side}_{i:06d}.png"), 0), cv2.COLOR_GRAY2BGR))
        w.release()
        paths.append(path)
    url = _url(5)
    sub = Subscriber(url)
    stop = threading.Event()

    def publish_state():
        lc = lcm.LCM(url)
        st = body_state_t()
        st.position_m, st.rpy_rad = [1.0, 2.0, 0.0], [0.0, 0.0, 0.3]
        while not stop.is_set():
            lc.publish("STATE", st.encode())
            time.sleep(0.01)

    pub = threading.Thread(target=publish_state, daemon=True)
    pub.start()
    try:
        code = main(
            ["run", "--left", str(paths[0]), "--right", str(paths[1]), "--calib", str(folder / "calib.yaml"),
             "--rig", str(folder / "rig.yaml"), "--state-channel", "STATE", "--lcm-url", url, "--quiet",
             "--as-fast"]
        )  # fmt: skip
    finally:
        stop.set()
        pub.join(1)
    assert code == 0, capsys.readouterr().err
    got = sub.wait_for(2)
    assert len(got) == 6, len(got)  # one message per pair
    assert all(m.quality & terrain_t.QUALITY_POSE_MISSING == 0 for m in got)
    tracking = [m for m in got if m.trigger_phase == terrain_t.PHASE_APPROACH]
    assert tracking and all(list(m.p0_m) == [1.0, 2.0, 0.0] for m in tracking)
    assert tracking[0].heading_rad == pytest.approx(0.3)
