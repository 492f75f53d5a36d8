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
