import numpy as np
import pytest

from stereo_terrain.calibration import StereoCalibration, read_calibration
from stereo_terrain.errors import InputError
from stereo_terrain.rectify import compute_rectification, read_image, rectify, to_grey


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
