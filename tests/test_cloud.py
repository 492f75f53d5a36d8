import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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


def _wall_disparity(top_curve, bottom_curve, right_drop):
    """A fronto-parallel wall 2 m ahead filling the view, its disparity NaN where a
    ``keep`` rectification has no source pixel: above ``top_curve`` and below
    ``bottom_curve`` (rows per column) in the left image, ``right_drop`` rows more at the
    top in the right one."""
    from stereo_terrain.rectify import compute_rectification
    from stereo_terrain.stereo import DisparityMap

    from .analytic import B_M, F_PX, rectified_calibration

    w, h = rectified_calibration().image_size
    rows = np.arange(h)[:, None]
    valid_left = (rows >= top_curve[None, :]) & (rows <= bottom_curve[None, :])
    valid_right = (rows >= top_curve[None, :] + right_drop) & (rows <= bottom_curve[None, :])
    rect = dataclasses.replace(
        compute_rectification(rectified_calibration()), valid_left=valid_left, valid_right=valid_right
    )
    disp = np.full((h, w), F_PX * B_M / 2.0, np.float32)
    disp[~(valid_left & valid_right)] = np.nan
    return DisparityMap(disp, 64, rect)


@settings(max_examples=25)
@given(
    top=st.integers(0, 60),
    bow=st.integers(0, 30),
    bottom=st.integers(0, 60),
    right_drop=st.integers(0, 15),
)
def test_the_views_top_and_bottom_are_where_both_images_have_a_source(top, bow, bottom, right_drop):
    """With a rectification that keeps the raw view (its top and bottom edges bowed: the
    middle of the width lower at the top, higher at the bottom), the samples' rows counted
    from the view's edges in each column start where they start in an image without
    sourceless rows: one grid row below the top (give or take one, where the top's row
    changes across a box's width), and the lowest within a grid step of the bottom."""
    from stereo_terrain.rectify import compute_rectification

    from .analytic import rectified_calibration

    T = Transform(np.eye(4), "yaw", "camera_rect")
    w, h = rectified_calibration().image_size
    x = np.linspace(-1.0, 1.0, w)
    top_curve = np.round(top + bow * (1 - x**2)).astype(int)
    bottom_curve = np.round(h - 1 - bottom - bow * (1 - x**2)).astype(int)
    s = sample_disparity(_wall_disparity(top_curve, bottom_curve, right_drop), T, CloudConfig(max_depth_m=10))
    cols = s.grid_index % s.grid_shape[1]
    assert s.source_rows is not None
    assert np.array_equal(s.source_rows[0], (top_curve + right_drop)[s.stride_px // 2 :: s.stride_px])
    assert np.array_equal(s.source_rows[1], bottom_curve[s.stride_px // 2 :: s.stride_px])
    below_top, above_bottom = s.grid_rows_below_top(), s.rows_above_bottom()
    plain = sample_disparity(
        dataclasses.replace(
            _wall_disparity(np.zeros(w, int), np.full(w, h - 1), 0),
            rectification=compute_rectification(rectified_calibration()),
        ),
        T,
        CloudConfig(max_depth_m=10),
    )
    assert plain.source_rows is None
    assert plain.grid_rows_below_top().min() == 1
    inner = [c for c in np.unique(cols) if 2 <= c < s.grid_shape[1] - 2]  # off the side borders
    for c in inner:
        assert below_top[cols == c].min() in (0, 1, 2)
        assert above_bottom[cols == c].min() - above_bottom.min() <= s.stride_px
