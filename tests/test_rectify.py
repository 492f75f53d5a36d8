import cv2
import numpy as np
import pytest

from stereo_terrain.calibration import StereoCalibration, read_calibration
from stereo_terrain.errors import InputError
from stereo_terrain.rectify import compute_rectification, read_image, rectify, to_grey, valid_interior


def _calib(size=(640, 480)):
    return StereoCalibration(
        np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
        np.array([-0.1, 0.01, 0, 0, 0]),
        np.array([[500.0, 0, 322], [0, 500, 238], [0, 0, 1]]),
        np.array([-0.1, 0.01, 0, 0, 0]),
        np.eye(3),
        np.array([-0.08, 0.0, 0.0]),
        size,
    )


def test_rectification_geometry():
    rect = compute_rectification(_calib())
    assert rect.maps is not None
    assert np.isclose(rect.baseline_m, 0.08, atol=1e-6)
    assert rect.focal_px > 0 and abs(rect.doffs_px) < 1e-6
    x, y, w, h = rect.valid_roi
    assert w > 400 and h > 300
    # depth from disparity: Z = f B / d
    z = rect.depth_from_disparity(np.array([[rect.focal_px * 0.08 / 2.0, np.nan, -1.0]], np.float32))
    assert np.isclose(z[0, 0], 2.0) and np.isnan(z[0, 1]) and np.isnan(z[0, 2])


def test_rectify_shapes_and_bad_pairs():
    rect = compute_rectification(_calib())
    img = np.random.default_rng(0).integers(0, 255, (480, 640), dtype=np.uint8)
    pair = rectify(img, img, rect)
    assert pair.left.shape == (480, 640) and pair.left.dtype == np.uint8
    with pytest.raises(InputError, match="differ in size"):
        rectify(img, img[:, :600], rect)
    with pytest.raises(InputError, match="calibration is for 640x480"):
        rectify(img[:240, :320], img[:240, :320], rect)
    with pytest.raises(InputError, match="uint8"):
        rectify(img.astype(np.float32), img.astype(np.float32), rect)


def test_bgr_and_uint16_to_grey():
    bgr = np.zeros((4, 5, 3), np.uint8)
    assert to_grey(bgr).shape == (4, 5)
    assert to_grey(np.full((4, 5), 65535, np.uint16)).max() == 255


def test_read_image_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_image(tmp_path / "none.png")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot decode"):
        read_image(bad)


def test_already_rectified_passthrough(shared_data):
    d = shared_data / "middlebury2014Q" / "Piano"
    rect = compute_rectification(read_calibration(d / "calib.txt"))
    assert rect.maps is None and np.isclose(rect.doffs_px, 31.34, atol=0.01)
    left = read_image(d / "im0.png")
    pair = rectify(left, read_image(d / "im1.png"), rect)
    assert pair.left is left


# --------------------------------------------------------------------------- fov="keep"


@pytest.fixture(scope="module")
def demo():
    from stereo_terrain.synthetic import default_scene_spec, render_scene

    return render_scene(default_scene_spec())


def test_keep_holds_the_whole_raw_left_image(demo):
    from stereo_terrain.rectify import SOURCE_MARGIN_PX, rectify_points

    calib = demo.calibration
    rect = compute_rectification(calib, fov="keep")
    old = compute_rectification(calib, fov="valid")
    w, h = rect.raw_size
    rw, rh = rect.image_size
    assert (w, h) == (640, 480) and rw > w and rh > h and rect.size == (rw, rh)
    # The raw outline, corners included, lands inside the rectified image, and (but for the
    # margin) on pixels that have a source; alpha 0 cut the bottom row away.
    m = SOURCE_MARGIN_PX + 1.0
    xs = np.linspace(m, w - 1 - m, 41)
    edges = np.concatenate(
        [np.column_stack([xs, np.full_like(xs, h - 1 - m)]), np.column_stack([xs, np.full_like(xs, m)])]
    )
    uv = rectify_points(edges, rect, "left")
    assert np.all((uv >= 0) & (uv <= [rw - 1, rh - 1])), uv
    assert rect.valid_left[np.round(uv[:, 1]).astype(int), np.round(uv[:, 0]).astype(int)].all()
    assert rectify_points(np.array([[w / 2, h - 1.0]]), old, "left")[0, 1] > h - 1
    # Alpha 0's cameras moved by whole pixels: same focal length, alpha 0's image is a crop.
    assert rect.focal_px == old.focal_px and rect.baseline_m == old.baseline_m and rect.doffs_px == 0
    dx, dy = rect.cx - old.cx, rect.cy - old.cy
    assert dx == int(dx) and dy == int(dy) and dx > 0 and dy > 0
    pair, pair0 = rectify(demo.left, demo.right, rect), rectify(demo.left, demo.right, old)
    assert pair.left.shape == (rh, rw) and pair.right.shape == (rh, rw)
    crop = (slice(int(dy), int(dy) + h), slice(int(dx), int(dx) + w))
    assert np.array_equal(pair.left[crop], pair0.left) and np.array_equal(pair.right[crop], pair0.right)
    # Q, P1, P2, T_camera_rect and the ROI agree with each other.
    assert np.allclose(rect.P1[:2, 2], [rect.cx, rect.cy]) and np.allclose(rect.P2[:2, 2], [rect.cx, rect.cy])
    assert np.allclose(rect.Q[:2, 3], [-rect.cx, -rect.cy]) and np.isclose(rect.Q[2, 3], rect.focal_px)
    assert np.isclose(-rect.P2[0, 3] / rect.P2[0, 0], rect.baseline_m)
    assert np.allclose(rect.T_camera_rect.matrix, old.T_camera_rect.matrix)
    x, y, vw, vh = rect.valid_roi
    assert rect.valid_left[y : y + vh, x : x + vw].all() and vw * vh > 0.8 * w * h
    assert rect.valid_left.shape == (rh, rw) and rect.valid_right.shape == (rh, rw)
    # A drift correction of the right camera keeps the rectified cameras and size.
    turned = compute_rectification(
        calib, fov="keep", right_correction=cv2.Rodrigues(np.array([0.0, 0.003, 0.001]))[0]
    )
    assert (
        turned.image_size == rect.image_size
        and np.allclose(turned.P1, rect.P1)
        and np.allclose(turned.Q, rect.Q)
    )


def test_keep_sourceless_pixels_give_nan(demo):
    from stereo_terrain.stereo import make_backend

    rect = compute_rectification(demo.calibration, fov="keep")
    pair = rectify(demo.left, demo.right, rect)
    assert not rect.valid_left.all() and not rect.valid_right.all()
    for name in ("opencv", "sgm"):
        d = make_backend(name).compute(pair, 64).disparity
        assert d.shape == pair.left.shape
        assert np.isfinite(d).mean() > 0.5, name
        assert not np.isfinite(d[~rect.valid_left]).any(), name
        ys, xs = np.nonzero(np.isfinite(d))
        assert rect.valid_right[ys, np.rint(xs - d[ys, xs]).astype(int)].all(), name


def test_keep_reconstructs_the_demo_staircase(demo):
    from stereo_terrain.evaluation import score_result
    from stereo_terrain.pipeline import Pipeline, PipelineConfig

    pipe = Pipeline(demo.calibration, demo.rig, PipelineConfig(rectify_fov="keep"))
    res = pipe.run(demo.left, demo.right)
    assert res.disparity.disparity.shape == res.rectified.left.shape == pipe.rectification.image_size[::-1]
    assert not np.isfinite(res.disparity.disparity[~pipe.rectification.valid_left]).any()  # nor the fill
    assert res.cloud.shape == res.rectified.left.shape
    score = score_result(res.to_json_dict(), demo.truth)
    assert score.count_right and max(score.rise_errors_m) < 0.01
    assert abs(score.first_distance_error_m) < 0.03
    # The contour method reads the larger rectified image too (it finds no staircase on this
    # weakly shaded scene with any fov: only that it runs on the larger image is checked).
    res_c = Pipeline(demo.calibration, demo.rig, PipelineConfig(rectify_fov="keep", method="contour")).run(
        demo.left, demo.right
    )
    assert res_c.planes.method == "contour" and len(res_c.planes.segments) > 0


def test_keep_passes_an_already_rectified_calibration_through():
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    calib = StereoCalibration(
        K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.08, 0.0, 0.0]), (640, 480), rectified=True
    )
    rect = compute_rectification(calib, fov="keep")
    assert rect.maps is None and rect.size is None and rect.image_size == rect.raw_size == (640, 480)
    img = np.random.default_rng(1).integers(0, 255, (480, 640), dtype=np.uint8)
    assert rectify(img, img, rect).left is img


def test_valid_interior_keeps_off_the_border_and_the_valid_regions_outline():
    """3 px of the image's border and 3 px more (a 7 px erosion) inside the valid region's
    outline are left out; the caller's mask, bool or uint8, is left as it was."""
    whole = valid_interior(None, (40, 60))
    assert whole.dtype == bool and whole.shape == (40, 60)
    rows, cols = np.nonzero(whole)
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (6, 33, 6, 53)
    for dtype in (bool, np.uint8):
        valid = np.ones((40, 60), dtype=dtype)
        valid[:, 30:] = 0  # the right half has no source pixel
        before = valid.copy()
        inside = valid_interior(valid, valid.shape)
        assert np.array_equal(valid, before)
        cols = np.nonzero(inside)[1]
        assert (cols.min(), cols.max()) == (6, 26)


def test_keep_takes_no_wall_cut_by_the_views_top_edge_for_a_step():
    """An empty room of the default profile (seed 11, its 32nd draw) whose back wall's
    foot, 4.3 m ahead, only ``keep``'s larger image shows, cut by the top edge of the raw
    view: the wall's plane stops at the rows where both images' source pixels start, not at
    the image's row 0. Taken for a riser whose top was seen, it was a 12.5 cm step."""
    from stereo_terrain.pipeline import Pipeline, PipelineConfig
    from stereo_terrain.synthetic import random_scene_spec, render_scene

    rng = np.random.default_rng(11)
    for _ in range(31):
        random_scene_spec(rng, profile="default")
    spec = random_scene_spec(rng, profile="default")
    assert spec.obstacle is None and spec.back_wall_m is not None
    scene = render_scene(spec)
    pipeline = Pipeline(scene.calibration, scene.rig, PipelineConfig(rectify_fov="keep"))
    res = pipeline.run(scene.left, scene.right)
    assert res.planes.samples.source_rows is not None
    assert res.terrain.obstacle == "none", res.terrain.note
