"""The per-step 1-sigmas (issue 14): against a Monte Carlo over rendered scenes, and their
shape on exact plane sets."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.runtime.simulate import ApproachConfig, approach_spec
from stereo_terrain.synthetic import render_scene
from stereo_terrain.terrain import TerrainConfig, build_terrain, estimate_step_sigmas
from stereo_terrain.terrain.sigmas import _disagreement, _share

from .test_terrain import _stairs

RISE = 0.17
RUNS = 8  # renders per distance
#: The predicted sigma (median over the renders) and the rms error over them agree within
#: this factor either way.
RATIO_BOUND = 2.5


def _monte_carlo(distance_m, seed0):
    """rms error / median sigma of the first step's rise, distance and the yaw over ``RUNS``
    renders (texture and sensor noise seeds, a few cm of position, a degree of pitch)."""
    rng = np.random.default_rng(seed0)
    errs, sigmas = [], []
    for k in range(RUNS):
        x = 2.2 - distance_m + rng.uniform(-0.03, 0.03)
        cfg = ApproachConfig(rise_m=RISE, image_size=(320, 240), supersample=1, seed=seed0 + k)
        scene = render_scene(approach_spec(cfg, x, rng.uniform(-0.015, 0.015)))
        result = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right)
        steps = result.terrain.steps
        d = 2.2 - x
        if not steps or abs(steps[0].distance_m - d) > 0.15:
            continue  # the first riser was missed: no sigma to check
        s = steps[0]
        errs.append((s.rise_m - RISE, s.distance_m - d, result.terrain.yaw_rad))
        sigmas.append((s.rise_sigma_m, s.distance_sigma_m, result.terrain.yaw_sigma_rad))
        doc = result.to_json_dict()
        assert doc["steps"][0]["rise_sigma"] > 0 and doc["yaw_sigma"] > 0
        assert set(doc["steps"][0]) >= {"rise_sigma", "run_sigma", "distance_sigma", "width_sigma"}
    assert len(errs) >= RUNS - 2
    e, s = np.array(errs), np.array(sigmas)
    return np.sqrt(np.mean(e**2, axis=0)) / np.median(s, axis=0)


@pytest.mark.parametrize("distance_m", [1.2, 1.8])
def test_sigmas_match_a_monte_carlo_on_rendered_scenes(distance_m):
    ratio = _monte_carlo(distance_m, seed0=11)
    for name, r in zip(("rise", "distance", "yaw"), ratio, strict=True):
        assert 1 / RATIO_BOUND < r < RATIO_BOUND, f"{name}: rms error / sigma = {r:.2f}"


def _sigmas(distance, **kw):
    planes = _stairs(distance=distance, **kw)
    model = build_terrain(planes)
    return estimate_step_sigmas(model, planes, focal_px=500.0, baseline_m=0.1)


def test_sigmas_on_exact_planes_grow_with_range_and_follow_the_values():
    near, far = _sigmas(1.3), _sigmas(2.6)
    assert len(near.steps) == len(far.steps) == 3
    for a, b in zip(near.steps, far.steps, strict=True):
        assert 0 < a.rise_sigma_m < b.rise_sigma_m
        assert 0 < a.distance_sigma_m < b.distance_sigma_m
    assert near.steps[-1].run_m is None and near.steps[-1].run_sigma_m is None
    assert near.steps[0].run_sigma_m > 0
    assert math.isfinite(near.yaw_sigma_rad) and near.yaw_sigma_rad > 0
    # the depth error grows as z^2 / (f b): twice the baseline, about half the sigma
    wide = estimate_step_sigmas(
        build_terrain(_stairs(distance=2.6)), _stairs(distance=2.6), focal_px=500.0, baseline_m=0.2
    )
    assert wide.steps[0].distance_sigma_m < 0.6 * far.steps[0].distance_sigma_m


def test_sigma_inputs_are_checked():
    planes = _stairs()
    model = build_terrain(planes)
    with pytest.raises(ConfigError, match="focal_px"):
        estimate_step_sigmas(model, planes, focal_px=0.0, baseline_m=0.1)
    with pytest.raises(ConfigError, match="face_bias_correlation"):
        TerrainConfig(face_bias_correlation=1.5)
    with pytest.raises(ConfigError, match="matching_window_px"):
        TerrainConfig(matching_window_px=0.0)


def _first_riser_seen_between(lo_m, hi_m, yaw=0.0):
    """The first step's distance sigma when only the part of the first riser between
    ``lo_m`` and ``hi_m`` to the left of the stair axis was seen."""
    planes = _stairs(distance=1.6, width=1.2, yaw=yaw)
    model = build_terrain(planes)
    riser = model.steps[0].riser
    P = planes.samples.points.copy()
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    lateral = P @ np.array([-u[1], u[0], 0.0])
    on = (np.abs(riser.residuals(P)) < 1e-4) & (planes.samples.normals @ riser.normal > 0.99)
    P[on & ((lateral < lo_m) | (lateral > hi_m)), 0] += 5.0  # not seen: far from every face
    seen = dataclasses.replace(planes, samples=dataclasses.replace(planes.samples, points=P))
    return estimate_step_sigmas(model, seen, focal_px=500.0, baseline_m=0.1).steps[0].distance_sigma_m


def test_a_riser_seen_off_to_one_side_has_the_lever_of_its_yaw_in_its_distance_sigma():
    """The riser plane turns about its samples' centre: the further that centre is from the
    x axis, the more a yaw error moves where the axis meets the plane."""
    near, side = _first_riser_seen_between(0.05, 0.25), _first_riser_seen_between(0.35, 0.55)
    assert side > 1.5 * near
    yawed = _first_riser_seen_between(0.35, 0.55, yaw=math.radians(30))
    assert yawed > side  # 1 / cos^2(yaw) more per radian


def _own_values(model, rise_off=None, run_off=None):
    """``model`` with every step reporting its own rise and run (none pooled), and step
    ``k`` of ``rise_off = (k, metres)`` (``run_off`` likewise) measured that much off."""
    steps = []
    for i, s in enumerate(model.steps):
        rise, run = s.own_rise_m, s.own_run_m
        if rise_off is not None and rise_off[0] == i:
            rise += rise_off[1]
        if run_off is not None and run_off[0] == i:
            run += run_off[1]
        steps.append(
            dataclasses.replace(s, rise_m=rise, run_m=run, measured_rise_m=None, measured_run_m=None)
        )
    return dataclasses.replace(model, steps=tuple(steps))


def test_a_step_that_the_staircase_disagrees_with_has_the_disagreement_in_its_sigma():
    """The steps of a staircase are equal: a measured rise 4 cm off the others' has a
    sigma of at least that, a run 5 cm off likewise, and its two risers share the run's
    disagreement in their distance sigmas (the farther the larger share); the steps that
    agree keep the sigmas of the model."""
    planes = _stairs(n_steps=5, distance=1.5)
    model = build_terrain(planes)
    assert len(model.steps) == 5

    def sig(m):
        return estimate_step_sigmas(m, planes, focal_px=500.0, baseline_m=0.1).steps

    agree = sig(_own_values(model))
    rise_off = sig(_own_values(model, rise_off=(1, 0.04)))
    assert 0.04 <= rise_off[1].rise_sigma_m < math.hypot(agree[1].rise_sigma_m, 0.04) + 1e-9
    for i in (0, 2, 3, 4):
        assert rise_off[i].rise_sigma_m == pytest.approx(agree[i].rise_sigma_m, abs=1e-6)
    run_off = sig(_own_values(model, run_off=(1, 0.05)))
    assert 0.05 <= run_off[1].run_sigma_m < math.hypot(agree[1].run_sigma_m, 0.05) + 1e-9
    for i in (0, 2, 3):
        assert run_off[i].run_sigma_m == pytest.approx(agree[i].run_sigma_m, abs=1e-6)
    # risers 1 and 2 bound the run that disagrees; riser 2 is the farther
    extra = [
        math.sqrt(max(a.distance_sigma_m**2 - b.distance_sigma_m**2, 0.0))
        for a, b in zip(run_off, agree, strict=True)
    ]
    assert all(extra[i] == pytest.approx(0.0, abs=1e-6) for i in (0, 3, 4))
    assert 0.0 < extra[1] < extra[2] and extra[1] + extra[2] == pytest.approx(0.05, rel=0.05)


@given(
    values=st.lists(st.floats(0.05, 0.4), min_size=1, max_size=8),
    shift=st.floats(-0.1, 0.1),
)
def test_disagreement_is_the_distance_to_the_others_median(values, shift):
    found = _disagreement(dict(enumerate(values)))
    assert set(found) == (set(range(len(values))) if len(values) > 1 else set())
    for k, off in found.items():
        others = values[:k] + values[k + 1 :]
        assert off == pytest.approx(abs(values[k] - float(np.median(others))), abs=1e-12)
    # the same shift of every value moves no disagreement
    moved = _disagreement({k: v + shift for k, v in enumerate(values)})
    assert all(moved[k] == pytest.approx(found[k], abs=1e-9) for k in found)


@given(a=st.floats(0.0, 1.0), b=st.floats(0.0, 1.0))
def test_the_two_shares_of_an_error_add_up_to_it(a, b):
    assert 0.0 <= _share(a, b) <= 1.0
    assert _share(a, b) + _share(b, a) == pytest.approx(1.0)
    if a > b:
        assert _share(a, b) >= 0.5
