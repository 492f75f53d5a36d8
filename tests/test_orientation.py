import numpy as np
import pytest

from stereo_terrain.cloud import CloudConfig, GridSample, sample_disparity
from stereo_terrain.errors import ConfigError
from stereo_terrain.planes.orientation import (
    HORIZONTAL,
    VERTICAL,
    OrientationConfig,
    classify_normal,
    extract_planes_orientation,
)

from .analytic import step_scene

NORMAL_TOL_DEG = 1.0
OFFSET_TOL_M = 0.005


def _samples(noise_m=0.0, outliers=0.0, seed=0):
    disp, T = step_scene()
    s = sample_disparity(disp, T, CloudConfig(max_depth_m=10))
    rng = np.random.default_rng(seed)
    pts = s.points + rng.normal(0, noise_m, s.points.shape).astype(np.float32)
    if outliers:
        k = rng.random(len(pts)) < outliers
        pts[k] += rng.uniform(-0.5, 0.5, (k.sum(), 3)).astype(np.float32)
    return GridSample(**{**s.__dict__, "points": pts})


def _angle(a, b):
    return np.degrees(np.arccos(np.clip(abs(np.dot(a, b)), 0, 1)))


def test_finds_ground_riser_and_tread():
    samples = _samples(noise_m=0.003, outliers=0.05)
    ps = extract_planes_orientation(samples)
    horiz = [s for s in ps.segments if s.kind == HORIZONTAL]
    vert = [s for s in ps.segments if s.kind == VERTICAL]
    heights = sorted(float(np.median(samples.points[s.indices, 2])) for s in horiz)
    assert heights[0] == pytest.approx(0.0, abs=OFFSET_TOL_M)
    assert any(abs(h - 0.18) < OFFSET_TOL_M for h in heights)
    riser = max(vert, key=lambda s: s.count)
    assert _angle(riser.plane.normal, [1, 0, 0]) < NORMAL_TOL_DEG
    assert riser.plane.normal[0] < 0  # toward the camera
    assert -riser.plane.offset / riser.plane.normal[0] == pytest.approx(1.4, abs=OFFSET_TOL_M)
    for s in horiz:
        assert s.plane.normal[2] > 0  # up
    assert ps.stop_reason


def test_deterministic_for_a_seed():
    s = _samples(noise_m=0.003)
    a = extract_planes_orientation(s, OrientationConfig(seed=3))
    b = extract_planes_orientation(s, OrientationConfig(seed=3))
    assert [x.count for x in a.segments] == [x.count for x in b.segments]


def test_stops_on_its_own_not_at_a_plane_count():
    ps = extract_planes_orientation(_samples())
    assert len(ps.segments) < OrientationConfig().max_planes
    assert "max_planes" not in ps.stop_reason


def test_tiny_and_single_plane_clouds():
    s = _samples()
    tiny = GridSample(
        **{
            **s.__dict__,
            **{k: getattr(s, k)[:10] for k in ("points", "normals", "sigma_m", "rows", "cols", "grid_index")},
        }
    )
    ps = extract_planes_orientation(tiny)
    assert ps.segments == () and "too small" in ps.stop_reason
    ground = np.abs(s.points[:, 2]) < 1e-3
    only = GridSample(
        **{
            **s.__dict__,
            **{
                k: getattr(s, k)[ground]
                for k in ("points", "normals", "sigma_m", "rows", "cols", "grid_index")
            },
        }
    )
    ps = extract_planes_orientation(only)
    assert len(ps.segments) == 1 and ps.segments[0].kind == HORIZONTAL


def test_classify_and_config_checks():
    up = np.array([0, 0, 1.0])
    assert classify_normal(np.array([0, 0.05, 1.0]) / np.hypot(0.05, 1), up, 6) == HORIZONTAL
    assert classify_normal(np.array([1.0, 0, 0.05]) / np.hypot(0.05, 1), up, 6) == VERTICAL
    assert classify_normal(np.array([1.0, 0, 1.0]) / np.sqrt(2), up, 6) == "other"
    with pytest.raises(ConfigError):
        OrientationConfig(angle_tol_deg=60)
    with pytest.raises(ConfigError):
        OrientationConfig(min_plane_points=0)


def test_confidence_keeps_low_confidence_outliers_out():
    """Outliers marked with a low disparity confidence seed no hypothesis and barely weigh
    in the refit; the planes stay as accurate as without outliers."""
    s = _samples(noise_m=0.002)
    rng = np.random.default_rng(1)
    bad = rng.random(len(s)) < 0.3
    pts = s.points.copy()
    pts[bad, 2] += rng.uniform(0.05, 0.3, bad.sum()).astype(np.float32)
    conf = np.where(bad, 0.01, 1.0).astype(np.float32)
    noisy = GridSample(**{**s.__dict__, "points": pts, "confidence": conf})
    assert extract_planes_orientation(noisy).parameters["confidence_weighting"] is False  # opt-in
    ps = extract_planes_orientation(noisy, OrientationConfig(min_confidence=0.2, confidence_weights=True))
    assert ps.parameters["confidence_weighting"] is True
    assert ps.parameters["low_confidence_seeds_excluded"] > 0
    horiz = [g for g in ps.segments if g.kind == HORIZONTAL]
    ground = max(horiz, key=lambda g: g.count)
    assert _angle(ground.plane.normal, [0, 0, 1]) < NORMAL_TOL_DEG
    assert abs(ground.plane.offset) < OFFSET_TOL_M


def test_adaptive_hypotheses_are_reported():
    s = _samples(noise_m=0.003)
    one = extract_planes_orientation(s).parameters["msac_hypotheses"]
    more = extract_planes_orientation(s, OrientationConfig(max_hypotheses_per_plane=400)).parameters[
        "msac_hypotheses"
    ]
    assert one["per_round_max"] <= OrientationConfig().hypotheses_per_plane
    assert more["total"] >= one["total"] * 0.5 and more["per_round_max"] <= 400
    with pytest.raises(ConfigError):
        OrientationConfig(max_hypotheses_per_plane=50)
    with pytest.raises(ConfigError):
        OrientationConfig(confidence=1.5)
