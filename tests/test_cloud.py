import numpy as np
import pytest

from stereo_terrain.cloud import (
    CloudConfig,
    disparity_to_cloud,
    sample_disparity,
    sample_grid,
    transform_cloud,
    transform_sample,
)
from stereo_terrain.errors import ConfigError, FrameError
from stereo_terrain.frames import Transform

from .analytic import step_scene

ON_PLANE_M = 1e-3


def test_cloud_points_lie_on_the_scene_planes():
    disp, T = step_scene()
    cloud = transform_cloud(disparity_to_cloud(disp, CloudConfig(max_depth_m=10)), T)
    assert cloud.frame == "yaw" and cloud.points.shape == (480, 640, 3)
    pts = cloud.points[cloud.valid]
    on_ground = np.abs(pts[:, 2]) < ON_PLANE_M
    on_riser = np.abs(pts[:, 0] - 1.4) < ON_PLANE_M
    on_tread = np.abs(pts[:, 2] - 0.18) < ON_PLANE_M
    assert (on_ground | on_riser | on_tread).mean() > 0.999
    assert np.allclose(cloud.camera_position, [0, 0, 0.6])


def test_invalid_and_out_of_range_become_nan():
    disp, _ = step_scene()
    cloud = disparity_to_cloud(disp, CloudConfig(min_depth_m=0.5, max_depth_m=2.0))
    z = cloud.points[..., 2]
    assert np.all(np.isnan(z[~cloud.valid]))
    assert np.nanmax(z) <= 2.0 and np.nanmin(z) >= 0.5
    assert np.isnan(disp.disparity).any() and not cloud.valid[np.isnan(disp.disparity)].any()


def test_grid_sample_normals():
    disp, T = step_scene()
    s = sample_disparity(disp, T, CloudConfig(max_depth_m=10))
    assert s.frame == "yaw" and len(s) > 5000
    ground = np.abs(s.points[:, 2]) < ON_PLANE_M
    riser = (np.abs(s.points[:, 0] - 1.4) < ON_PLANE_M) & (s.points[:, 2] > 0.05) & (s.points[:, 2] < 0.13)
    assert np.median(np.abs(s.normals[ground, 2])) > 0.999
    assert np.median(np.abs(s.normals[riser, 0])) > 0.99
    # Same result as sampling the full cloud.
    full = sample_grid(transform_cloud(disparity_to_cloud(disp, CloudConfig(max_depth_m=10)), T))
    assert abs(len(full) - len(s)) < 0.05 * len(s)


def test_transform_sample_round_trip():
    disp, T = step_scene()
    s = sample_disparity(disp, Transform.identity("camera_rect"))
    back = transform_sample(transform_sample(s, T), T.inverse())
    assert np.allclose(back.points, s.points, atol=1e-5) and np.allclose(back.normals, s.normals, atol=1e-5)


def test_frames_must_chain():
    disp, T = step_scene()
    cloud = disparity_to_cloud(disp)
    with pytest.raises(FrameError):
        transform_cloud(cloud, Transform.identity("yaw"))
    with pytest.raises(FrameError):
        sample_disparity(disp, Transform.identity("yaw"))
    with pytest.raises(ConfigError):
        CloudConfig(min_depth_m=3, max_depth_m=1)


def _sample_disparity_numpy(disparity, T, config, target_points=12000, disparity_sigma_px=0.25):
    """The grid sample as NumPy computed it before the compiled pass (issue 13): the
    reference the kernel must equal bit for bit."""
    from stereo_terrain.cloud import _box_means, _grid_cells

    rect = disparity.rectification
    fb = rect.focal_px * rect.baseline_m
    dd, valid, cnt, acc, stride, k = _box_means(disparity, config, target_points, None)
    rr, cc, ru, rd, cl, cr, idx, _ = _grid_cells(valid, cnt, stride, k)
    cx, cy, f = rect.cx, rect.cy, rect.focal_px

    def reproject(r, c, disp):
        z = fb / disp
        return np.column_stack([(c - cx) * z / f, (r - cy) * z / f, z])

    def mean_at(r, c):
        return acc[r, c] / cnt[r, c]

    a = reproject(rr, cr, mean_at(rr, cr)) - reproject(rr, cl, mean_at(rr, cl))
    b = reproject(rd, cc, mean_at(rd, cc)) - reproject(ru, cc, mean_at(ru, cc))
    n = np.cross(a, b)
    norm = np.sqrt(np.einsum("ij,ij->i", n, n))
    good = (norm > 0) & np.isfinite(norm)
    n = n[good] / norm[good, None]
    rr, cc, idx = rr[good], cc[good], idx[good]
    pts = reproject(rr, cc, dd[rr, cc].astype(np.float64))
    sigma = (pts[:, 2] ** 2) * (disparity_sigma_px / fb)
    return (
        T.apply(pts).astype(np.float32),
        T.apply_vectors(n).astype(np.float32),
        sigma.astype(np.float32),
        idx,
    )


@pytest.mark.parametrize("doffs", [0.0, 3.5])
def test_compiled_grid_sample_equals_numpy_bit_for_bit(doffs):
    import dataclasses

    disp, T = step_scene()
    rng = np.random.default_rng(3)
    noisy = disp.disparity + rng.normal(0, 0.3, disp.disparity.shape).astype(np.float32)
    noisy[rng.random(noisy.shape) < 0.05] = np.nan  # scattered holes: cells and boxes mostly valid or not
    rect = dataclasses.replace(disp.rectification, doffs_px=doffs)
    disp = dataclasses.replace(disp, disparity=noisy, rectification=rect)
    config = CloudConfig(max_depth_m=10)
    s = sample_disparity(disp, T, config)
    points, normals, sigma, idx = _sample_disparity_numpy(disp, T, config)
    assert len(s) > 5000
    assert np.array_equal(s.grid_index, idx)
    assert np.array_equal(s.points, points) and np.array_equal(s.normals, normals)
    assert np.array_equal(s.sigma_m, sigma)
