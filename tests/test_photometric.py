"""Risers moved to where both images of their faces agree (terrain/photometric.py, issue
11: the runs of real stairs): the search finds a rendered riser's true distance from a
wrong start, keeps nothing on a uniform face, and moves positions, distances and runs
consistently."""

from __future__ import annotations

import dataclasses
import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.synthetic import random_scene_spec, render_scene
from stereo_terrain.terrain import Step, StereoView, TerrainConfig, photometric
from stereo_terrain.terrain.photometric import RiserFit, fit_riser, refine_risers
from stereo_terrain.terrain.risers import riser_distance

_CACHE: dict = {}

#: How near the truth a riser started 4 cm off must end (metres): the samples' own
#: positions are off by 2-3 cm at these distances (docs/benchmarks.md).
_REFINED_TOL_M = 0.015


def _lab_stairs():
    """A realistic wooden staircase (rise 20 cm, run 31 cm, 7 cm baseline) seen with its
    rig, its rectified pair as a StereoView, and the truth (cached)."""
    if not _CACHE:
        rng = np.random.default_rng(3)
        while True:
            spec = random_scene_spec(
                rng,
                profile="realistic",
                kind="stairs",
                distance_m=1.6,
                baseline_m=0.07,
                weak_texture=False,
                rise_m=0.2,
                run_m=0.31,
                n_steps=3,
                yaw_rad=0.0,
            )
            if spec.riser.texture == "planks":
                break
        scene = render_scene(spec)
        result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
        rect = result.rectified.rectification
        view = StereoView(
            result.rectified.left,
            result.rectified.right,
            rect.focal_px,
            rect.cx,
            rect.cy,
            rect.baseline_m,
            rect.doffs_px,
            result.T_yaw_camera_rect.matrix,
            rect.valid_left,
            rect.valid_right,
        )
        _CACHE.update(scene=scene, view=view)
    return _CACHE["scene"], _CACHE["view"]


def _true_riser(truth: dict, k: int) -> Plane:
    p = next(p for p in truth["planes"] if p["name"] == f"riser_{k + 1}")
    return Plane(np.asarray(p["normal"]), float(p["offset"]))


def test_risers_started_off_end_near_their_true_distances():
    """Each of the three risers, started 4 cm nearer and 4 cm farther: every fit kept
    lands near the truth, and half of them are kept (the others' cost is too flat or
    their thirds disagree, and they stay where they started)."""
    scene, view = _lab_stairs()
    truth = scene.truth
    rise = truth["steps"][0]["rise"]
    ob = scene.spec.obstacle
    half = 0.5 * ob.width_m
    v = np.array([0.0, 1.0, 0.0])
    lateral = (ob.lateral_m - half, ob.lateral_m + half)
    t = view.T_frame_camera[:3, 3]
    kept = 0
    for k in range(3):
        true = _true_riser(truth, k)
        for off_m in (-0.04, 0.04):
            start = Plane(true.normal, true.offset - off_m)  # normal -x: offset is +x position
            fit = fit_riser(view, start, (k * rise, (k + 1) * rise), lateral, v, TerrainConfig())
            assert fit is not None
            if not fit.kept:
                continue
            kept += 1
            o_c = start.offset + start.normal @ t
            refined = o_c / fit.scale - start.normal @ t
            assert abs(refined - true.offset) < _REFINED_TOL_M, (k, off_m, refined, true.offset)
    assert kept >= 3


def test_a_uniform_face_keeps_the_samples_position():
    scene, view = _lab_stairs()
    grey = np.full_like(view.left, 128)
    flat = dataclasses.replace(view, left=grey, right=grey)
    ob = scene.spec.obstacle
    true = _true_riser(scene.truth, 0)
    rise = scene.truth["steps"][0]["rise"]
    lateral = (ob.lateral_m - 0.5 * ob.width_m, ob.lateral_m + 0.5 * ob.width_m)
    fit = fit_riser(
        view=flat,
        plane=true,
        z_range=(0.0, rise),
        lateral=lateral,
        v=np.array([0.0, 1.0, 0.0]),
        config=TerrainConfig(),
    )
    assert fit is not None and not fit.kept  # in view, and nothing to match


def test_a_face_out_of_view_is_not_searched():
    scene, view = _lab_stairs()
    behind = Plane(np.array([1.0, 0.0, 0.0]), 1.0)  # x = -1: behind the cameras
    fit = fit_riser(view, behind, (0.0, 0.2), (-0.5, 0.5), np.array([0.0, 1.0, 0.0]), TerrainConfig())
    assert fit is None


def _staircase(n: int, yaw: float, run: float) -> tuple[list[Step], np.ndarray]:
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    steps = []
    for i in range(n):
        s = 1.5 + i * run
        plane = Plane(-u, s)  # -u . x + s = 0: the riser s along u
        steps.append(
            Step(
                0.17,
                run if i < n - 1 else None,
                riser_distance(plane, s, u),
                1.0,
                0.17 * (i + 1),
                s,
                plane,
            )
        )
    return steps, u


def _view(translation=(0.0, 0.0, 0.0)) -> StereoView:
    T = np.eye(4)
    T[:3, 3] = translation
    return StereoView(np.zeros((4, 4), np.uint8), np.zeros((4, 4), np.uint8), 500.0, 2.0, 2.0, 0.07, 0.0, T)


def _kept(scale: float) -> RiserFit:
    return RiserFit(scale, 0.1, 0.05, 1000, True, 0.0, 0.002)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 5),
    st.floats(-0.8, 0.8),
    st.floats(0.2, 0.4),
    st.lists(st.one_of(st.none(), st.floats(0.92, 1.08)), min_size=5, max_size=5),
    st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(0.2, 1.0)),
)
def test_moved_risers_keep_positions_distances_and_runs_consistent(n, yaw, run, scales, camera):
    steps, u = _staircase(n, yaw, run)
    v = np.array([-u[1], u[0], 0.0])
    view = _view(camera)
    t = np.asarray(camera)
    fits = iter(scales)

    def fake_fit(view, plane, z_range, lateral, v, config):
        k = next(fits)
        return None if k is None else _kept(k)

    config = TerrainConfig()
    with mock.patch.object(photometric, "fit_riser", fake_fit):
        out, moved = refine_risers(steps, u, v, [(-0.5, 0.5)] * n, view, config)
    assert len(out) == n
    assert moved == sum(b.riser_move is not None for b in out)
    for i, (a, b) in enumerate(zip(steps, out, strict=True)):
        k = scales[i]
        if b.riser_move is None:
            assert b.riser is a.riser and b.axis_position_m == a.axis_position_m
        else:
            # The depth along the normal from the camera scales as 1 / k.
            o_c = a.riser.offset + a.riser.normal @ t
            assert b.riser.offset == pytest.approx(o_c / k - a.riser.normal @ t, abs=1e-9)
            assert b.riser_move.sampled_riser is a.riser
            assert b.riser_move.sampled_position_m == a.axis_position_m
            assert b.riser_move.sigma_m > 0
        np.testing.assert_allclose(b.riser.normal, a.riser.normal, atol=1e-12)
        # The position lies on the plane, and the distance is where x meets it.
        point = b.axis_position_m * u
        assert abs(b.riser.normal @ point + b.riser.offset) < 1e-9
        assert b.distance_m == pytest.approx(riser_distance(b.riser, b.axis_position_m, u), abs=1e-12)
        if i + 1 < n:
            gap = out[i + 1].axis_position_m - b.axis_position_m
            assert b.run_m == pytest.approx(gap, abs=1e-9)
            assert gap >= min(config.min_run_m, run) - 1e-9  # no move brings two risers nearer
        else:
            assert b.run_m is None


def test_a_move_onto_the_next_riser_is_not_made():
    steps, u = _staircase(2, 0.0, 0.25)  # risers at 1.50 and 1.75 m
    # The first searched 1.08x nearer in disparity (1.39 m), the second 8% farther in depth
    # would be fine alone; here the first goes farther instead: 1.5 / 0.92 = 1.63 m, 12 cm
    # before the next, under min_run_m (0.15 m).
    fits = iter([_kept(0.92), None])
    with mock.patch.object(photometric, "fit_riser", lambda *a, **k: next(fits)):
        out, moved = refine_risers(
            steps, u, np.array([0.0, 1.0, 0.0]), [(-0.5, 0.5)] * 2, _view(), TerrainConfig()
        )
    assert moved == 0 and out == steps


def test_a_run_that_is_no_difference_of_positions_stays():
    steps, u = _staircase(1, 0.0, 0.3)
    box = [dataclasses.replace(steps[0], run_m=0.45)]  # a box's depth from its top
    with mock.patch.object(photometric, "fit_riser", lambda *a, **k: _kept(1.02)):
        out, moved = refine_risers(box, u, np.array([0.0, 1.0, 0.0]), [(-0.5, 0.5)], _view(), TerrainConfig())
    assert moved == 1 and out[0].run_m == 0.45
    assert out[0].distance_m < box[0].distance_m  # nearer: its disparity grew


def test_steps_the_lines_placed_are_not_searched():
    steps, u = _staircase(3, 0.0, 0.3)
    steps[2] = dataclasses.replace(steps[2], position_inferred=True)
    calls = []

    def fake_fit(view, plane, *a, **k):
        calls.append(plane)
        return _kept(1.01)

    with mock.patch.object(photometric, "fit_riser", fake_fit):
        out, moved = refine_risers(
            steps, u, np.array([0.0, 1.0, 0.0]), [(-0.5, 0.5)] * 3, _view(), TerrainConfig()
        )
    assert moved == 2 and calls == [steps[0].riser, steps[1].riser]
    assert out[2] == steps[2]


def test_the_staircase_found_with_moved_risers_keeps_their_widths():
    """End to end on the rendered lab stairs: some risers move, their polytope faces keep
    their own lateral extent (found where their samples put them), and the step sigmas
    stay finite."""
    scene, _ = _lab_stairs()
    on = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right).terrain
    off_config = PipelineConfig(terrain=TerrainConfig(photometric_risers=False))
    off = (
        Pipeline(scene.calibration, scene.rig, off_config, warm_up=False).run(scene.left, scene.right).terrain
    )
    assert any(s.riser_move is not None for s in on.steps), on.note
    assert "moved to where both images" in on.note
    assert len(on.steps) == len(off.steps) == len(on.polytope.faces) // 2
    v = np.array([-math.sin(on.yaw_rad), math.cos(on.yaw_rad), 0.0])
    for q in range(len(on.polytope.faces)):
        lat_on = on.polytope.vertices[4 * q : 4 * q + 4] @ v
        lat_off = off.polytope.vertices[4 * q : 4 * q + 4] @ v
        np.testing.assert_allclose(np.sort(lat_on), np.sort(lat_off), atol=0.02)
    for s in on.steps:
        if s.riser_move is not None:
            assert math.isfinite(s.distance_sigma_m) and s.distance_sigma_m > 0


@pytest.mark.parametrize(
    "field,value",
    [
        ("photometric_span", 0.0),
        ("photometric_span", 0.6),
        ("photometric_min_sharpness", -0.1),
        ("photometric_max_cost", 0.0),
        ("photometric_max_cost", 2.5),
        ("photometric_max_spread", 3.0),
    ],
)
def test_bad_photometric_settings_are_refused(field, value):
    with pytest.raises(ConfigError, match=field):
        TerrainConfig(**{field: value})
