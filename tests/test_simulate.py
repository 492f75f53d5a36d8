"""The kinematic foot model, the controller side and the scenes of the simulated approach
(rendered only to check that textures stay on the surfaces)."""

import dataclasses
import time

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.runtime.simulate import (
    ApproachConfig,
    SwingCommand,
    approach_spec,
    commanded_swing,
    simulate_feet,
    step_profile,
    trigger_position,
)
from stereo_terrain.synthetic import render_scene

CFG = ApproachConfig(image_size=(320, 240))


def _raised_from(x_trigger, height=0.31):
    return lambda x_body: height if x_body >= x_trigger else 0.15


def test_step_profile():
    x = np.array([0.0, CFG.riser_x_m - 1e-6, CFG.riser_x_m + 1e-6, CFG.riser_x_m + CFG.run_m + 0.01, 10.0])
    assert step_profile(CFG, x) == pytest.approx([0.0, 0.0, 0.21, 0.42, 0.63])


def test_blind_swing_hits_and_a_timely_raise_clears():
    blind = simulate_feet(CFG, lambda x: 0.15)
    crossings = [f for f in blind if f.edge_clearance_m is not None]
    assert {f.leg for f in crossings} == {"FL", "FR", "RL", "RR"}
    assert all(f.edge_clearance_m < 0 for f in crossings)  # 0.15 m apex < 0.21 m edge
    raised = simulate_feet(CFG, _raised_from(CFG.riser_x_m - 0.10))
    first = {}
    for f in raised:
        if f.edge_clearance_m is not None:
            first.setdefault(f.leg, f.edge_clearance_m)
    assert all(v > 0 for v in first.values()) and len(first) == 4


def test_a_late_trigger_trips_the_front_feet():
    late = simulate_feet(CFG, _raised_from(CFG.riser_x_m + 0.3))  # after the front feet crossed
    first = {}
    for f in late:
        if f.edge_clearance_m is not None:
            first.setdefault(f.leg, f.edge_clearance_m)
    assert first["FL"] < 0 and first["FR"] < 0 and first["RL"] > 0 and first["RR"] > 0


def test_controller_applies_eq2_between_messages():
    # One message at x = 0.5: riser 1.0 ahead, d_buffer 0.1 -> trigger distance 0.9 from p0 = 0.5.
    cmds = [
        SwingCommand(x_m=0.5, p0_x_m=0.5, trigger_distance_m=0.9, height_m=0.31, raised=False, approach=True)
    ]
    assert commanded_swing(cmds, 1.39, 0.15) == (False, 0.15)
    assert commanded_swing(cmds, 1.401, 0.15) == (True, 0.31)
    assert commanded_swing(cmds, 0.4, 0.15) == (False, 0.15)  # before any message
    assert trigger_position(cmds, 2.0, 0.15) == pytest.approx(1.4, abs=0.0011)


def test_approach_config_is_checked():
    with pytest.raises(ConfigError, match="must start further than"):
        ApproachConfig(start_distance_m=0.3)
    with pytest.raises(ConfigError, match="rear_hip_m"):
        ApproachConfig(rear_hip_m=0.0)
    assert ApproachConfig(start_distance_m=2.2, end_distance_m=0.45, speed_mps=0.5, fps=30).frame_count == 106
    with pytest.raises(ConfigError, match="more than 20000"):
        ApproachConfig(fps=1e9)
    with pytest.raises(ConfigError, match="speed_mps must be >= 0.01"):
        ApproachConfig(speed_mps=1e-9)
    for kw in ({"start_distance_m": 1e308}, {"fps": 1e308}, {"speed_mps": 1e-300, "fps": 1e300}):
        with pytest.raises(ConfigError):
            ApproachConfig(**kw)


def test_an_unknown_approach_profile_is_refused():
    with pytest.raises(ConfigError, match="profile must be one of default, realistic"):
        ApproachConfig(profile="photoreal")


@settings(max_examples=12, deadline=None)
@given(
    yaw_deg=st.floats(-30.0, 30.0),
    x=st.floats(0.0, 1.5),
    seed=st.integers(0, 2**31 - 1),
)
def test_a_realistic_approach_moves_the_walls_with_the_stairs(yaw_deg, x, seed):
    """Seen from x m further on, the stairs are x m closer along the path and the back and
    side walls keep their places beside and behind them (the scene is one rigid world)."""
    cfg = ApproachConfig(
        profile="realistic", seed=seed, image_size=(160, 120), stair_yaw_rad=np.radians(yaw_deg),
        start_distance_m=2.0, supersample=1,
    )  # fmt: skip
    a, b = approach_spec(cfg, 0.0, 0.0), approach_spec(cfg, x, 0.01)
    assert a.profile == b.profile == "realistic" and a.jpeg_quality is not None
    assert (a.obstacle.rise_m, a.obstacle.run_m, a.obstacle.n_steps) == (cfg.rise_m, cfg.run_m, cfg.n_steps)
    assert b.obstacle.distance_m == pytest.approx(cfg.start_distance_m - x)
    assert b.body_rpy == (0.0, 0.01, 0.0) and b.side_wall_start_m is None
    c, s = np.cos(cfg.stair_yaw_rad), np.sin(cfg.stair_yaw_rad)

    def place(spec):  # the first riser's centre: along the stair axis, and across it
        ob = spec.obstacle
        return ob.distance_m * c, -ob.distance_m * s + ob.lateral_m

    (ua, va), (ub, vb) = place(a), place(b)
    assert b.back_wall_m - ub == pytest.approx(a.back_wall_m - ua)
    for side in ("left_wall_m", "right_wall_m"):
        wa, wb = getattr(a, side), getattr(b, side)
        assert (wa is None) == (wb is None)
        if wa is not None:
            assert wb - vb == pytest.approx(wa - va)


def _walk_pair(cfg, x_b, *, glued=True):
    """The scenes rendered from the start and from ``x_b`` further on, without noise, blur,
    vignetting or JPEG; textures glued to the world or (``glued`` False) counted from the
    camera as before."""
    quiet = {"noise_sigma": (0.0, 0.0), "shot_noise": 0.0, "blur_sigma_px": 0.0, "right_blur_sigma_px": None}
    quiet.update(vignetting=0.0, jpeg_quality=None)
    a = dataclasses.replace(approach_spec(cfg, 0.0, 0.0), **quiet)
    b = dataclasses.replace(approach_spec(cfg, x_b, 0.0), **quiet)
    if not glued:
        b = dataclasses.replace(b, texture_origin_m=(0.0, 0.0))
    sa, sb = render_scene(a), render_scene(b)
    return sa, sb


@pytest.mark.parametrize("profile", ["default", "realistic"])
def test_the_approach_textures_stay_on_the_surfaces(profile):
    """A surface point seen from two places of the walk has the same grey level (noise,
    blur and JPEG off): its texture does not slide with the camera."""
    cfg = ApproachConfig(image_size=(160, 120), supersample=1, profile=profile, seed=5, start_distance_m=2.0)
    x_b = 0.3

    def grey_differences(glued):
        sa, sb = _walk_pair(cfg, x_b, glued=glued)
        K = sb.calibration.K1
        D = sb.calibration.D1
        v, u = np.nonzero(np.isfinite(sb.depth_left))
        pix = np.stack([u, v], axis=1).astype(np.float64)[:, None, :]
        ray = cv2.undistortPoints(pix, K, D).reshape(-1, 2)
        z = sb.depth_left[v, u].astype(np.float64)
        pts_b = np.column_stack([ray * z[:, None], z])
        world = sb.rig.T_yaw_camera.apply(pts_b) + np.array([x_b, 0.0, 0.0])  # in frame a's yaw frame
        pts_a = sa.rig.T_yaw_camera.inverse().apply(world)
        ahead = pts_a[:, 2] > 0.1
        cal = sa.calibration
        uv, _ = cv2.projectPoints(pts_a[ahead], np.zeros(3), np.zeros(3), cal.K1, cal.D1)
        uv = np.rint(uv.reshape(-1, 2)).astype(int)
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < 160) & (uv[:, 1] >= 0) & (uv[:, 1] < 120)
        ua, va = uv[inside].T
        ub, vb = u[ahead][inside], v[ahead][inside]
        # the same surface seen from a (depth agrees): not hidden there
        za = sa.depth_left[va, ua]
        seen = np.abs(za - pts_a[ahead][inside][:, 2]) < 0.02
        return np.abs(sa.left[va, ua].astype(float) - sb.left[vb, ub].astype(float))[seen]

    glued, slid = grey_differences(True), grey_differences(False)
    assert len(glued) > 2000
    # (160x120, 0.3 m apart: p90 4-5 grey levels glued, 17-35 slid)
    assert np.percentile(glued, 90) < min(8.0, 0.5 * np.percentile(slid, 90))


def test_the_simulated_approach_runs_on_its_own_time(monkeypatch):
    """The live loop of ``simulate_approach`` takes each frame's capture time (k / fps) for
    the time, as if the machine kept up: a slow machine gives the same messages (on the
    machine's clock, a loaded machine stretched the time between frames, and the tracker
    dropped a track after fewer frames)."""
    from stereo_terrain.pipeline import Pipeline
    from stereo_terrain.runtime.simulate import simulate_approach

    cfg = ApproachConfig(image_size=(160, 120), supersample=1, start_distance_m=0.8, fps=10.0)

    def key(result):
        return [
            (m.frame_index, m.utime, m.publish_utime, m.track_state, m.num_steps, tuple(m.distance_m))
            for m in result.messages
        ]

    fast = simulate_approach(cfg)
    assert [m.utime for m in fast.messages] == [round(k / cfg.fps * 1e6) for k in range(cfg.frame_count)]
    run = Pipeline.run

    def slow_run(self, *args, **kwargs):
        time.sleep(0.05)
        return run(self, *args, **kwargs)

    monkeypatch.setattr(Pipeline, "run", slow_run)
    assert key(simulate_approach(cfg)) == key(fast)
