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
SAMPLE_FIELDS = ("points", "normals", "sigma_m", "rows", "cols", "grid_index", "normal_sigma_rad")
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
            **{k: getattr(s, k)[:10] for k in SAMPLE_FIELDS},
        }
    )
    ps = extract_planes_orientation(tiny)
    assert ps.segments == () and "too small" in ps.stop_reason
    ground = np.abs(s.points[:, 2]) < 1e-3
    only = GridSample(
        **{
            **s.__dict__,
            **{k: getattr(s, k)[ground] for k in SAMPLE_FIELDS},
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


@pytest.mark.parametrize("seed", range(4))
def test_one_batch_round_is_the_general_round_bit_for_bit(seed):
    """Issue 13: the fused compiled round (one batch, the default) draws what the general
    round draws and gives the same plane, inliers and ratio, bit for bit."""
    from stereo_terrain.planes import orientation as o

    samples = _samples(noise_m=0.004, outliers=0.1, seed=seed)
    config = OrientationConfig(score_points=300 + 200 * seed)
    P, N = samples.points, samples.normals
    thr = np.clip(3.0 * samples.sigma_m, 0.012, 0.05).astype(np.float32)
    lut, gr, gc = o.grid_lookup(samples)
    up = np.array([0.0, 0.0, 1.0])
    orient = (
        up,
        float(np.cos(np.radians(6.0))),
        float(np.sin(np.radians(6.0))),
        (1.0 / thr).astype(np.float32),
    )
    agree = np.full(len(P), float(np.cos(np.radians(config.normal_agreement_deg))))
    if seed >= 2:  # per-sample agreement widened by the normals' noise (far samples)
        agree = np.cos(np.radians(np.random.default_rng(seed).uniform(20.0, 45.0, len(P))))
    remaining = np.random.default_rng(seed).random(len(P)) < 0.8  # a cloud with planes taken out
    rest = np.flatnonzero(remaining)
    first = rest[::2]
    weights = np.random.default_rng(seed).uniform(0.1, 1.0, len(P)) if seed % 2 else np.ones(len(P))
    rest_view = (rest, P[rest], N[rest], thr[rest], weights[rest] if seed % 2 else None)
    cfg_general = (
        config
        if seed % 2 == 0
        else OrientationConfig(score_points=config.score_points, confidence_weights=True)
    )
    for r in range(3):
        a = o._best_plane(
            P,
            N,
            thr,
            lut,
            gr,
            gc,
            first,
            remaining,
            rest_view,
            np.random.default_rng(r),
            cfg_general,
            orient,
            agree,
        )
        b = o._one_batch_round(
            P,
            N,
            thr,
            weights,
            lut,
            gr,
            gc,
            first,
            remaining,
            rest,
            np.random.default_rng(r),
            config,
            orient,
            agree,
        )
        assert a is not None and b is not None
        assert a[0].normal.tobytes() == b[0].normal.tobytes() and a[0].offset == b[0].offset
        assert np.array_equal(np.flatnonzero(a[1]), b[1])
        assert a[2] == b[2] and a[3] == b[3]


def test_one_batch_round_without_a_valid_hypothesis_is_none():
    from stereo_terrain.planes import orientation as o

    samples = _samples()
    thr = np.full(len(samples), 0.02, np.float32)
    lut, gr, gc = o.grid_lookup(samples)
    orient = (np.array([0.0, 0.0, 1.0]), 1.0, 0.0, (1.0 / thr).astype(np.float32))  # nothing passes
    remaining = np.zeros(len(samples), dtype=bool)
    remaining[:3] = True  # three points, far apart in the grid: no triplet
    rest = np.flatnonzero(remaining)
    got = o._one_batch_round(
        samples.points,
        samples.normals,
        thr,
        np.ones(len(samples)),
        lut,
        gr,
        gc,
        rest,
        remaining,
        rest,
        np.random.default_rng(0),
        OrientationConfig(),
        orient,
        np.full(len(samples), float(np.cos(np.radians(20.0)))),
    )
    assert got is None
