"""End to end: rendered scenes through the whole pipeline, scored against their truth."""

import importlib.util
import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np
import pytest

from stereo_terrain.calibration import read_calibration
from stereo_terrain.errors import ConfigError
from stereo_terrain.evaluation import score_result, summarize
from stereo_terrain.frames import Rig, camera_mount
from stereo_terrain.gravity import VerticalLinesConfig
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import read_image, to_grey
from stereo_terrain.synthetic import default_scene_spec, random_scene_spec, render_scene
from stereo_terrain.terrain import TerrainConfig

from .rounding import premise

# The acceptance bounds.
MIN_DETECTION_RATE = 0.95
MIN_COUNT_RATE = 0.85
MAX_RISE_MEDIAN_M = 0.010
MAX_RISE_P90_M = 0.025
MAX_RUN_MEDIAN_M = 0.02
MAX_FIRST_DISTANCE_MEDIAN_M = 0.03

E2E_SEED = 2026


def e2e_specs():
    """The issue's end-to-end set: stairs and boxes (yawed by the renderer's random draw),
    3 + 1 scenes with weakly textured risers, two at 320x240, two at 1280x720, one empty."""
    rng = np.random.default_rng(E2E_SEED)
    specs = [random_scene_spec(rng, kind="stairs", weak_texture=False) for _ in range(12)]
    specs += [random_scene_spec(rng, kind="box", weak_texture=False) for _ in range(3)]
    hard = [random_scene_spec(rng, kind="stairs", weak_texture=True) for _ in range(3)]
    hard += [
        random_scene_spec(rng, kind="stairs", image_size=(320, 240), weak_texture=False) for _ in range(2)
    ]
    specs += hard
    big = [
        random_scene_spec(rng, kind="stairs", image_size=(1280, 720), weak_texture=w) for w in (False, True)
    ]
    specs += big
    specs += [random_scene_spec(rng, kind="none")]
    return specs


def _run_scores(specs):
    scores, rows = [], []
    for spec in specs:
        scene = render_scene(spec)
        result = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right)
        data = result.to_json_dict()
        scores.append(score_result(data, scene.truth))
        rows.append(
            (
                spec.image_size,
                spec.weak_texture,
                scene.truth["obstacle"],
                len(scene.truth["steps"]),
                data["obstacle"],
                len(data["steps"]),
            )
        )
    return scores, rows


def _check_acceptance(scores, rows):
    summary = summarize(scores)
    report = json.dumps(summary, indent=1) + "\n" + "\n".join(map(str, rows))
    assert summary["detection_rate"] >= MIN_DETECTION_RATE, report
    assert summary["false_positive_rate"] == 0.0, report
    assert summary["count_rate"] >= MIN_COUNT_RATE, report
    assert summary["rise_median_m"] <= MAX_RISE_MEDIAN_M, report
    assert summary["rise_p90_m"] <= MAX_RISE_P90_M, report
    assert summary["run_median_m"] <= MAX_RUN_MEDIAN_M, report
    assert summary["first_distance_median_m"] <= MAX_FIRST_DISTANCE_MEDIAN_M, report


@pytest.mark.slow
def test_end_to_end_accuracy_full_mix():
    """The issue's full mix: 22 obstacles (weak texture, 320x240, 1280x720 among them) and
    an empty scene meet the issue's bounds."""
    specs = e2e_specs()
    assert len(specs) >= 20
    assert any(s.weak_texture for s in specs) and any(s.image_size == (320, 240) for s in specs)
    _check_acceptance(*_run_scores(specs))


def test_demo_scene_recovers_the_staircase():
    scene = render_scene(default_scene_spec())
    result = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right)
    data = result.to_json_dict()
    truth = scene.truth
    assert data["obstacle"] == "stairs" and len(data["steps"]) == len(truth["steps"])
    for got, want in zip(data["steps"], truth["steps"], strict=True):
        assert abs(got["rise"] - want["rise"]) < 0.01
        assert abs(got["distance"] - want["distance"]) < 0.03
    assert abs(data["yaw"] - truth["yaw"]) < np.radians(2)
    # JSON contract of CONVENTIONS.md
    assert data["version"] == 1 and data["frame"] == "yaw"
    assert set(data["timing_ms"]) >= {"rectify", "disparity", "cloud", "planes", "polytope", "total"}
    assert set(data["swing"]) == {"height", "trigger_distance", "traversable"}
    json.dumps(data)  # serialisable
    # Polytope vertices lie on the planes they were intersected from.
    verts = np.array(data["polytope"]["vertices"])
    assert len(verts) and len(data["polytope"]["faces"])
    for step in result.terrain.steps:
        on_riser = np.abs(verts @ step.riser.normal + step.riser.offset) < 1e-3
        assert on_riser.sum() >= 4


def test_a_step_too_high_to_climb_is_reported_not_traversable():
    """Safety: a 0.45 m step is above the swing's reach; it must show up as a step that
    cannot be climbed, not vanish as a wall (with obstacle none and traversable true)."""
    import dataclasses

    base = default_scene_spec()
    tall = dataclasses.replace(base.obstacle, rise_m=0.45, n_steps=1, distance_m=1.5)
    scene = render_scene(dataclasses.replace(base, obstacle=tall))
    data = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right).to_json_dict()
    assert data["obstacle"] == "stairs", data["note"]
    assert abs(data["steps"][0]["rise"] - 0.45) < 0.02
    assert data["swing"]["traversable"] is False


def test_no_obstacle_is_a_normal_result():
    scene = render_scene(random_scene_spec(np.random.default_rng(5), kind="none"))
    data = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right).to_json_dict()
    assert data["obstacle"] == "none" and data["steps"] == []
    assert data["swing"]["trigger_distance"] is None and data["swing"]["height"] == 0.15


def test_result_is_deterministic():
    scene = render_scene(default_scene_spec())
    a = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right).to_json_dict()
    b = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right).to_json_dict()
    a.pop("timing_ms"), b.pop("timing_ms")
    assert a == b


def test_a_frame_holds_blas_to_one_thread_and_gives_the_threads_back(monkeypatch):
    """OpenBLAS's idle workers spin after a threaded call and take a core from the next
    frame's matcher (issue 13): a frame on the main thread runs with one BLAS thread, and
    the caller's setting is back afterwards, also when the frame raises; a frame on
    another thread leaves the process-wide setting alone."""
    from threadpoolctl import ThreadpoolController

    import stereo_terrain.pipeline.core as core

    blas = ThreadpoolController().select(user_api="blas")
    if not blas.lib_controllers:
        pytest.skip("no BLAS library that threadpoolctl can limit")
    seen = []
    real = core.refine_up_from_planes

    def spy(*args, **kwargs):
        seen.append({c["num_threads"] for c in blas.info()})
        return real(*args, **kwargs)

    monkeypatch.setattr(core, "refine_up_from_planes", spy)
    scene = render_scene(default_scene_spec())
    pipeline = Pipeline(scene.calibration)
    with blas.limit(limits=2):
        before = [c["num_threads"] for c in blas.info()]
        if set(before) == {1}:
            pytest.skip("BLAS runs one thread here (one CPU or OPENBLAS_NUM_THREADS=1)")
        pipeline.run(scene.left, scene.right)
        after = [c["num_threads"] for c in blas.info()]
        assert seen and all(s == {1} for s in seen)
        assert after == before
        with ThreadPoolExecutor(max_workers=1) as pool:
            pool.submit(pipeline.run, scene.left, scene.right).result()
        assert seen[-1] == set(before)
        assert [c["num_threads"] for c in blas.info()] == before

        def broken(*args, **kwargs):
            raise RuntimeError("a stage failed")

        monkeypatch.setattr(core, "refine_up_from_planes", broken)
        with pytest.raises(RuntimeError):
            pipeline.run(scene.left, scene.right)
        assert [c["num_threads"] for c in blas.info()] == before


def test_without_rig_the_scene_levels_the_cloud():
    scene = render_scene(default_scene_spec())
    data = Pipeline(scene.calibration).run(scene.left, scene.right).to_json_dict()
    assert data["gravity_source"] == "scene"
    assert data["obstacle"] == "stairs"
    assert abs(data["steps"][0]["rise"] - scene.truth["steps"][0]["rise"]) < 0.02


def test_config_from_yaml(tmp_path):
    p = tmp_path / "cfg.yaml"
    p.write_text("max_disparity_px: 96\norientation:\n  angle_tol_deg: 8\n")
    cfg = PipelineConfig.from_yaml(p)
    assert cfg.max_disparity_px == 96 and cfg.orientation.angle_tol_deg == 8
    p.write_text("orientation:\n  angle_tolerance: 8\n")
    with pytest.raises(ConfigError, match="unknown keys"):
        PipelineConfig.from_yaml(p)
    p.write_text("orientation:\n  angle_tol_deg: 80\n")
    with pytest.raises(ConfigError, match="angle_tol_deg"):
        PipelineConfig.from_yaml(p)


def test_max_disparity_must_be_multiple_of_16():
    scene = render_scene(default_scene_spec())
    with pytest.raises(ConfigError, match="multiple of 16"):
        Pipeline(scene.calibration, scene.rig, PipelineConfig(max_disparity_px=50))


@pytest.mark.parametrize("scene_name", ["living_room", "desk", "corridor"])
def test_real_oakd_scenes_find_the_floor(shared_data, scene_name):
    d = shared_data / "oakd_lite" / scene_name
    calib = read_calibration(d / "stereodemo_calibration.json")
    result = Pipeline(calib).run(read_image(d / "left.png"), read_image(d / "right.png"))
    # The corridor shows little floor within the 4 m depth range: the levelling may fall
    # back to a level camera there.
    assert result.gravity_source == "scene" or scene_name == "corridor"
    assert result.disparity.density > 0.4
    # The floor levels the frame: in the rooms a large horizontal plane is found, in the
    # corridor (little floor in view) its two walls come out vertical.
    kinds = [s.kind for s in result.planes.segments if s.count >= 50]
    if scene_name == "corridor":
        assert kinds.count("vertical") >= 2
    else:
        flat = [s for s in result.planes.segments if s.kind == "horizontal" and s.count >= 80]
        assert flat and min(s.rms_m for s in flat) < 0.03
    # Issue 11: rooms without stairs report none.
    assert result.terrain.obstacle == "none", result.terrain.note


@pytest.mark.parametrize("scene_name", ["Adirondack", "Motorcycle"])
def test_real_middlebury_furniture_is_no_step_too_tall(shared_data, scene_name):
    """A chair and a motorbike in a room (no rig): their fronts are vertical faces 39-53 cm
    tall whose tops the planes do not show. They used to come out of the terrain's
    too-tall-step safety net as stairs; a step taller than a stair rise needs its top."""
    d = shared_data / "middlebury2014Q" / scene_name
    result = Pipeline(read_calibration(d / "calib.txt")).run(
        read_image(d / "im0.png"), read_image(d / "im1.png")
    )
    assert result.terrain.obstacle == "none", result.terrain.note


def test_real_middlebury_staircase_is_ordinary_stairs(shared_data):
    """Issue 11, item 6: the painted building staircase seen from the side is a staircase of
    at least 4 steps with rises within 1.5 cm of each other, 14-21 cm, runs 24-34 cm. Met
    since the planar fill's occlusion check and the Manhattan frame of the lines (rises
    17.0, 17.1, 15.7, 16.3 cm: a 1.4 cm spread, close to the bound; the third riser is
    still about 1 cm low against the reference staircase's 16.7 cm)."""
    d = shared_data / "middlebury2014Q_noGT" / "Staircase"
    data = Pipeline(read_calibration(d / "calib.txt")).run(
        read_image(d / "im0.png"), read_image(d / "im1.png")
    )
    steps = data.to_json_dict()["steps"]
    assert data.terrain.obstacle == "stairs" and len(steps) >= 4, data.terrain.note
    # The check on the rises and runs as measured (each step reports the staircase's
    # common rise where they agree within 3 cm: terrain/uniform.py; the rise that puts the
    # nosings at their heights, or their median). Steps inferred beyond have none of their own.
    measured = [
        s["rise"] if s["measured_rise"] is None else s["measured_rise"]
        for s in steps
        if not s["rise_inferred"]
    ]
    assert len(measured) >= 4
    assert max(measured) - min(measured) <= 0.015 and 0.14 <= min(measured) and max(measured) <= 0.21
    common = steps[0]["rise"]
    assert all(s["rise"] == common for s in steps) and 0.14 <= common <= 0.21
    assert all(abs(common - m) <= TerrainConfig().common_rise_tolerance_m for m in measured)
    runs = [s["run"] if s["measured_run"] is None else s["measured_run"] for s in steps]
    assert all(0.24 <= run <= 0.34 for run in runs if run is not None)


def test_real_middlebury_staircase_has_four_ordinary_steps(shared_data):
    """The painted staircase seen from the side: at least 4 steps, every rise 14-21 cm and
    every run 24-34 cm (ordinary building stairs; the reference staircase of
    bench_staircase_faces.py: rise 16.7, run 28.6 cm). Its white risers' planar fills
    slope 29-34 deg away from every direction of the scene (their outline support holds
    the railing); the Manhattan fill's check fits them again."""
    d = shared_data / "middlebury2014Q_noGT" / "Staircase"
    data = Pipeline(read_calibration(d / "calib.txt")).run(
        read_image(d / "im0.png"), read_image(d / "im1.png")
    )
    steps = data.to_json_dict()["steps"]
    assert data.terrain.obstacle == "stairs" and len(steps) >= 4, data.terrain.note
    assert all(0.14 <= s["rise"] <= 0.21 for s in steps)
    assert all(0.24 <= s["run"] <= 0.34 for s in steps if s["run"] is not None)


def test_real_middlebury_staircase_upper_steps_from_their_nosings(shared_data):
    """The painted staircase's upper risers form no plane (a few pixels of disparity noise
    tall) but their nosings are long edges in the image: the terrain stage adds them at
    the staircase's rise and run (terrain/nosings/). Without it, the four steps of the
    riser planes; with it, more, every one an ordinary step."""
    d = shared_data / "middlebury2014Q_noGT" / "Staircase"
    calibration = read_calibration(d / "calib.txt")
    left, right = read_image(d / "im0.png"), read_image(d / "im1.png")
    off = PipelineConfig(terrain=TerrainConfig(nosing_steps=False))
    without = Pipeline(calibration, config=off).run(left, right).terrain
    with_lines = Pipeline(calibration).run(left, right).terrain
    assert "line segments show their nosings" in with_lines.note
    assert len(with_lines.steps) > len(without.steps) >= 4
    assert all(0.14 <= s.rise_m <= 0.21 for s in with_lines.steps)
    added = with_lines.steps[len(without.steps) :]
    assert all(s.rise_inferred for s in added)
    positions = [s.axis_position_m for s in with_lines.steps]
    assert all(0.24 <= b - a <= 0.34 for a, b in zip(positions, positions[1:], strict=False))


def test_real_middlebury_staircase_blurred_as_a_webcam_blurs_still_has_four_steps(shared_data):
    """The painted staircase blurred by 0.8 px (a webcam's optics;
    benchmarks/bench_staircase_webcam.py): only the first riser forms a plane, and the
    steps beyond come from their nosings. On the third, a line 1.3 steps on covers more
    of the width than the nosing does and has no riser foot under it; the nosing nearer
    is taken instead of stopping there (terrain/nosings/), and the staircase passes
    the issue's check with its rises and runs as reported."""
    d = shared_data / "middlebury2014Q_noGT" / "Staircase"
    left, right = (cv2.GaussianBlur(to_grey(read_image(d / n)), (0, 0), 0.8) for n in ("im0.png", "im1.png"))
    data = Pipeline(read_calibration(d / "calib.txt")).run(left, right).to_json_dict()
    steps = data["steps"]
    assert data["obstacle"] == "stairs" and len(steps) >= 4, data["note"]
    rises = [s["rise"] for s in steps]
    assert max(rises) - min(rises) <= 0.015 and 0.14 <= min(rises) and max(rises) <= 0.21
    assert all(0.24 <= s["run"] <= 0.34 for s in steps if s["run"] is not None)


def _webcam_bench():
    """benchmarks/bench_staircase_webcam.py, for its webcam degradation of a real pair."""
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_staircase_webcam.py"
    spec = importlib.util.spec_from_file_location("bench_staircase_webcam", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _webcam_staircase(shared_data, seed: int):
    """The real painted staircase as a cheap webcam sees it (noise 2 grey + shot, blur 0.8
    px, JPEG 75, an exposure difference; bench_staircase_webcam.py's webcam row, ``seed``):
    its calibration and the degraded pair."""
    bench = _webcam_bench()
    d = shared_data / "middlebury2014Q_noGT" / "Staircase"
    noise, shot, blur, quality, _ = bench.DEGRADATIONS["all, webcam (noise 2, shot 0.05, blur 0.8, JPEG 75)"]
    rng = np.random.default_rng(seed)
    gain, offset = float(rng.uniform(0.85, 1.15)), float(rng.uniform(-10.0, 10.0))
    left = bench.degrade(to_grey(read_image(d / "im0.png")), rng, noise, shot, blur, quality)
    right = bench.degrade(to_grey(read_image(d / "im1.png")), rng, noise, shot, blur, quality, gain, offset)
    return read_calibration(d / "calib.txt"), left, right


#: The webcam-degraded staircase's runs with the sloped lines left in the Manhattan fill's
#: horizontal direction (as before the twenty-eighth session), for the tests of the rules
#: that came before.
_SLOPES_KEPT = VerticalLinesConfig(horizontal_max_slope_deg=0.0)


def test_real_middlebury_staircase_railing_at_webcam_quality_is_no_step(shared_data):
    """Webcam seed 3: the matcher's samples of the railing 0.7 m away make a vertical plane
    as tall as a step, nearer than every riser. It was reported as a 28 cm step at 0.8 m;
    through its middle the cameras see the stairs beyond it, so it is no riser
    (TerrainConfig.max_riser_see_through) and the first step reported is a riser of the
    staircase, 2 m away or more. (With the sloped lines left out of the Manhattan fill's
    direction the staircase is found either way: both run with them kept.)"""
    calibration, left, right = _webcam_staircase(shared_data, 3)
    after = Pipeline(calibration, config=PipelineConfig(vanishing=_SLOPES_KEPT)).run(left, right).terrain
    assert after.steps and after.steps[0].distance_m >= 2.0, after.note
    assert 0.14 <= after.steps[0].rise_m <= 0.21
    default = Pipeline(calibration).run(left, right).terrain
    assert default.steps and default.steps[0].distance_m >= 2.0, default.note
    off = PipelineConfig(terrain=TerrainConfig(max_riser_see_through=1.0), vanishing=_SLOPES_KEPT)
    before = Pipeline(calibration, config=off).run(left, right).terrain
    premise(
        bool(before.steps) and before.steps[0].distance_m < 1.0,
        "without the see-through test, the railing is reported as a step",
    )


def test_real_middlebury_staircase_at_webcam_quality_passes_without_its_sloped_lines(shared_data):
    """Webcam seed 7: the handrail's long sloped lines outweighed the nosings in the
    Manhattan fill's horizontal direction, the painted risers were filled as planes turned
    50 deg from the real ones, and a lone 14 cm step was all. Left out where the disparity
    shows them sloped (VerticalLinesConfig.horizontal_max_slope_deg), the staircase is
    found and meets the issue's check: 4 or more steps, rises 14-21 cm within 1.5 cm of
    each other, runs 24-34 cm."""
    calibration, left, right = _webcam_staircase(shared_data, 7)
    steps = Pipeline(calibration).run(left, right).to_json_dict()["steps"]
    assert len(steps) >= 4
    rises = [s["rise"] for s in steps]
    assert max(rises) - min(rises) <= 0.015 and 0.14 <= min(rises) and max(rises) <= 0.21
    assert all(0.24 <= s["run"] <= 0.34 for s in steps if s["run"] is not None)


def test_real_middlebury_staircase_axis_is_across_the_wall_not_along_the_railing(shared_data):
    """Seen from the side, the balusters' plane (short, vertical, facing the camera, nearer
    than the steps) holds more samples than the first riser; it must not set the stair
    axis. The first step is found, with an ordinary rise, its riser at right angles to
    the side wall."""
    d = shared_data / "middlebury2014Q_noGT" / "Staircase"
    result = Pipeline(read_calibration(d / "calib.txt")).run(
        read_image(d / "im0.png"), read_image(d / "im1.png")
    )
    steps = result.terrain.steps
    assert result.terrain.obstacle == "stairs" and steps, result.terrain.note
    assert 0.14 <= steps[0].rise_m <= 0.21
    wall = max((s for s in result.planes.segments if s.kind == "vertical"), key=lambda s: s.count)
    assert abs(float(steps[0].riser.normal @ wall.plane.normal)) < np.sin(np.radians(10.0))


def test_real_middlebury_classroom_runs(shared_data):
    d = shared_data / "middlebury2014Q_noGT" / "Classroom2"
    pipeline = Pipeline(read_calibration(d / "calib.txt"))
    assert pipeline.max_disparity_px == 160  # from ndisp=153
    result = pipeline.run(read_image(d / "im0.png"), read_image(d / "im1.png"))
    assert result.gravity_source == "scene" and len(result.planes.segments) >= 3


def test_rig_pitch_is_used():
    scene = render_scene(default_scene_spec())
    wrong = Rig(camera_mount(0.55, 0.0))  # pitch ignored: the ground would tilt by 15 deg
    result = Pipeline(scene.calibration, wrong).run(scene.left, scene.right)
    steps = result.terrain.steps
    assert result.terrain.obstacle == "none" or steps[0].rise_m != pytest.approx(0.17, abs=0.01)
