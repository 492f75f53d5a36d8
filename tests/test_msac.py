import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereo_terrain.errors import InputError
from stereo_terrain.frames import rotation_from_rpy
from stereo_terrain.msac import Plane, msac, plane_msac, required_trials

NORMAL_TOL_DEG = 1.0
# arccos near 1 loses precision: ~1e-6 deg is round-off, 1e-4 deg is still exact for a fit.
EXACT_DEG = 1e-4


def _noisy_plane(rng, n_in=300, n_out=150, normal=(0.2, -0.1, 1.0), offset=-0.4, noise=0.003):
    normal = np.asarray(normal) / np.linalg.norm(normal)
    a = np.cross(normal, [1.0, 0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(normal, a)
    uv = rng.uniform(-1, 1, (n_in, 2))
    pts = -offset * normal + uv[:, :1] * a + uv[:, 1:] * b + rng.normal(0, noise, (n_in, 1)) * normal
    out = rng.uniform(-1.5, 1.5, (n_out, 3))
    return np.vstack([pts, out]), normal, offset, n_in


def _angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(abs(np.dot(a, b)), 0, 1)))


def test_msac_recovers_plane_with_outliers():
    rng = np.random.default_rng(1)
    data, normal, offset, n_in = _noisy_plane(rng)
    res = msac(data, Plane.estimate, 3, 0.01, rng=2)
    assert res.success
    assert _angle_deg(res.model.normal, normal) < NORMAL_TOL_DEG
    assert res.inliers[:n_in].mean() > 0.97  # true inliers found
    assert res.inliers[n_in:].mean() < 0.05  # outliers rejected
    assert res.trials < 1000  # adaptive stopping kicked in


def test_msac_deterministic_for_seed():
    rng = np.random.default_rng(3)
    data, *_ = _noisy_plane(rng)
    a = msac(data, Plane.estimate, 3, 0.01, rng=7)
    b = msac(data, Plane.estimate, 3, 0.01, rng=7)
    assert np.array_equal(a.inliers, b.inliers) and a.trials == b.trials


def test_msac_orientation_constraint_rejects_wrong_planes():
    rng = np.random.default_rng(4)
    data, *_ = _noisy_plane(rng, normal=(1.0, 0.0, 1.0))  # 45 deg tilted

    def horizontal(model):
        return abs(model.normal[2]) > np.cos(np.radians(10))

    res = msac(data, Plane.estimate, 3, 0.01, rng=0, is_model_valid=horizontal, max_trials=200)
    assert not res.success or horizontal(res.model)


def test_msac_degenerate_inputs():
    assert not msac(np.zeros((2, 3)), Plane.estimate, 3, 0.01, rng=0).success
    line = np.c_[np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)]
    assert not msac(line, Plane.estimate, 3, 0.01, rng=0, max_trials=20).success
    with pytest.raises(InputError):
        msac(np.zeros(5), Plane.estimate, 3, 0.01)
    with pytest.raises(InputError):
        msac(np.zeros((5, 3)), Plane.estimate, 3, 0.0)
    with pytest.raises(InputError):
        Plane([0.0, 0.0, 0.0], 1.0)


def test_plane_msac_vectorised_matches():
    rng = np.random.default_rng(5)
    data, normal, offset, n_in = _noisy_plane(rng)
    samples = rng.integers(0, len(data), (300, 3))
    res = plane_msac(data, 0.01, samples)
    assert _angle_deg(res.model.normal, normal) < 3.0
    assert res.inliers[:n_in].mean() > 0.9


def test_required_trials():
    assert required_trials(1.0, 3, 0.99) == 1
    assert required_trials(0.5, 3, 0.99) == 35


@given(
    st.integers(0, 2**31 - 1),
    st.floats(-np.pi, np.pi),
    st.floats(-1.5, 1.5),
    st.floats(-np.pi, np.pi),
    st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-3, 3)),
)
def test_plane_fit_invariant_to_order_and_rigid_motion(seed, r, p, y, t):
    rng = np.random.default_rng(seed)
    pts, *_ = _noisy_plane(rng, n_in=60, n_out=0)
    fit = Plane.estimate(pts)
    perm = rng.permutation(len(pts))
    fit_perm = Plane.estimate(pts[perm])
    assert _angle_deg(fit.normal, fit_perm.normal) < EXACT_DEG
    R = rotation_from_rpy(r, p, y)
    moved = pts @ R.T + np.asarray(t)
    fit_moved = Plane.estimate(moved)
    assert _angle_deg(fit_moved.normal, R @ fit.normal) < EXACT_DEG
    assert np.allclose(fit_moved.residuals(moved), fit.residuals(pts), atol=1e-7)
    # the plane moved as its points were: the same signed distances
    assert np.allclose(
        fit.moved(R, np.asarray(t)).signed_distance(moved), fit.signed_distance(pts), atol=1e-9
    )


def test_required_trials_edge_cases():
    assert required_trials(0.0, 3, 0.99) == 2**31 - 1
    assert required_trials(1e-7, 3, 0.99) == 2**31 - 1
    with pytest.raises(InputError):
        required_trials(0.5, 3, 1.0)


def test_msac_with_no_inliers_at_all_is_a_failed_result():
    class Far:
        def residuals(self, data):
            return np.ones(len(data))

    res = msac(np.zeros((10, 3)), lambda s: Far(), 3, 0.5, rng=0, max_trials=20)
    assert res.model is not None and not res.inliers.any() and res.trials == 20
