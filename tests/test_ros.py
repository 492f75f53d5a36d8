"""ROS 2 output and input: MCAP written by replay/reconstruct, bags written by other tools
replayed, the calibration from CameraInfo, the Rerun recording."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")
pytest.importorskip("rosbags")

from stereo_terrain.calibration import read_calibration  # noqa: E402
from stereo_terrain.cli import main  # noqa: E402
from stereo_terrain.frames import Transform, load_rig  # noqa: E402
from stereo_terrain.pipeline import Pipeline  # noqa: E402
from stereo_terrain.rectify import compute_rectification, read_image, rectify  # noqa: E402
from stereo_terrain.ros import TERRAIN_TYPE  # noqa: E402
from stereo_terrain.ros.bag import (  # noqa: E402
    calibration_from_camera_info,
    camera_info_fields,
    info_topic,
)
from stereo_terrain.ros.messages import terrain_fields, terrain_msgdef  # noqa: E402
from stereo_terrain.runtime.messages import terrain_t  # noqa: E402

from .cli_run import run_cli  # noqa: E402
from .ros_bags import (  # noqa: E402
    T0_S,
    bag_messages,
    read_mcap,
    render_recording,
    write_mcap_ros2,
    write_rosbag2,
)

N_PAIRS = 3
TOPICS = {
    "/tf": "tf2_msgs/msg/TFMessage",
    "/stereo_terrain/cloud": "sensor_msgs/msg/PointCloud2",
    "/stereo_terrain/stairs": "visualization_msgs/msg/MarkerArray",
    "/stereo_terrain/terrain": TERRAIN_TYPE,
    "/stereo_terrain/left/image_rect": "sensor_msgs/msg/Image",
    "/stereo_terrain/left/camera_info": "sensor_msgs/msg/CameraInfo",
    "/stereo_terrain/disparity": "sensor_msgs/msg/Image",
}
#: Plane fit residual allowed for a cloud point labelled with a plane (its MSAC threshold is
#: a few cm at these depths; the JSON rounds offsets to 0.1 mm).
PLANE_TOL_M = 0.08


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ros") / "rec"
    scene = render_recording(folder, N_PAIRS)
    return folder, scene


@pytest.fixture(scope="module")
def png_mcap(rec, tmp_path_factory):
    """The MCAP of ``replay REC`` (the PNG recording)."""
    folder, _ = rec
    out = tmp_path_factory.mktemp("out") / "png.mcap"
    assert main(["replay", str(folder), "--no-lcm", "--as-fast", "--quiet", "--mcap", str(out)]) == 0
    return out


def _cloud_points(msg):
    fields = {f.name: (f.offset, f.datatype) for f in msg.fields}
    assert set(fields) >= {"x", "y", "z", "plane", "rgb"}
    raw = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.width * msg.height, msg.point_step)
    xyz = np.stack([raw[:, fields[c][0] : fields[c][0] + 4].copy().view("<f4")[:, 0] for c in "xyz"], axis=1)
    labels = raw[:, fields["plane"][0] : fields["plane"][0] + 4].copy().view("<i4")[:, 0]
    return xyz, labels


def _terrain_steps(decoded):
    return [
        (list(np.round(m.rise_m, 6)), list(np.round(m.distance_m, 6)), m.obstacle, m.num_steps)
        for _, m in decoded["/stereo_terrain/terrain"]
    ]


# --------------------------------------------------------------------------- MCAP output


def test_replay_mcap_every_message_decodes(png_mcap):
    decoded = read_mcap(png_mcap)
    assert set(decoded) == set(TOPICS)
    for topic, typ in TOPICS.items():
        assert len(decoded[topic]) == N_PAIRS, topic
        assert {name for name, _ in decoded[topic]} == {typ}
    # One PointCloud2, one MarkerArray and the tf per processed pair, stamped alike.
    for k in range(N_PAIRS):
        stamps = {
            (m.header.stamp.sec, m.header.stamp.nanosec)
            for topic in ("/stereo_terrain/cloud", "/stereo_terrain/terrain", "/stereo_terrain/disparity")
            for m in [decoded[topic][k][1]]
        }
        assert len(stamps) == 1
    _, img = decoded["/stereo_terrain/left/image_rect"][0]
    assert (img.encoding, img.width, img.height) == ("mono8", 320, 240)
    _, disp = decoded["/stereo_terrain/disparity"][0]
    d = np.frombuffer(bytes(disp.data), dtype="<f4").reshape(disp.height, disp.width)
    assert disp.encoding == "32FC1" and np.isnan(d).any() and np.nanmax(d) > 1.0
    _, stairs = decoded["/stereo_terrain/stairs"][0]
    assert stairs.markers[0].action == 3  # DELETEALL first
    texts = [mk.text for mk in stairs.markers if mk.ns == "dimensions"]
    _, terrain = decoded["/stereo_terrain/terrain"][0]
    assert terrain.obstacle == terrain_t.OBSTACLE_STAIRS and len(texts) == terrain.num_steps >= 2
    assert f"rise {100 * terrain.rise_m[0]:.1f} cm" in texts[0]
    faces = [mk for mk in stairs.markers if mk.ns in ("risers", "treads")]
    assert {mk.type for mk in faces} == {11} and all(len(mk.points) % 3 == 0 for mk in faces)


def test_reconstruct_mcap_cloud_matches_json_planes_and_tf_resolves(rec, tmp_path, capsys):
    folder, scene = rec
    out, js = tmp_path / "one.mcap", tmp_path / "one.json"
    left, right = folder / "left_000000.png", folder / "right_000000.png"
    argv = ["reconstruct", left, right, "--calib", folder / "calib.yaml", "--rig", folder / "rig.yaml"]
    code, _, err = run_cli([*argv, "--json", js, "--mcap", out], capsys)
    assert code == 0, err
    result = json.loads(js.read_text())
    decoded = read_mcap(out)
    assert all(len(decoded[t]) == 1 for t in TOPICS)
    # The cloud: each labelled point lies on its plane of the JSON result, as many as its inliers.
    _, cloud = decoded["/stereo_terrain/cloud"][0]
    assert cloud.header.frame_id == "yaw"
    xyz, labels = _cloud_points(cloud)
    assert len(result["planes"]) >= 3 and labels.max() == len(result["planes"]) - 1
    for k, plane in enumerate(result["planes"]):
        on = xyz[labels == k]
        assert len(on) == plane["inliers"]
        resid = on @ np.array(plane["normal"]) + plane["offset"]
        assert np.percentile(np.abs(resid), 95) < PLANE_TOL_M
        assert abs(np.sqrt(np.mean(resid**2)) - plane["rms"]) < 2e-3
    # tf: camera_rect -> camera -> body -> yaw resolves to the pipeline's T_yaw_camera_rect.
    _, tf = decoded["/tf"][0]
    parent = {}
    for t in tf.transforms:
        q, p = t.transform.rotation, t.transform.translation
        from scipy.spatial.transform import Rotation

        T = Transform.from_rt(
            Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix(),
            [p.x, p.y, p.z],
            t.header.frame_id,
            t.child_frame_id,
        )
        parent[t.child_frame_id] = T
    chain, frame = [], "camera_rect"
    while frame in parent:
        chain.append(parent[frame])
        frame = parent[frame].to_frame
    assert frame == "yaw" and [T.from_frame for T in chain] == ["camera_rect", "camera", "body"]
    T_yaw_rect = chain[2] @ chain[1] @ chain[0]
    pipeline = Pipeline(read_calibration(folder / "calib.yaml"), load_rig(folder / "rig.yaml"))
    truth = pipeline.run(read_image(left), read_image(right)).T_yaw_camera_rect
    assert np.allclose(T_yaw_rect.matrix, truth.matrix, atol=1e-9)
    assert np.allclose(chain[1].matrix, scene.rig.T_body_camera.matrix, atol=1e-9)  # body -> camera = rig


def test_replay_tf_has_world_from_recorded_poses(png_mcap):
    decoded = read_mcap(png_mcap)
    xs = []
    for _, tf in decoded["/tf"]:
        world = [t for t in tf.transforms if t.header.frame_id == "world"]
        assert len(world) == 1 and world[0].child_frame_id == "yaw"
        xs.append(world[0].transform.translation.x)
    assert np.allclose(xs, [0.0, 0.05, 0.10])


def test_terrain_schema_follows_the_lcm_fields():
    text = terrain_msgdef()
    body = [ln for ln in text.splitlines() if ln and not ln.startswith("#") and "=" not in ln]
    assert body[0] == "std_msgs/Header header"
    assert [ln.split()[1] for ln in body[1:]] == list(terrain_t.__slots__)
    assert dict(terrain_fields())["rise_m"] == "float32[]" and dict(terrain_fields())["p0_m"] == "float64[3]"
    assert "int8 OBSTACLE_STAIRS=1" in text and "int32 QUALITY_POSE_MISSING=16" in text


def test_interrupted_loop_leaves_a_complete_file(rec, tmp_path, capsys, monkeypatch):
    folder, _ = rec
    real_run = Pipeline.run
    calls = []

    def run_then_interrupt(self, left, right, **options):
        calls.append(1)
        if len(calls) == 3:  # warm-up, pair 0, then Ctrl-C during pair 1
            raise KeyboardInterrupt
        return real_run(self, left, right, **options)

    monkeypatch.setattr(Pipeline, "run", run_then_interrupt)
    out = tmp_path / "stopped.mcap"
    code, stdout, _ = run_cli(["replay", folder, "--no-lcm", "--as-fast", "--quiet", "--mcap", out], capsys)
    assert code == 0 and "interrupted" in stdout
    decoded = read_mcap(out)
    assert len(decoded["/stereo_terrain/cloud"]) == 1 and len(decoded["/tf"]) == 1
    assert [p.name for p in tmp_path.iterdir()] == ["stopped.mcap"]


def test_failed_replay_leaves_no_mcap(rec, tmp_path, capsys):
    folder, _ = rec
    bad = tmp_path / "calib.yaml"
    calib = read_calibration(folder / "calib.yaml")
    from dataclasses import replace

    from stereo_terrain.calibration import write_opencv_yaml

    write_opencv_yaml(replace(calib, image_size=(640, 480)), bad)
    out = tmp_path / "x.mcap"
    code, _, err = run_cli(["replay", folder, "--calib", bad, "--no-lcm", "--as-fast", "--mcap", out], capsys)
    assert code == 2 and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calib.yaml"]


# --------------------------------------------------------------------------- bags as input


@pytest.mark.parametrize("kind", ["rosbag2", "rosbag2-sqlite", "mcap-compressed"])
def test_bag_written_by_another_tool_replays_like_the_png_recording(rec, png_mcap, tmp_path, capsys, kind):
    folder, scene = rec
    ts, msgs = bag_messages(scene, N_PAIRS, compressed=kind == "mcap-compressed", odom=True)
    if kind.startswith("rosbag2"):
        bag = tmp_path / "bag"
        write_rosbag2(bag, ts, msgs, sqlite=kind.endswith("sqlite"))
        left, right = "/stereo/left/image_raw", "/stereo/right/image_raw"
    else:
        bag = tmp_path / "bag.mcap"
        write_mcap_ros2(bag, ts, msgs)
        left, right = "/stereo/left/image_raw/compressed", "/stereo/right/image_raw/compressed"
    out = tmp_path / "out.mcap"
    argv = ["replay", bag, "--left-topic", left, "--right-topic", right, "--odom-topic", "/odom"]
    argv += ["--calib", folder / "calib.yaml", "--rig", folder / "rig.yaml"]
    code, _, err = run_cli([*argv, "--no-lcm", "--as-fast", "--quiet", "--mcap", out], capsys)
    assert code == 0, err
    got, want = read_mcap(out), read_mcap(png_mcap)
    for topic in ("/stereo_terrain/cloud", "/stereo_terrain/stairs", "/tf"):
        assert len(got[topic]) == N_PAIRS
    assert _terrain_steps(got) == _terrain_steps(want)
    # Stamped with the bag's header stamps (the later image of each pair), not the loop's clock.
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for _, m in got["/stereo_terrain/cloud"]]
    assert np.allclose(stamps, T0_S + 0.1 * np.arange(N_PAIRS) + 0.002, atol=1e-6)
    xs = [
        t.transform.translation.x
        for _, tf in got["/tf"]
        for t in tf.transforms
        if t.header.frame_id == "world"
    ]
    assert np.allclose(xs, [0.0, 0.05, 0.10])  # odometry from the bag


def test_camera_info_gives_the_yaml_rectification(rec):
    folder, _ = rec
    calib = read_calibration(folder / "calib.yaml")

    class Info:
        def __init__(self, fields):
            self.__dict__.update(fields)

    left, right = camera_info_fields(calib)
    got = calibration_from_camera_info(Info(left), Info(right))
    for name in ("K1", "D1", "K2", "D2", "R", "T"):
        assert np.allclose(getattr(got, name), getattr(calib, name), atol=1e-9), name
    assert got.image_size == calib.image_size
    a, b = compute_rectification(calib), compute_rectification(got)
    for name in ("R1", "R2", "P1", "P2", "Q"):
        assert np.allclose(getattr(a, name), getattr(b, name), atol=1e-7), name
    assert abs(a.baseline_m - b.baseline_m) < 1e-12 + 1e-9 * a.baseline_m
    l_img, r_img = read_image(folder / "left_000000.png"), read_image(folder / "right_000000.png")
    ra, rb = rectify(l_img, r_img, a), rectify(l_img, r_img, b)
    assert np.mean(ra.left != rb.left) < 1e-3 and np.mean(ra.right != rb.right) < 1e-3


def test_camera_info_only_bag_replays_like_the_yaml(rec, png_mcap, tmp_path, capsys):
    folder, scene = rec
    infos = camera_info_fields(read_calibration(folder / "calib.yaml"))
    ts, msgs = bag_messages(scene, N_PAIRS, infos=infos, odom=True)
    bag = tmp_path / "bag"
    write_rosbag2(bag, ts, msgs)
    shutil.copy(folder / "rig.yaml", tmp_path / "rig.yaml")
    out = tmp_path / "out.mcap"
    argv = [
        "replay",
        bag,
        "--left-topic",
        "/stereo/left/image_raw",
        "--right-topic",
        "/stereo/right/image_raw",
    ]
    code, _, err = run_cli(
        [
            *argv,
            "--rig",
            tmp_path / "rig.yaml",
            "--no-lcm",
            "--as-fast",
            "--quiet",
            "--odom-topic",
            "/odom",
            "--mcap",
            out,
        ],
        capsys,
    )
    assert code == 0, err
    got, want = read_mcap(out), read_mcap(png_mcap)
    for (g_rise, g_dist, g_obs, g_n), (w_rise, w_dist, w_obs, w_n) in zip(
        _terrain_steps(got), _terrain_steps(want), strict=True
    ):
        assert (g_obs, g_n) == (w_obs, w_n)
        assert np.allclose(g_rise, w_rise, atol=2e-3) and np.allclose(g_dist, w_dist, atol=2e-3)


def test_info_topic_beside_the_image_topic():
    assert info_topic("/stereo/left/image_raw") == "/stereo/left/camera_info"
    assert info_topic("/stereo/left/image_raw/compressed") == "/stereo/left/camera_info"
    assert info_topic("/image") == "/camera_info"


@pytest.mark.parametrize(
    "extra, match",
    [
        ([], "give --left-topic and --right-topic"),
        (["--left-topic", "/nope", "--right-topic", "/stereo/right/image_raw"], "no such topic"),
        (["--left-topic", "/odom", "--right-topic", "/stereo/right/image_raw"], "expected sensor_msgs"),
        (
            ["--left-topic", "/stereo/left/image_raw", "--right-topic", "/stereo/right/image_raw"],
            "no --calib given",
        ),
    ],
)
def test_bag_mistakes_are_one_line_exit_2(rec, tmp_path, capsys, extra, match):
    _, scene = rec
    ts, msgs = bag_messages(scene, 1, odom=True)
    bag = tmp_path / "bag"
    write_rosbag2(bag, ts, msgs)
    code, _, err = run_cli(["replay", bag, "--no-lcm", "--as-fast", *extra], capsys)
    assert code == 2 and match in err and err.count("\n") == 1


def test_bag_options_on_a_png_folder_are_refused(rec, capsys):
    folder, _ = rec
    code, _, err = run_cli(["replay", folder, "--no-lcm", "--left-topic", "/l"], capsys)
    assert code == 2 and "is for a ROS bag" in err


# --------------------------------------------------------------------------- Rerun


def test_view_save_writes_a_rerun_recording(rec, tmp_path, capsys):
    pytest.importorskip("rerun")
    folder, _ = rec
    out = tmp_path / "view.rrd"
    code, _, err = run_cli(["replay", folder, "--no-lcm", "--as-fast", "--quiet", "--view-save", out], capsys)
    assert code == 0, err
    assert out.stat().st_size > 10_000 and [p.name for p in tmp_path.iterdir()] == ["view.rrd"]
    rerun = shutil.which("rerun") or str(Path(__import__("sys").executable).parent / "rerun")
    if not Path(rerun).exists():
        pytest.skip("the rerun command line is not installed: size checked only")
    verified = subprocess.run([rerun, "rrd", "verify", str(out)], capture_output=True, text=True, timeout=60)
    assert verified.returncode == 0, verified.stderr
    printed = subprocess.run([rerun, "rrd", "print", str(out)], capture_output=True, text=True, timeout=60)
    assert printed.returncode == 0, printed.stderr
    for entity, component in (
        ("world/yaw/cloud", "Points3D:positions"),
        ("world/yaw/polytope/faces", "Mesh3D"),
        ("camera_rect/image", "Image"),
        ("camera_rect/image/planes", "SegmentationImage"),
        ("camera_rect/disparity", "DepthImage"),
        ("world/yaw/body", "Transform3D"),
        ("swing/height_m", "Scalars"),
    ):
        lines = [ln for ln in printed.stdout.splitlines() if f"{entity} -" in ln]
        assert any(component in ln for ln in lines), (entity, component)


def test_mcap_opens_in_rerun(png_mcap, tmp_path):
    rerun = shutil.which("rerun") or str(Path(__import__("sys").executable).parent / "rerun")
    if not Path(rerun).exists():
        pytest.skip("the rerun command line is not installed")
    out = tmp_path / "conv.rrd"
    conv = subprocess.run(
        [rerun, "mcap", "convert", str(png_mcap), "-o", str(out)], capture_output=True, text=True, timeout=120
    )
    assert conv.returncode == 0, conv.stderr
    printed = subprocess.run([rerun, "rrd", "print", str(out)], capture_output=True, text=True, timeout=60)
    text = printed.stdout
    for topic, component in (
        ("/stereo_terrain/cloud", "Points3D:positions"),
        ("/tf", "Transform3D"),
        ("/stereo_terrain/left/camera_info", "Pinhole"),
        ("/stereo_terrain/disparity", "Image"),
    ):
        assert any(component in ln for ln in text.splitlines() if f"- {topic} -" in ln), topic


def test_reconstruct_without_rig_mcap_and_view_save(rec, tmp_path, capsys):
    folder, _ = rec
    out, rrd = tmp_path / "h.mcap", tmp_path / "h.rrd"
    argv = [
        "reconstruct",
        folder / "left_000000.png",
        folder / "right_000000.png",
        "--calib",
        folder / "calib.yaml",
    ]
    code, _, err = run_cli([*argv, "--mcap", out, "--view-save", rrd], capsys)
    assert code == 0, err
    decoded = read_mcap(out)
    assert len(decoded["/stereo_terrain/stairs"]) == 1 and rrd.stat().st_size > 10_000
    # Without a rig the body frame is the levelled yaw frame: yaw -> body is the identity.
    _, tf = decoded["/tf"][0]
    yaw_body = [t.transform for t in tf.transforms if t.child_frame_id == "body"][0]
    assert yaw_body.rotation.w == pytest.approx(1.0) and yaw_body.translation.z == 0.0


def test_stale_heartbeat_goes_on_the_terrain_topic(rec, tmp_path):
    from stereo_terrain.ros.mcap_out import McapSink
    from stereo_terrain.runtime.capture import StereoFrame
    from stereo_terrain.runtime.messages import terrain_message
    from stereo_terrain.swing import SwingTrigger

    folder, _ = rec
    pipeline = Pipeline(read_calibration(folder / "calib.yaml"), load_rig(folder / "rig.yaml"))
    left, right = read_image(folder / "left_000000.png"), read_image(folder / "right_000000.png")
    result = pipeline.run(left, right)
    trig = SwingTrigger(pipeline.config.swing).update(None, result.terrain)

    def msg(publish_s, stale):
        return terrain_message(
            result.terrain, trig, capture_s=10.0, publish_s=publish_s, frame_index=0, latency_s=0.05,
            density=0.9, quality=0, stale=stale, epoch_offset_s=T0_S,
        )  # fmt: skip

    out = tmp_path / "hb.mcap"
    with McapSink(out, epoch_offset_s=T0_S) as sink:
        sink.publish(msg(10.05, False))
        sink.on_result(StereoFrame(left, right, 10.0, 10.0, 0), result)
        sink.publish(msg(10.7, True))  # a heartbeat: no result follows
    terrain = [m for _, m in read_mcap(out)["/stereo_terrain/terrain"]]
    assert [m.stale for m in terrain] == [False, True]
    assert all(m.header.stamp.sec == int(T0_S + 10.0) for m in terrain)
    from mcap.reader import make_reader

    with out.open("rb") as fh:
        times = [
            msg.log_time for _, ch, msg in make_reader(fh).iter_messages() if ch.topic.endswith("terrain")
        ]
    assert times[1] - times[0] == pytest.approx(0.7e9, abs=1e3)


def test_humble_definitions(rec, tmp_path):
    from mcap.reader import make_reader

    from stereo_terrain.ros.mcap_out import McapSink

    folder, _ = rec
    pipeline = Pipeline(read_calibration(folder / "calib.yaml"))
    result = pipeline.run(read_image(folder / "left_000000.png"), read_image(folder / "right_000000.png"))
    schemas = {}
    for distro in ("humble", "jazzy"):
        with McapSink(tmp_path / f"{distro}.mcap", distro=distro) as sink:
            sink.write_result(result, 1)
        with (tmp_path / f"{distro}.mcap").open("rb") as fh:
            schemas[distro] = {
                s.name: s.data.decode() for s in make_reader(fh).get_summary().schemas.values()
            }
        assert len(read_mcap(tmp_path / f"{distro}.mcap")["/stereo_terrain/stairs"]) == 1
    marker = "visualization_msgs/msg/MarkerArray"
    assert "ARROW_STRIP" in schemas["jazzy"][marker] and "ARROW_STRIP" not in schemas["humble"][marker]


def test_mcap_figure_is_drawn_from_the_file(png_mcap, tmp_path):
    pytest.importorskip("matplotlib")
    from stereo_terrain.viz.mcap_figure import read_pair, save_mcap_figure, transform_between

    out = tmp_path / "fig.png"
    save_mcap_figure(png_mcap, out, pair=1)
    assert out.stat().st_size > 20_000
    tf = read_pair(png_mcap, 1)["/tf"]
    T = transform_between(tf, "camera_rect", "yaw") @ transform_between(tf, "yaw", "camera_rect")
    assert np.allclose(T, np.eye(4), atol=1e-9)
    assert np.allclose(transform_between(tf, "world", "yaw")[:3, 3], [0.05, 0.0, 0.0])


def _mcap_figure(argv, capsys) -> tuple[int, str, str]:
    """``python -m stereo_terrain.viz.mcap_figure ARGV`` in this process."""
    from stereo_terrain.viz.mcap_figure import main as figure_main

    from .cli_run import run_cli

    return run_cli(argv, capsys, figure_main)


def test_mcap_figure_command_draws_and_says_so(png_mcap, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    code, out, err = _mcap_figure([png_mcap, tmp_path / "fig.png", 1], capsys)
    assert code == 0, err
    assert out.strip() == f"wrote {tmp_path / 'fig.png'}" and (tmp_path / "fig.png").stat().st_size > 20_000


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda d, good: d / "nope.mcap", "MCAP file not found"),
        (lambda d, good: d, "is not a file"),
        (lambda d, good: _write_bytes(d / "empty.mcap", b""), "as an MCAP file (EndOfFile)"),
        (lambda d, good: _write_bytes(d / "cut.mcap", good.read_bytes()[:5000]), "not an empty or cut-off"),
        (lambda d, good: _write_bytes(d / "junk.mcap", b"not an mcap file at all" * 10), "as an MCAP file"),
    ],
)  # fmt: skip
def test_mcap_figure_bad_file_is_one_line_exit_2(png_mcap, tmp_path, capsys, make, match):
    pytest.importorskip("matplotlib")
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier figure")
    code, _, err = _mcap_figure([make(tmp_path, png_mcap), out], capsys)
    assert code == 2 and match in err, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert out.read_bytes() == b"earlier figure"  # not clobbered
    assert sorted(p.name for p in tmp_path.glob(".keep*")) == []  # no temporary left


def test_mcap_figure_of_a_pair_past_the_last_is_one_line_exit_2(png_mcap, tmp_path, capsys):
    """Found in review: PAIR past the file's last pair drew the last pair, silently."""
    pytest.importorskip("matplotlib")
    out = tmp_path / "fig.png"
    for pair in (N_PAIRS, N_PAIRS + 5):
        code, _, err = _mcap_figure([png_mcap, out, pair], capsys)
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
        assert f"holds {N_PAIRS} pairs" in err and f"PAIR 0 to {N_PAIRS - 1}" in err, err
        assert not out.exists() and list(tmp_path.iterdir()) == []
    code, _, err = _mcap_figure([png_mcap, out, N_PAIRS - 1], capsys)
    assert code == 0 and out.exists(), err


def test_mcap_figure_takes_the_pairs_own_terrain_among_heartbeats(rec, tmp_path, capsys):
    """Found in review: the figure took the PAIR-th message of the terrain topic, but the
    live loop's stale heartbeats go there too, so the title's steps and yaw could be a
    heartbeat's of an earlier pair. Pairs with two heartbeats after each; pair 1 sees no
    stairs; pair 2 is slow, so its own message is stale too."""
    from stereo_terrain.ros.mcap_out import McapSink
    from stereo_terrain.runtime.capture import StereoFrame
    from stereo_terrain.runtime.messages import terrain_message
    from stereo_terrain.swing import SwingTrigger
    from stereo_terrain.viz.mcap_figure import read_pair

    folder, _ = rec
    pipeline = Pipeline(read_calibration(folder / "calib.yaml"), load_rig(folder / "rig.yaml"))
    left, right = read_image(folder / "left_000000.png"), read_image(folder / "right_000000.png")
    result = pipeline.run(left, right)
    trig = SwingTrigger(pipeline.config.swing).update(None, result.terrain)
    assert result.terrain.steps  # pair 1 (no model: no steps) differs from the others

    def msg(k, model, capture_s, age_s, stale):
        return terrain_message(
            model, trig, capture_s=capture_s, publish_s=capture_s + age_s, frame_index=k, latency_s=age_s,
            density=0.9, quality=0, stale=stale, epoch_offset_s=T0_S,
        )  # fmt: skip

    out = tmp_path / "hb.mcap"
    with McapSink(out, epoch_offset_s=T0_S) as sink:
        for k, (model, age_s) in enumerate([(result.terrain, 0.05), (None, 0.05), (result.terrain, 0.8)]):
            t = 10.0 + k
            sink.publish(msg(k, model, t, age_s, stale=age_s > 0.5))
            sink.on_result(StereoFrame(left, right, t, t, k), result)
            for heartbeat_age_s in (0.9, 0.95):  # no fresh pair: the last terrain re-sent
                sink.publish(msg(k, model, t, heartbeat_age_s, stale=True))
    assert len(read_mcap(out)["/stereo_terrain/terrain"]) == 9
    for k, (steps, age_s, stale) in enumerate([(len(result.terrain.steps), 0.05, False), (0, 0.05, False),
                                               (len(result.terrain.steps), 0.8, True)]):  # fmt: skip
        terrain = read_pair(out, k)["/stereo_terrain/terrain"]
        assert (terrain.frame_index, terrain.num_steps, terrain.stale) == (k, steps, stale), k
        assert terrain.age_s == pytest.approx(age_s), k
    pytest.importorskip("matplotlib")
    code, _, err = _mcap_figure([out, tmp_path / "fig.png", 1], capsys)
    assert code == 0 and (tmp_path / "fig.png").stat().st_size > 20_000, err


def test_mcap_figure_of_a_bag_without_our_topics_is_one_line_exit_2(rec, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    _, scene = rec
    ts, msgs = bag_messages(scene, 1)
    write_mcap_ros2(tmp_path / "other.mcap", ts, msgs)
    code, _, err = _mcap_figure([tmp_path / "other.mcap", tmp_path / "fig.png"], capsys)
    assert code == 2 and "has no /stereo_terrain/" in err and "--mcap" in err and err.count("\n") == 1
    assert not (tmp_path / "fig.png").exists()


@pytest.mark.parametrize(
    "argv, match",
    [
        ([], "required: mcap, out"),
        (["in.mcap", "fig.txt"], "a figure must end in"),
        (["in.mcap", "fig.png", "-1"], "expected an integer >= 0"),
        (["in.mcap", "fig.png", "two"], "invalid int value"),
        (["in.mcap", "{tmp}/missing/fig.png"], "does not exist; create it first"),
    ],
)
def test_mcap_figure_bad_arguments_are_one_line_exit_2(tmp_path, capsys, argv, match):
    pytest.importorskip("matplotlib")
    (tmp_path / "in.mcap").write_bytes(b"")
    argv = [a.replace("in.mcap", str(tmp_path / "in.mcap")).format(tmp=tmp_path) for a in argv]
    code, _, err = _mcap_figure(argv, capsys)
    assert code == 2 and match in err, err
    assert err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize("module, extra", [("mcap", "ros"), ("mcap_ros2", "ros"), ("matplotlib", "viz")])
def test_mcap_figure_names_a_missing_extra(png_mcap, tmp_path, capsys, monkeypatch, module, extra):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as when not installed
    code, _, err = _mcap_figure([png_mcap, tmp_path / "fig.png"], capsys)
    assert code == 2 and f"pip install 'stereo-terrain[{extra}]'" in err and err.count("\n") == 1
    assert not (tmp_path / "fig.png").exists()


def _write_bytes(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def test_a_field_added_to_terrain_t_follows_into_the_ros_message(monkeypatch):
    """What another change adds to the LCM type appears in the ROS 2 message with no change
    to stereo_terrain.ros (issue 14's rise_sigma_m[num_steps] and track_state are in
    terrain_t now; two hypothetical fields stand for the next change)."""
    import stereo_terrain.ros.messages as rm

    assert "float32[] rise_sigma_m" in rm.terrain_msgdef() and "int8 track_state" in rm.terrain_msgdef()

    class Extended(terrain_t):
        __slots__ = [*terrain_t.__slots__, "extra_sigma_m", "extra_state"]
        __typenames__ = [*terrain_t.__typenames__, "float", "int8_t"]
        __dimensions__ = [*terrain_t.__dimensions__, ["num_steps"], None]
        EXTRA_LOST = 3

    monkeypatch.setattr(rm, "terrain_t", Extended)
    text = rm.terrain_msgdef()
    assert text.rstrip().endswith("float32[] extra_sigma_m\nint8 extra_state") and "EXTRA_LOST=3" in text
    assert (
        text.index("int8 OBSTACLE_NONE=0") < text.index("int32 EXTRA_LOST=3") < text.index("std_msgs/Header")
    )
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(text, TERRAIN_TYPE))
    msg = Extended()
    msg.num_steps, msg.rise_m, msg.run_m, msg.distance_m, msg.width_m = 1, [0.2], [0.3], [1.5], [1.0]
    msg.rise_sigma_m, msg.run_sigma_m, msg.distance_sigma_m, msg.width_sigma_m = (
        [0.01],
        [0.02],
        [0.03],
        [0.04],
    )
    msg.extra_sigma_m, msg.extra_state, msg.p0_m = [0.05], 2, [0.0, 0.0, 0.0]
    ros = rm.terrain_ros_message(store, msg, 5)
    back = store.deserialize_cdr(store.serialize_cdr(ros, TERRAIN_TYPE), TERRAIN_TYPE)
    assert back.extra_state == 2 and np.allclose(back.extra_sigma_m, [0.05])
    assert np.allclose(back.rise_sigma_m, [0.01])


def test_msg_package_for_colcon(tmp_path):
    from rosbags.typesys import get_types_from_msg

    from stereo_terrain.ros.messages import write_msg_package

    files = write_msg_package(tmp_path / "stereo_terrain_msgs")
    assert sorted(p.name for p in files) == ["CMakeLists.txt", "Terrain.msg", "package.xml"]
    msg = (tmp_path / "stereo_terrain_msgs" / "msg" / "Terrain.msg").read_text()
    assert get_types_from_msg(msg, TERRAIN_TYPE)[TERRAIN_TYPE][1][0][0] == "header"
    import re
    import xml.etree.ElementTree as ET

    assert ET.parse(tmp_path / "stereo_terrain_msgs" / "package.xml").getroot().find("name").text == (
        "stereo_terrain_msgs"
    )
    fields = [ln.split()[1] for ln in msg.splitlines() if ln and not ln.startswith("#") and "=" not in ln]
    assert all(re.fullmatch(r"[a-z][a-z0-9]*(_[a-z0-9]+)*", f) for f in fields)  # ROS 2 field-name rule
