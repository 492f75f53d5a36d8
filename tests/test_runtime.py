"""Capture sources, the live loop and its fault handling (fake clock: no real waiting)."""

import math

import cv2
import numpy as np
import pytest

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.odometry import PoseJumps
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.runtime.capture import (
    END,
    FRAME,
    MAX_REPLAY_GAP_S,
    NONE,
    SKEW,
    UNREADABLE,
    Capture,
    CaptureEvent,
    FolderPairs,
    Paced,
    StereoFrame,
    read_pairs_index,
    write_pairs,
)
from stereo_terrain.runtime.loop import LiveLoop, LoopConfig
from stereo_terrain.runtime.messages import terrain_t
from stereo_terrain.runtime.simulate import ApproachConfig, FrameSource, approach_spec
from stereo_terrain.swing import Odometry
from stereo_terrain.synthetic import render_scene


class FakeClock:
    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t

    def sleep(self, dt):
        self.t += dt


class ScriptedCamera:
    """Gives each item once the fake clock reaches its time; nothing (``none``) before."""

    def __init__(self, clock, script):
        self.clock, self.script, self.closed = clock, list(script), False

    def read(self):
        if not self.script:
            return CaptureEvent(END)
        t, item = self.script[0]
        if self.clock() < t:
            return CaptureEvent(NONE)
        self.script.pop(0)
        return item if isinstance(item, CaptureEvent) else CaptureEvent(FRAME, item)

    def close(self):
        self.closed = True


@pytest.fixture(scope="module")
def scene():
    cfg = ApproachConfig(image_size=(320, 240), supersample=1, start_distance_m=1.2)
    return render_scene(approach_spec(cfg, 0.0, 0.0))


@pytest.fixture(scope="module")
def pipeline(scene):
    return Pipeline(scene.calibration, scene.rig)


def _frame(scene, t, i, skew=0.0, x=0.0):
    return StereoFrame(scene.left, scene.right, t, t + skew, i, Odometry((x, 0.0, 0.0)), (0.0, 0.0, 0.0))


def test_faults_are_counted_flagged_and_survived(scene, pipeline):
    clock = FakeClock()
    t0 = clock()
    bad_shape = StereoFrame(scene.left[:100], scene.right[:100], t0 + 0.2, t0 + 0.2, 3)
    script = [
        (t0, _frame(scene, t0, 0)),
        (t0 + 0.03, _frame(scene, t0 + 0.03, 1)),
        (t0 + 0.1, CaptureEvent(UNREADABLE, detail="cannot decode")),  # corrupt image
        (t0 + 0.2, bad_shape),  # a truncated frame
        (t0 + 0.25, _frame(scene, t0 + 0.25, 4, skew=0.05)),  # 50 ms apart > 15 ms
        (t0 + 0.3, _frame(scene, t0 + 0.3, 5)),
        # ... then the camera gives nothing for 2 s ...
        (t0 + 2.3, _frame(scene, t0 + 2.3, 6)),
        (t0 + 2.33, _frame(scene, t0 + 2.33, 7)),
    ]
    cam = ScriptedCamera(clock, script)
    msgs = []
    loop = LiveLoop(
        Capture(cam),
        pipeline,
        msgs.append,
        config=LoopConfig(poll_s=0.01, stall_timeout_s=0.5, heartbeat_s=0.1),
        clock=clock,
        sleep=clock.sleep,
    )
    s = loop.run()
    assert cam.closed and not s.interrupted
    assert s.processed == 5 and [m.frame_index for m in msgs if not m.stale] == [0, 1, 5, 6, 7]
    assert s.unreadable == 2 and s.skew_dropped == 1 and s.stalls == 1
    assert s.stalled_s == pytest.approx(2.0, abs=0.05)
    fresh = {m.frame_index: m for m in msgs if not m.stale}
    assert (
        fresh[5].quality & terrain_t.QUALITY_UNREADABLE and fresh[5].quality & terrain_t.QUALITY_SKEW_DROPPED
    )
    assert fresh[1].quality & (terrain_t.QUALITY_UNREADABLE | terrain_t.QUALITY_STALLED) == 0
    stale = [m for m in msgs if m.stale]
    # Heartbeats every 0.1 s from 0.5 s after the last pair to its return: about 15.
    assert 13 <= s.heartbeats == len(stale) <= 17
    assert all(m.quality & terrain_t.QUALITY_STALLED and m.frame_index == 5 for m in stale)
    ages = [m.age_s for m in stale]
    assert ages == sorted(ages) and ages[0] >= 0.5 and 1.85 <= ages[-1] <= 2.0
    assert fresh[6].quality & terrain_t.QUALITY_STALLED  # the first pair after the stall says so
    assert fresh[7].quality & terrain_t.QUALITY_STALLED == 0
    assert "stalls 1" in s.format() and "skew 1" in s.format()


def test_pipeline_errors_are_counted_and_the_loop_goes_on(scene, pipeline, monkeypatch):
    real_run = pipeline.run
    calls = {"n": 0}

    def flaky(left, right, **options):
        calls["n"] += 1
        if calls["n"] == 2:
            raise RuntimeError("boom")
        return real_run(left, right, **options)

    monkeypatch.setattr(pipeline, "run", flaky)
    msgs = []
    frames = [_frame(scene, float(i), i) for i in range(3)]
    s = LiveLoop(Capture(FrameSource(frames)), pipeline, msgs.append).run()
    assert s.processed == 2 and s.failed == 1 and [m.frame_index for m in msgs] == [0, 2]
    assert msgs[1].quality & terrain_t.QUALITY_UNREADABLE


def test_ctrl_c_stops_cleanly(scene, pipeline):
    def items():
        yield _frame(scene, 0.0, 0)
        raise KeyboardInterrupt

    src = FrameSource(items())
    s = LiveLoop(Capture(src), pipeline, lambda m: None).run()
    assert s.interrupted and s.processed == 1 and src.closed
    assert s.format().startswith("interrupted: 1 pairs")


def test_status_line_and_limits(scene, pipeline):
    import io

    out = io.StringIO()
    frames = [_frame(scene, i / 30, i) for i in range(5)]
    loop = LiveLoop(
        Capture(FrameSource(frames)),
        pipeline,
        lambda m: None,
        config=LoopConfig(max_frames=3, status_interval_s=0.0),
        status=out,
    )
    s = loop.run()
    assert s.processed == 3
    text = out.getvalue()
    assert text.startswith("\r") and "pairs" in text and "fps" in text and "stairs" in text
    with pytest.raises(ConfigError, match="stall_timeout_s"):
        LoopConfig(stall_timeout_s=-1.0)


def test_capture_drops_skewed_pairs(scene):
    frames = [_frame(scene, 0.0, 0, skew=0.010), _frame(scene, 0.1, 1, skew=-0.020)]
    cap = Capture(FrameSource(frames), max_skew_s=0.015)
    assert [cap.read().status for _ in range(3)] == [FRAME, SKEW, END]
    assert cap.stats.skew_dropped == 1 and cap.stats.pairs == 1
    with pytest.raises(ConfigError):
        Capture(FrameSource([]), max_skew_s=-1)


def _small_recording(tmp_path, n=10, fps=30.0):
    rng = np.random.default_rng(0)
    frames = []
    for i in range(n):
        img = rng.integers(0, 255, (24, 32), dtype=np.uint8)
        frames.append(
            StereoFrame(img, img, i / fps, i / fps + 0.001, i, Odometry((0.01 * i, 0, 0)), (0, 0.1, 0))
        )
    write_pairs(tmp_path, frames)
    return tmp_path


def test_recorded_folder_round_trip_and_poses(tmp_path):
    folder = _small_recording(tmp_path)
    src = FolderPairs(folder)
    ev = [src.read() for _ in range(11)]
    assert [e.status for e in ev] == [FRAME] * 10 + [END]
    f = ev[4].frame
    assert f.t_left_s == pytest.approx(4 / 30, abs=1e-5) and f.skew_s == pytest.approx(0.001, abs=1e-5)
    assert f.odometry.position_m[0] == pytest.approx(0.04) and f.body_rpy == pytest.approx((0, 0.1, 0))
    assert f.odometry.stamp_s == pytest.approx(4 / 30, abs=1e-5)  # the pose's recorded time
    looped = FolderPairs(folder, loop=True)
    times, stamps = [], []
    for _ in range(25):
        frame = looped.read().frame
        times.append(frame.t_left_s)
        stamps.append(frame.odometry.stamp_s)
    assert np.all(np.diff(times) > 0)  # repeats keep time going forward
    assert np.all(np.diff(stamps) > 0)  # and so do the poses' stamps (odometry.PoseJumps)
    # The first pair of each later round says the source started over (the loop then
    # forgets the odometry's jumps: the poses start over with the images).
    looped = FolderPairs(folder, loop=True)
    restarts = [looped.read().frame.restart for _ in range(25)]
    assert [i for i, r in enumerate(restarts) if r] == [10, 20]
    # As the live loop feeds them: the poses' way back to the start (here 0.9 m in a
    # frame's time, a jump of the frame otherwise) is no jump.
    img = np.zeros((24, 32), np.uint8)
    walk = [StereoFrame(img, img, i / 30, i / 30, i, Odometry((0.1 * i, 0, 0)), (0, 0, 0)) for i in range(10)]
    write_pairs(folder / "walk", walk)
    jumps, looped = PoseJumps(), FolderPairs(folder / "walk", loop=True)
    for _ in range(25):
        frame = looped.read().frame
        if frame.restart:
            jumps.reset()
        assert jumps.correct(frame.odometry).position_m == frame.odometry.position_m
    assert jumps.jumps == 0


def test_a_long_pause_is_shortened_for_the_pairs_not_for_the_poses_clock(tmp_path):
    """A replay shortens a long pause between pairs; the poses keep their recorded times,
    so the travel in the pause is not judged a jump of the odometry's frame."""
    img = np.zeros((24, 32), np.uint8)
    frames = [
        StereoFrame(img, img, t, t, i, Odometry((0.5 * t, 0, 0)), (0, 0, 0))
        for i, t in enumerate([0.0, 0.1, 10.1])
    ]
    write_pairs(tmp_path, frames)
    src = FolderPairs(tmp_path)
    got = [src.read().frame for _ in range(3)]
    assert got[2].t_left_s == pytest.approx(0.1 + MAX_REPLAY_GAP_S)
    assert got[2].odometry.stamp_s == pytest.approx(10.1)


def test_paced_replay_gives_the_newest_pair_and_never_queues(tmp_path):
    folder = _small_recording(tmp_path)
    clock = FakeClock()
    paced = Paced(FolderPairs(folder), clock=clock)
    first = paced.read()
    assert first.frame.index == 0 and first.frame.t_right_s == pytest.approx(clock())
    assert paced.read().status == NONE  # the next pair's time has not come
    clock.sleep(0.11)  # the loop was busy for 110 ms: pairs 1, 2, 3 came meanwhile
    ev = paced.read()
    assert ev.frame.index == 3 and ev.skipped == 2
    assert ev.frame.t_right_s == pytest.approx(100.0 + 3 / 30, abs=1e-5)
    clock.sleep(10.0)
    ev = paced.read()
    assert ev.frame.index == 9 and ev.skipped == 5 and paced.read().status == END
    with pytest.raises(ConfigError, match="speed"):
        Paced(FolderPairs(folder), speed=0.0)


def test_corrupt_image_in_a_recording_is_unreadable(tmp_path):
    folder = _small_recording(tmp_path, n=3)
    (folder / "left_000001.png").write_bytes(b"\x89PNG garbage")
    src = FolderPairs(folder)
    assert [src.read().status for _ in range(4)] == [FRAME, UNREADABLE, FRAME, END]


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (None, "has no pairs.csv"),
        ("a,b\n1,2\n", "must have the columns"),
        ("t_left,t_right,left,right\n", "lists no pairs"),
        ("t_left,t_right,left,right\nx,0,l.png,r.png\n", "line 2: times"),
        ("t_left,t_right,left,right\n0,nan,l.png,r.png\n", "line 2: times must be finite"),
    ],
)
def test_bad_recordings_are_clear_errors(tmp_path, content, match):
    if content is not None:
        (tmp_path / "pairs.csv").write_text(content)
    with pytest.raises(InputError, match=match):
        read_pairs_index(tmp_path)


def test_bad_rows_among_good_ones_are_left_out_and_said(tmp_path, caplog):
    """A bad row of a recording is a bad frame, not a bad recording (found in review: one
    bad timestamp refused the whole replay): left out, with one warning; a pose that is not
    finite leaves its row without a pose."""
    folder = _small_recording(tmp_path, n=4)
    lines = (folder / "pairs.csv").read_text().splitlines()
    head = lines[0].split(",")
    x_col = head.index("x")
    decreasing = lines[2].split(",")
    decreasing[head.index("t_left")] = decreasing[head.index("t_right")] = "-5"
    not_a_pose = lines[3].split(",")
    not_a_pose[x_col] = "nan"
    lines[2], lines[3] = ",".join(decreasing), ",".join(not_a_pose)
    (folder / "pairs.csv").write_text("\n".join(lines) + "\n")
    with caplog.at_level("WARNING"):
        rows = read_pairs_index(folder)
    assert len(rows) == 3 and rows[1].pose is None and rows[2].pose is not None
    assert "1 bad row(s) left out" in caplog.text and "line 3: pair times must not decrease" in caplog.text


def test_one_row_far_ahead_in_time_is_the_one_left_out(tmp_path, caplog):
    """Found in review: a row 1e6 s ahead made every later row "earlier than the row
    before" and left out the rest of the recording; it is that row that is wrong."""
    folder = _small_recording(tmp_path, n=10)
    lines = (folder / "pairs.csv").read_text().splitlines()
    head = lines[0].split(",")
    glitch = lines[3].split(",")
    glitch[head.index("t_left")] = glitch[head.index("t_right")] = "1e6"
    lines[3] = ",".join(glitch)
    (folder / "pairs.csv").write_text("\n".join(lines) + "\n")
    with caplog.at_level("WARNING"):
        rows = read_pairs_index(folder)
    assert len(rows) == 9 and "line 4" in caplog.text
    # a file mostly of bad rows is no recording to replay
    t_col = head.index("t_left")
    garbled = [",".join(c if k != t_col else "x" for k, c in enumerate(r.split(","))) for r in lines[2:]]
    (folder / "pairs.csv").write_text("\n".join([lines[0], lines[1], *garbled]) + "\n")
    with pytest.raises(InputError, match="most rows are bad"):
        read_pairs_index(folder)


def test_a_repeated_row_is_left_out_and_said(tmp_path, caplog):
    """Found in review: a row of ``pairs.csv`` given twice (or two rows with the same
    times and the same images, the pose aside) replayed that frame twice. The repeat is a
    bad row: left out, with the warning; a file mostly of repeats is still refused."""
    folder = _small_recording(tmp_path, n=4)
    lines = (folder / "pairs.csv").read_text().splitlines()
    head = lines[0].split(",")
    other_pose = lines[2].split(",")
    other_pose[head.index("x")] = "7"
    written_otherwise = lines[3].split(",")
    written_otherwise[head.index("index")] = "99"
    written_otherwise[head.index("t_left")] += "0"
    written_otherwise[head.index("left")] = "./" + written_otherwise[head.index("left")]
    repeats = [lines[2], ",".join(other_pose), lines[3], ",".join(written_otherwise)]
    rows_in = [lines[1], lines[2], *repeats, lines[4]]
    (folder / "pairs.csv").write_text("\n".join([lines[0], *rows_in]) + "\n")
    with caplog.at_level("WARNING"):
        rows = read_pairs_index(folder)
    assert [r.left.name for r in rows] == [f"left_{i:06d}.png" for i in range(4)]
    assert rows[1].pose[0] == pytest.approx(0.01)  # the first of the repeats is kept
    assert "3 bad row(s) left out" in caplog.text and "line 4: a repeat of line 3" in caplog.text
    assert len(FolderPairs(folder)) == 4
    (folder / "pairs.csv").write_text("\n".join([lines[0], lines[1], lines[1], lines[1]]) + "\n")
    with pytest.raises(InputError, match="most rows are bad"):
        read_pairs_index(folder)


def test_looped_replay_of_equal_times_goes_forward(tmp_path):
    import csv

    folder = _small_recording(tmp_path, n=3)
    with (folder / "pairs.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    with (folder / "pairs.csv").open("w", newline="") as fh:
        out = csv.DictWriter(fh, fieldnames=list(rows[0]))
        out.writeheader()
        out.writerows({**r, "t_left": "0", "t_right": "0"} for r in rows)
    looped = FolderPairs(folder, loop=True)
    times = [looped.read().frame.t_left_s for _ in range(7)]
    assert times[3] > times[0] and times[6] > times[3]  # each repeat later than the last


def test_a_bad_body_pose_is_ignored_counted_and_the_loop_goes_on(scene, pipeline):
    clock = FakeClock()
    t0 = clock()
    nan_attitude = StereoFrame(
        scene.left, scene.right, t0 + 0.03, t0 + 0.03, 1, Odometry((0, 0, 0)), (0, math.nan, 0)
    )
    nan_position = StereoFrame(
        scene.left, scene.right, t0 + 0.06, t0 + 0.06, 2, Odometry((math.inf, 0, 0)), None
    )
    script = [(t0, _frame(scene, t0, 0)), (t0 + 0.03, nan_attitude), (t0 + 0.06, nan_position)]
    script.append((t0 + 0.09, _frame(scene, t0 + 0.09, 3)))
    msgs = []
    loop = LiveLoop(
        Capture(ScriptedCamera(clock, script)), pipeline, msgs.append, clock=clock, sleep=clock.sleep
    )
    s = loop.run()
    assert s.processed == 4 and s.bad_poses == 2 and "bad poses ignored 2" in s.format()
    fresh = {m.frame_index: m for m in msgs if not m.stale}
    assert (
        fresh[1].quality & terrain_t.QUALITY_POSE_MISSING
        and fresh[2].quality & terrain_t.QUALITY_POSE_MISSING
    )
    assert fresh[3].quality & terrain_t.QUALITY_POSE_MISSING == 0


def test_heartbeats_carry_the_pose_flag_of_the_terrain_they_re_send(scene, pipeline):
    """Found in review: in a replay with poses every stale heartbeat said the pose was
    missing (a recording's poses come with its pairs, none between them). A heartbeat
    re-sends the last pair's terrain and says what that pair had; a live pose source
    (the state estimator) between pairs counts as a pose."""
    clock = FakeClock()
    t0 = clock()
    no_pose = StereoFrame(scene.left, scene.right, t0 + 1.0, t0 + 1.0, 1)
    script = [(t0, _frame(scene, t0, 0)), (t0 + 1.0, no_pose), (t0 + 2.0, _frame(scene, t0 + 2.0, 2))]
    msgs = []
    config = LoopConfig(poll_s=0.01, stall_timeout_s=0.5, heartbeat_s=0.1)
    camera = Capture(ScriptedCamera(clock, script))
    s = LiveLoop(camera, pipeline, msgs.append, config=config, clock=clock, sleep=clock.sleep).run()
    assert s.processed == 3 and s.heartbeats > 4
    missing = {m.frame_index: [] for m in msgs}
    for m in msgs:
        missing[m.frame_index].append(bool(m.quality & terrain_t.QUALITY_POSE_MISSING))
    assert missing[0] == [False] * len(missing[0]) and len(missing[0]) > 2  # the pair, its heartbeats
    assert missing[1] == [True] * len(missing[1]) and len(missing[1]) > 2
    assert missing[2] == [False]
    # a live pose between pairs: the heartbeats after a pair without one have a pose
    clock = FakeClock()
    t0 = clock()
    script = [(t0, StereoFrame(scene.left, scene.right, t0, t0, 0)), (t0 + 1.0, _frame(scene, t0 + 1.0, 1))]
    msgs = []

    def live(frame):
        return (None, None) if frame is not None else (Odometry((0.1, 0.0, 0.0)), None)

    LiveLoop(
        Capture(ScriptedCamera(clock, script)), pipeline, msgs.append, pose=live, config=config, clock=clock,
        sleep=clock.sleep,
    ).run()  # fmt: skip
    flags = [(m.stale, bool(m.quality & terrain_t.QUALITY_POSE_MISSING)) for m in msgs]
    assert flags[0] == (False, True) and len(flags) > 3 and all(f == (True, False) for f in flags[1:-1])


def test_missing_folder_and_existing_recording(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_pairs_index(tmp_path / "nope")
    folder = _small_recording(tmp_path, n=1)
    with pytest.raises(InputError, match="already holds a recording"):
        write_pairs(folder, [])


def test_message_round_trip(scene, pipeline):
    msgs = []
    LiveLoop(
        Capture(Paced(FrameSource([_frame(scene, 0.0, 0)]), realtime=False)), pipeline, msgs.append
    ).run()
    m = terrain_t.decode(msgs[0].encode())
    assert m.obstacle == terrain_t.OBSTACLE_STAIRS and m.num_steps == len(m.rise_m) >= 2
    assert m.distance_m[0] == pytest.approx(1.2, abs=0.03) and m.rise_m[0] == pytest.approx(0.21, abs=0.02)
    assert math.isnan(m.trigger_distance_m)  # one frame: not yet confirmed
    assert m.trigger_phase == terrain_t.PHASE_IDLE and not m.stale and 0 < m.disparity_density <= 1


def test_videos_record_and_replay(tmp_path, scene):
    from stereo_terrain.runtime.capture import VideoPair, record_pairs

    paths = []
    for name, img in (("l.avi", scene.left), ("r.avi", scene.right)):
        w = cv2.VideoWriter(str(tmp_path / name), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (320, 240))
        if not w.isOpened():
            pytest.skip("OpenCV has no MJPG writer here")
        for _ in range(4):
            w.write(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
        w.release()
        paths.append(tmp_path / name)
    n = record_pairs(Capture(VideoPair(*paths)), tmp_path / "rec")
    assert n == 4
    rows = read_pairs_index(tmp_path / "rec")
    assert [r.t_left for r in rows] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    # Played against a clock, videos also give the newest pair only.
    clock = FakeClock()
    paced = Paced(VideoPair(*paths), clock=clock)
    assert paced.read().frame.index == 0
    clock.sleep(0.25)
    ev = paced.read()
    assert ev.frame.index == 2 and ev.skipped == 1


def test_warm_up_leaves_no_trace_in_the_drift_correction(scene):
    from stereo_terrain.drift import DriftConfig
    from stereo_terrain.pipeline import PipelineConfig

    online = Pipeline(
        scene.calibration, scene.rig, PipelineConfig(drift=DriftConfig(online=True, every_frames=1))
    )
    loop = LiveLoop(Capture(ScriptedCamera(FakeClock(), [])), online, lambda m: None)
    loop.warm_up()
    assert online.last_correction is None and online.rectifier is not None
    assert online.rectification is online.rectifier.base
    assert not online.rectifier.correction_rotvec_rad.any()


def test_one_video_and_a_missing_one_says_which(tmp_path):
    from stereo_terrain.runtime.capture import open_devices

    video = tmp_path / "left.avi"
    video.write_bytes(b"")
    with pytest.raises(InputError, match="right video .* does not exist"):
        open_devices(str(video), str(tmp_path / "missing.avi"))
    with pytest.raises(InputError, match="left video .* is a folder"):
        open_devices(str(tmp_path), str(video))


def test_a_stop_that_surfaces_as_an_error_stops_the_loop(scene, pipeline, monkeypatch):
    """SIGTERM inside a compiled kernel can surface as an ordinary error: once a stop is
    requested, that error stops the loop (interrupted) instead of counting as a failed
    frame after which the loop goes on."""
    from stereo_terrain.runtime.loop import request_stop

    real_run = pipeline.run
    calls = {"n": 0}

    def interrupted(left, right, **options):
        calls["n"] += 1
        if calls["n"] == 2:
            request_stop()
            raise SystemError("error return without exception set")
        return real_run(left, right, **options)

    monkeypatch.setattr(pipeline, "run", interrupted)
    frames = [_frame(scene, float(i), i) for i in range(4)]
    src = FrameSource(frames)
    s = LiveLoop(Capture(src), pipeline, lambda m: None).run()
    assert s.interrupted and s.processed == 1 and s.failed == 0 and src.closed
    # The next loop starts afresh.
    s = LiveLoop(Capture(FrameSource([_frame(scene, 0.0, 0)])), pipeline, lambda m: None).run()
    assert not s.interrupted and s.processed == 1


def test_the_loop_takes_out_an_odometry_jump_and_publishes_the_origin_in_the_estimators_frame(
    scene, pipeline
):
    """A relocalisation (the state estimator's frame moved 1 m back between two stamped
    poses 0.1 s apart) is no travel: the loop counts it, the trigger counts on, and the
    published origin p0 is in the estimator's frame, where the controller's odometry is."""
    clock = FakeClock()
    t0 = clock()
    script = []
    cfg = ApproachConfig(image_size=(320, 240), supersample=1, start_distance_m=1.2)
    for i in range(9):
        t, x = t0 + 0.1 * i, 0.05 * i
        seen = render_scene(approach_spec(cfg, x, 0.0))  # the stairs as the body walks on
        raw_x = x - (1.0 if i >= 6 else 0.0)
        odo = Odometry((raw_x, 0.0, 0.0), 0.0, t)
        script.append((t, StereoFrame(seen.left, seen.right, t, t, i, odo, (0.0, 0.0, 0.0))))
    msgs = []
    config = LoopConfig(max_skew_s=1.0, stall_timeout_s=1e9)
    loop = LiveLoop(
        Capture(ScriptedCamera(clock, script)),
        pipeline,
        msgs.append,
        config=config,
        clock=clock,
        sleep=clock.sleep,
    )
    s = loop.run()
    assert s.processed == 9 and s.pose_jumps == 1 and "odometry jumps 1" in s.format()
    last = [m for m in msgs if not m.stale][-1]
    # The body is at x = 0.4 (estimator: -0.6); the published origin is where the
    # estimator puts the point the trigger counts from.
    # The pair of the jump publishes no distance (the estimator's frame is not known for
    # sure until the next pose confirms the shift); the pairs after it do.
    fresh = {m.frame_index: m for m in msgs if not m.stale}
    distances = [fresh[i].trigger_distance_m for i in (5, 6, 7)]
    assert math.isfinite(distances[0]) and math.isnan(distances[1]) and math.isfinite(distances[2])
    trig = loop.trigger.state
    assert trig.phase in ("approach", "raised")  # an origin that means something
    assert trig.p0_m[0] - 0.4 == pytest.approx(last.p0_m[0] - (-0.6), abs=1e-6)
    # and the remaining distance the controller computes from its own odometry is the
    # trigger's, not a metre off
    assert trig.trigger_distance_m - (-0.6 - last.p0_m[0]) == pytest.approx(trig.remaining_m - 0.1, abs=0.01)
