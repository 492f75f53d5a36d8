"""Gravity from the scene's plane families (stereo_terrain.gravity)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.cloud import GridSample
from stereo_terrain.errors import ConfigError
from stereo_terrain.frames import rotation_from_rpy
from stereo_terrain.gravity import (
    GravityConfig,
    GravityEstimate,
    angle_deg,
    estimate_up,
    rotation_between,
    yaw_frame_from_up,
)
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.synthetic import default_scene_spec, render_scene

from .close_stairs import close_level_stairs_spec

#: Angle bounds (deg) for the synthetic-normal tests: noise of 8 deg per sample normal.
COARSE_TOL_DEG = 1.5
NOISE_DEG = 8.0


def _sample(normals_by_family: list[tuple[np.ndarray, int]], R: np.ndarray, rng, clutter: int = 0):
    """A GridSample whose normals (camera frame, y down) come from the given families
    (world normals, z up), rotated into the camera by ``R`` (camera <- world), with noise,
    random signs and ``clutter`` random normals."""
    normals = []
    for n, count in normals_by_family:
        noise = rng.normal(0.0, math.radians(NOISE_DEG) / math.sqrt(2), (count, 3))
        v = np.asarray(n, dtype=float)[None, :] + noise
        normals.append(v)
    if clutter:
        normals.append(rng.normal(size=(clutter, 3)))
    N = np.vstack(normals)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    N *= rng.choice([-1.0, 1.0], size=(len(N), 1))
    N = N @ R.T
    n = len(N)
    gw = 80
    idx = rng.permutation(120 * gw)[:n].astype(np.int32)
    return GridSample(
        points=rng.normal(size=(n, 3)).astype(np.float32),
        normals=N.astype(np.float32),
        sigma_m=np.full(n, 0.01, np.float32),
        rows=(idx // gw).astype(np.int32),
        cols=(idx % gw).astype(np.int32),
        grid_index=idx,
        grid_shape=(120, gw),
        stride_px=8,
        frame="camera_rect",
    )


# Camera (optical: x right, y down, z forward) <- world (x forward, y left, z up).
R_CAM_WORLD = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


def _camera(roll: float, pitch: float) -> np.ndarray:
    return R_CAM_WORLD @ rotation_from_rpy(roll, pitch, 0.0).T


@pytest.mark.parametrize("pitch_deg", [-5.0, 0.0, 12.0, 30.0])
def test_risers_and_a_side_wall_give_up_without_any_floor(pitch_deg):
    """No horizontal surface at all: a riser family and a wall family fix up."""
    rng = np.random.default_rng(1)
    yaw = math.radians(35.0)
    riser = np.array([-math.cos(yaw), -math.sin(yaw), 0.0])
    wall = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    R = _camera(math.radians(2.0), math.radians(pitch_deg))
    est = estimate_up(_sample([(riser, 1500), (wall, 1500)], R, rng, clutter=800))
    true_up = R @ np.array([0.0, 0.0, 1.0])
    assert est.ok, est.reason
    assert angle_deg(est.up, true_up) < COARSE_TOL_DEG
    assert 0 < est.sigma_deg < 2.0


def test_one_wall_family_alone_does_not_fix_up():
    """Up may turn freely about a lone wall's normal: not used, and it says why."""
    rng = np.random.default_rng(2)
    est = estimate_up(_sample([(np.array([-1.0, 0.0, 0.0]), 3000)], _camera(0.0, 0.1), rng, clutter=300))
    assert not est.ok and "deg" in est.reason or "up" in est.reason


def test_clutter_alone_is_refused():
    rng = np.random.default_rng(3)
    est = estimate_up(_sample([], _camera(0.0, 0.0), rng, clutter=3000))
    assert not est.ok and not np.isfinite(est.sigma_deg)


def test_a_slanted_envelope_does_not_pull_up_away_from_the_treads():
    """A staircase's noisy envelope (slope ~35 deg) plus a side wall: up stays on the
    treads (the Middlebury Staircase failure: up turned 50 deg to make the slope vertical)."""
    rng = np.random.default_rng(4)
    slope = math.radians(35.0)
    envelope = np.array([-math.sin(slope), 0.0, math.cos(slope)])
    wall = np.array([0.0, 1.0, 0.0])
    tread = np.array([0.0, 0.0, 1.0])
    R = _camera(0.0, math.radians(5.0))
    est = estimate_up(_sample([(envelope, 2500), (wall, 2500), (tread, 300)], R, rng))
    assert est.ok, est.reason
    assert angle_deg(est.up, R @ tread) < 3.0


@settings(max_examples=25, deadline=None)
@given(
    roll=st.floats(-0.3, 0.3),
    pitch=st.floats(-0.3, 0.5),
    seed=st.integers(0, 2**16),
)
def test_estimate_follows_the_camera_attitude(roll, pitch, seed):
    """Floor + risers + wall, any camera attitude within the prior: up is found."""
    rng = np.random.default_rng(seed)
    R = _camera(roll, pitch)
    fams = [
        (np.array([0.0, 0.0, 1.0]), 800),
        (np.array([-1.0, 0.0, 0.0]), 800),
        (np.array([0.0, 1.0, 0.0]), 800),
    ]
    est = estimate_up(_sample(fams, R, rng, clutter=400))
    assert est.ok
    assert angle_deg(est.up, R @ np.array([0.0, 0.0, 1.0])) < COARSE_TOL_DEG


@settings(max_examples=40, deadline=None)
@given(
    a=st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.1),
    b=st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.1),
)
def test_rotation_between_takes_a_to_b(a, b):
    a, b = np.array(a) / np.linalg.norm(a), np.array(b) / np.linalg.norm(b)
    R = rotation_between(a, b)
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-9) and np.linalg.det(R) == pytest.approx(1.0)
    assert np.allclose(R @ a, b, atol=1e-7)


def test_yaw_frame_from_up_levels_and_keeps_the_heading():
    R = _camera(0.05, 0.2)
    up = R @ np.array([0.0, 0.0, 1.0])
    T = yaw_frame_from_up(up, "camera_rect")
    assert np.allclose(T.apply_vectors(up), [0.0, 0.0, 1.0], atol=1e-9)
    fwd = T.apply_vectors(np.array([0.0, 0.0, 1.0]))
    assert fwd[1] == pytest.approx(0.0, abs=1e-9) and fwd[0] > 0


def test_config_is_checked():
    with pytest.raises(ConfigError, match="prior_cone_deg"):
        GravityConfig(prior_cone_deg=0)
    with pytest.raises(ConfigError, match="min_support"):
        GravityConfig(min_support=0.5)
    with pytest.raises(ConfigError, match="plane_pieces"):
        GravityConfig(plane_pieces=0.5)


def test_pipeline_without_rig_reports_scene_gravity_and_with_rig_checks_it():
    scene = render_scene(default_scene_spec())
    free = Pipeline(scene.calibration).run(scene.left, scene.right)
    true_up = (
        (scene.rig.T_yaw_camera @ free.rectified.rectification.T_camera_rect)
        .inverse()
        .apply_vectors(np.array([0.0, 0.0, 1.0]))
    )
    g = free.to_json_dict()["gravity"]
    assert g["source"] == "scene" and 0 < g["sigma_deg"] < 2.0
    assert angle_deg(free.gravity.up_camera, true_up) < 1.0
    rigged = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right).to_json_dict()["gravity"]
    assert rigged["source"] == "rig" and rigged["rig_disagreement_deg"] < 1.0
    assert "agrees" in rigged["note"]


def test_a_wrong_rig_is_reported():
    from stereo_terrain.frames import Rig, camera_mount

    scene = render_scene(default_scene_spec())
    wrong = Rig(camera_mount(0.55, 0.0))  # the camera is pitched down 15 deg, not 0
    g = Pipeline(scene.calibration, wrong).run(scene.left, scene.right).to_json_dict()["gravity"]
    assert g["rig_disagreement_deg"] > 10.0 and "check the rig" in g["note"]


def test_a_rig_off_by_more_than_the_prior_cone_is_reported_in_the_note():
    """An identity ``T_body_camera`` (a newcomer's rig file) puts up along the optical axis,
    about 90 deg from the truth: beyond the rig check's cone around the rig's up, so the
    scene's own up (camera roughly upright) is the check."""
    from stereo_terrain.frames import Rig, Transform

    scene = render_scene(default_scene_spec())
    identity = Rig(Transform(np.eye(4), "body", "camera"))
    result = Pipeline(scene.calibration, identity, warm_up=False).run(scene.left, scene.right).to_json_dict()
    assert result["gravity"]["rig_disagreement_deg"] > 80.0
    assert "check the rig" in result["gravity"]["note"] and "check the rig" in result["note"]
    good = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right).to_json_dict()
    assert "check the rig" not in good["note"]


def test_a_correct_rig_pitched_beyond_the_prior_cone_is_not_flagged(monkeypatch):
    """A camera pitched 50 deg down with its true rig, on a frame whose planes do not fix
    up (forced): the upright estimate, which takes the risers' normals for up there, is
    the worse fixed one, so the rig's own check stands."""
    import stereo_terrain.pipeline.core as core

    spec = default_scene_spec()
    spec = dataclasses.replace(
        spec,
        pitch_down_rad=math.radians(50.0),
        camera_height_m=0.9,
        obstacle=dataclasses.replace(spec.obstacle, distance_m=0.8),
    )
    scene = render_scene(spec)
    unsure = GravityEstimate(np.full(3, np.nan), "yaw", math.inf, False, reason="forced: planes unsure")
    monkeypatch.setattr(core, "refine_up_from_planes", lambda planes, config: unsure)
    g = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right).gravity
    assert g.rig_disagreement_deg is not None and g.rig_disagreement_deg < 5.0 and not g.rig_warning


@pytest.mark.parametrize(
    ("yaw_deg", "pitch_deg", "roll_deg"), [(0.0, 0.0, 0.0), (20.0, 5.0, 2.0), (-30.0, -3.0, -2.0)]
)
def test_gravity_from_a_rendered_scene_without_floor(yaw_deg, pitch_deg, roll_deg):
    """A level camera 0.45 m high, 0.8 m from a 2.5 m wide staircase: no floor in front
    (the first riser's foot is below the image), risers and treads only."""
    spec = close_level_stairs_spec(
        n_steps=5, width_m=2.5, distance_m=0.8, yaw_deg=yaw_deg, pitch_deg=pitch_deg, roll_deg=roll_deg,
        back_wall_m=None,
    )  # fmt: skip
    scene = render_scene(spec)
    floor = float(np.mean(scene.labels_left == 0))  # label 0: the ground
    assert floor < 0.06, floor  # (almost) no floor in view, none in front of the stairs
    pipeline = Pipeline(scene.calibration)
    result = pipeline.run(scene.left, scene.right)
    T_true = scene.rig.T_yaw_camera @ pipeline.rectification.T_camera_rect
    true_up = T_true.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
    assert result.gravity_source == "scene"
    assert angle_deg(result.gravity.up_camera, true_up) < NO_FLOOR_TOL_DEG
    assert result.terrain.obstacle == "stairs"


#: Bound on the gravity error of a rendered scene without floor (measured 0.2-0.4 deg).
NO_FLOOR_TOL_DEG = 1.5


def _irls_reference(cons, u, floor):
    """The Gauss-Newton of refine_up_from_planes as NumPy matrices (before issue 13's
    scalar version): up and the widened largest variance, or None."""
    from stereo_terrain.gravity.from_planes import _CAUCHY_SCALE
    from stereo_terrain.gravity.geometry import _tangent_basis
    from stereo_terrain.planes.orientation import HORIZONTAL

    weights = np.ones(len(cons))
    for _ in range(8):
        B = _tangent_basis(u)
        H, g, chi = np.zeros((2, 2)), np.zeros(2), np.zeros(len(cons))
        for k, (kind, n, cov_n) in enumerate(cons):
            if kind == HORIZONTAL:
                W = np.linalg.inv(B @ cov_n @ B.T + floor * np.eye(2))
                r = B @ n
                chi[k] = math.sqrt(float(r @ W @ r) / 2)
                H += weights[k] * W
                g += weights[k] * W @ r
            else:
                J = (B @ n)[None, :]
                W = np.linalg.inv(np.array([[u @ cov_n @ u + floor]]))
                r = np.array([-n @ u])
                chi[k] = math.sqrt(float(r @ W @ r))
                H += weights[k] * J.T @ W @ J
                g += weights[k] * J.T @ W @ r
        if np.linalg.cond(H) > 1e8:
            return None
        delta = np.linalg.solve(H, g)
        u = u + B.T @ delta
        u /= np.linalg.norm(u)
        weights = 1.0 / (1.0 + (chi / _CAUCHY_SCALE) ** 2)
        if np.linalg.norm(delta) < 1e-7:
            break
    dof = sum(2 if kind == HORIZONTAL else 1 for kind, _, _ in cons) - 2
    chi2 = float(np.sum(weights * chi * chi)) / float(np.sum(weights)) * (dof + 2)
    scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    return u, scale * float(np.linalg.eigvalsh(np.linalg.inv(H))[-1])


def test_scalar_gauss_newton_is_the_matrix_one():
    """refine_up_from_planes's Gauss-Newton in Python floats (issue 13) gives the matrix
    formulation's up and variance to rounding, and fails where it fails."""
    from stereo_terrain.gravity.from_planes import _irls_up
    from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL

    rng = np.random.default_rng(13)
    floor = math.radians(0.3) ** 2
    for t in range(300):
        R = rotation_from_rpy(*rng.normal(0.0, 0.05, 3))
        cons = []
        for _ in range(int(rng.integers(1, 7))):
            if rng.random() < 0.4:
                kind, n = HORIZONTAL, R @ np.array([0.0, 0.0, 1.0])
            else:
                a = rng.uniform(0, math.pi) if t % 4 else rng.choice([0.0, 1e-4])  # one wall family
                kind, n = VERTICAL, R @ np.array([math.cos(a), math.sin(a), 0.0])
            n = n + rng.normal(0.0, 0.01, 3)
            E = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            cov = sum(np.outer(E[:, k], E[:, k]) * 10.0 ** rng.uniform(-7, -3) for k in (1, 2))
            cons.append((kind, n / np.linalg.norm(n), cov))
        if sum(2 if c[0] == HORIZONTAL else 1 for c in cons) < 2:
            continue
        u0 = np.array([0.0, 0.0, 1.0]) + rng.normal(0.0, 0.03, 3)
        u0 /= np.linalg.norm(u0)
        want = _irls_reference(cons, u0.copy(), floor)
        got = _irls_up(cons, (float(u0[0]), float(u0[1]), float(u0[2])), floor)
        assert (got is None) == (want is None), t
        if got is not None and want is not None:
            assert np.abs(got[0] - want[0]).max() < 1e-12, t
            assert got[1] == pytest.approx(want[1], rel=1e-8), t


def test_the_rig_check_runs_only_when_the_planes_do_not_settle_it(monkeypatch):
    """With a rig the local normals' estimate (the rig check) is skipped when the planes
    found in the rig's frame agree with it; a rig 15 deg off still runs it (issue 13)."""
    from stereo_terrain.frames import Rig, camera_mount
    from stereo_terrain.pipeline import gravity_steps as pipeline_module

    scene = render_scene(default_scene_spec())
    calls = []

    def counted(*args, **kwargs):
        calls.append(1)
        return estimate_up(*args, **kwargs)

    monkeypatch.setattr(pipeline_module, "estimate_up", counted)
    good = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert calls == [] and "agrees" in good.gravity.note
    wrong = Pipeline(scene.calibration, Rig(camera_mount(0.55, 0.0)), warm_up=False)
    g = wrong.run(scene.left, scene.right).gravity
    assert calls == [1] and g.rig_disagreement_deg > 10.0
