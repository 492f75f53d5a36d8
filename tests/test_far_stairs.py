"""Stairs 2-4 m ahead (issue 11's OAK-D check): far risers' normals are noisy, and the plane
stage widens its tests by each sample's expected normal error (docs/benchmarks.md, "Stairs
2-4 m ahead")."""

import dataclasses

import numpy as np
import pytest

from stereo_terrain.cloud import CloudConfig, sample_disparity, transform_sample
from stereo_terrain.errors import ConfigError
from stereo_terrain.evaluation import score_result
from stereo_terrain.frames import Transform
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.planes.orientation import OrientationConfig, normal_agreement_cos
from stereo_terrain.synthetic import random_scene_spec, render_scene

from .analytic import step_scene

# benchmarks/bench_far_stairs.py's draws (seed 77): scene 13 is a 5-step staircase of
# 11.7 cm risers whose first riser is 2.84 m ahead, seen with a 7.5 cm baseline. With the
# fixed normal tests (the default) the pipeline finds no stairs in it.
FAR_SEED, FAR_INDEX = 77, 13
WIDENED = OrientationConfig(normal_noise_sigmas=1.1)
RISE_TOL_M = 0.015
MIN_STEPS = 3


@pytest.fixture(scope="module")
def far_staircase():
    rng = np.random.default_rng(FAR_SEED)
    for _ in range(FAR_INDEX + 1):
        distance = float(rng.uniform(2.0, 3.5))
        spec = random_scene_spec(rng, profile="default", kind="stairs", distance_m=distance, baseline_m=0.075)
    return render_scene(spec)


def test_widened_normal_tests_find_a_staircase_three_metres_ahead(far_staircase):
    scene = far_staircase
    config = PipelineConfig(orientation=WIDENED)
    pipe = Pipeline(scene.calibration, scene.rig, config, warm_up=False)
    result = pipe.run(scene.left, scene.right).to_json_dict()
    score = score_result(result, scene.truth)
    assert score.detected, result["plane_stage"]
    assert len(score.rise_errors_m) >= MIN_STEPS
    assert max(score.rise_errors_m) <= RISE_TOL_M


def test_normal_noise_grows_with_depth_over_baseline():
    disp, T = step_scene()
    s = sample_disparity(disp, T, CloudConfig(max_depth_m=10))
    assert s.normal_sigma_rad is not None and s.normal_sigma_rad.shape == (len(s),)
    depth = (s.points - s.camera_position) @ T.apply_vectors(np.array([0.0, 0.0, 1.0]))
    tan = np.tan(s.normal_sigma_rad.astype(np.float64))
    # tan(sigma) = sqrt(2) sigma_box Z / (2 k B): proportional to depth
    ratio = tan / depth
    assert np.all(s.normal_sigma_rad > 0) and np.all(s.normal_sigma_rad < np.pi / 2)
    assert np.ptp(ratio) <= 1e-3 * np.median(ratio)
    wider = sample_disparity(disp, T, CloudConfig(max_depth_m=10), box_disparity_sigma_px=0.2)
    assert np.allclose(np.tan(wider.normal_sigma_rad), 2 * tan, rtol=1e-4)


def test_agreement_widens_only_for_noisy_normals_and_is_capped():
    disp, T = step_scene()
    s = sample_disparity(disp, T, CloudConfig(max_depth_m=10))
    sigma = np.radians(np.linspace(0.0, 80.0, len(s))).astype(np.float32)
    noisy = dataclasses.replace(s, normal_sigma_rad=sigma)
    config = WIDENED
    angle = np.degrees(np.arccos(normal_agreement_cos(noisy, config)))
    base, cap = config.normal_agreement_deg, config.max_noise_tolerance_deg
    assert angle.min() == pytest.approx(base) and angle.max() == pytest.approx(cap)
    expected = np.degrees(np.arctan(config.normal_noise_sigmas * np.tan(sigma.astype(np.float64))))
    mid = (expected > base) & (expected < cap)
    assert mid.sum() > 100
    assert np.allclose(angle[mid], expected[mid], atol=1e-3)
    off = normal_agreement_cos(noisy, OrientationConfig())  # the default: off
    unknown = normal_agreement_cos(dataclasses.replace(s, normal_sigma_rad=None), config)
    fixed = float(np.cos(np.radians(base)))
    assert np.all(off == fixed) and np.all(unknown == fixed)


def test_transform_keeps_the_normal_noise():
    disp, T = step_scene()
    s = sample_disparity(disp, Transform.identity("camera_rect"), CloudConfig(max_depth_m=10))
    moved = transform_sample(s, T)
    assert moved.normal_sigma_rad is not None
    assert np.array_equal(moved.normal_sigma_rad, s.normal_sigma_rad)


@pytest.mark.parametrize(
    "fields",
    [{"normal_noise_sigmas": -1.0}, {"max_noise_tolerance_deg": 45.0}, {"max_noise_tolerance_deg": 10.0}],
)
def test_noise_options_out_of_range_are_config_errors(fields):
    with pytest.raises(ConfigError):
        OrientationConfig(**fields)
