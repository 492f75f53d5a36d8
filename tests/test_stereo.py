import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.rectify import RectifiedPair, compute_rectification
from stereo_terrain.stereo import choose_max_disparity, make_backend
from stereo_terrain.stereo.fill import PlanarFillConfig, fill_planar_regions
from stereo_terrain.stereo.opencv import OpenCVSGBMConfig

from .analytic import rectified_calibration

SUBPIXEL_TOL_PX = 0.25


def _shifted_pair(shift_px=12.5, seed=0):
    """A random texture and the same texture shifted left by ``shift_px`` (known disparity)."""
    import cv2

    rng = np.random.default_rng(seed)
    big = cv2.GaussianBlur(rng.uniform(0, 255, (480, 800)).astype(np.float32), (0, 0), 1.2)
    x = np.arange(640, dtype=np.float32)
    mx, my = np.meshgrid(x + 40, np.arange(480, dtype=np.float32))
    left = cv2.remap(big, mx, my, cv2.INTER_CUBIC)
    right = cv2.remap(big, mx + np.float32(shift_px), my, cv2.INTER_CUBIC)
    rect = compute_rectification(rectified_calibration())
    to8 = lambda a: np.clip(a, 0, 255).astype(np.uint8)  # noqa: E731
    return RectifiedPair(to8(left), to8(right), rect)


def test_opencv_backend_recovers_known_disparity():
    pair = _shifted_pair(12.5)
    dm = make_backend("opencv").compute(pair, 64)
    d = dm.disparity[:, 80:]
    assert dm.disparity.dtype == np.float32 and dm.density > 0.8
    assert np.nanmedian(np.abs(d - 12.5)) < SUBPIXEL_TOL_PX
    assert np.isnan(dm.disparity[:, :60]).all()  # no match possible: NaN, never 0
    assert not (dm.disparity == 0).any()


def test_a_blank_pair_has_no_density():
    """A covered lens or a dead camera: OpenCV's SGBM says disparity 0 (at infinity) almost
    everywhere; the density (published in every terrain message) must not read as a good
    frame's."""
    blank = _shifted_pair(12.5)
    blank = RectifiedPair(np.zeros_like(blank.left), np.zeros_like(blank.right), blank.rectification)
    assert make_backend("opencv").compute(blank, 64).density < 0.05
    assert make_backend("opencv").compute(_shifted_pair(12.5), 64).density > 0.8


def test_bad_backend_arguments():
    pair = _shifted_pair()
    backend = make_backend("opencv")
    for bad in (50, 0, -16, 640):
        with pytest.raises(ConfigError):
            backend.compute(pair, bad)
    with pytest.raises(ConfigError):
        make_backend("nope")
    with pytest.raises(ConfigError):
        OpenCVSGBMConfig(block_size_px=4)
    with pytest.raises(ConfigError):
        OpenCVSGBMConfig(p1_per_px=40, p2_per_px=8)


def test_choose_max_disparity():
    rect = compute_rectification(rectified_calibration())  # f 500 px, B 0.08 m
    assert choose_max_disparity(rect, 0.7) == 64
    assert choose_max_disparity(rect, 0.3) == 144
    with pytest.raises(ConfigError):
        choose_max_disparity(rect, 0.0)


def test_planar_fill_recovers_a_textureless_face_from_its_side_edges():
    """A flat grey rectangle on a textured background: inside, the matcher has nothing;
    its vertical edges carry the disparity, and the fill puts the plane back."""
    rng = np.random.default_rng(1)
    left = rng.integers(0, 255, (200, 300)).astype(np.uint8)
    left[60:140, 80:240] = 120
    true = np.fromfunction(lambda v, u: 20.0 + 0.02 * u + 0.01 * v, (200, 300)).astype(np.float32)
    disp = true.copy()
    inside = np.zeros_like(disp, bool)
    inside[63:137, 83:237] = True
    disp[inside] = np.where(rng.random(inside.sum()) < 0.5, np.nan, 35.0)  # holes and a wrong ramp
    filled, mask = fill_planar_regions(disp, left, PlanarFillConfig(min_region_fraction=0.01))
    core = np.zeros_like(inside)
    core[68:132, 88:232] = True  # the face less the blurred edge band
    assert mask[core].all()
    assert np.max(np.abs(filled[mask] - true[mask])) < 0.2


def test_planar_fill_leaves_texture_and_disagreement_alone():
    rng = np.random.default_rng(2)
    left = rng.integers(0, 255, (200, 300)).astype(np.uint8)
    disp = np.full((200, 300), 20.0, np.float32)
    filled, mask = fill_planar_regions(disp, left)
    assert not mask.any() and np.array_equal(filled, disp)
    # A flat face whose edges disagree (random disparities): left alone.
    left[60:140, 80:240] = 120
    disp = rng.uniform(5, 60, (200, 300)).astype(np.float32)
    _, mask = fill_planar_regions(disp, left, PlanarFillConfig(min_region_fraction=0.01))
    assert not mask.any()
    assert not fill_planar_regions(disp, left, PlanarFillConfig(enabled=False))[1].any()
