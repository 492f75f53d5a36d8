"""Two webcams focused apart: which image is blurrier and by how much, from the images alone,
and the sharper one blurred to match (stereo/blur.py, issue 11)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.stereo.blur import MAX_BLUR_PX, MIN_BLUR_PX, match_blur, relative_blur_px
from stereo_terrain.synthetic import random_scene_spec, render_scene

#: How far the estimate may be from the true blur difference (pixels): about the p90 error
#: on the realistic renders (docs/benchmarks.md, "Fifteenth session").
SIGMA_TOL_PX = 0.35


def _texture(seed: int, shape: tuple[int, int] = (240, 320)) -> np.ndarray:
    """A grey image with texture at every scale (noise summed over octaves)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    image = np.zeros(shape, np.float32)
    for octave in range(5):
        f = 2**octave
        small = rng.normal(0.0, 1.0, (h // f + 1, w // f + 1)).astype(np.float32)
        image += cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)[:h, :w] * f**0.5
    image = 128.0 + 40.0 * image / image.std()
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def _blurred(image: np.ndarray, sigma: float) -> np.ndarray:
    return image if sigma <= 0 else cv2.GaussianBlur(image, (0, 0), sigma)


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    sharp=st.floats(0.0, 0.6),
    extra=st.floats(0.5, 1.5),
    right_blurrier=st.booleans(),
)
def test_the_blur_difference_is_found(seed, sharp, extra, right_blurrier):
    texture = _texture(seed)
    soft = math.hypot(sharp, extra)
    left, right = _blurred(texture, sharp), _blurred(texture, soft)
    if not right_blurrier:
        left, right = right, left
    sigma = relative_blur_px(left, right)
    assert abs(abs(sigma) - extra) < SIGMA_TOL_PX
    assert (sigma > 0) == right_blurrier


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16), gain=st.floats(0.6, 1.4), offset=st.floats(-20.0, 20.0))
def test_the_estimate_ignores_the_exposure(seed, gain, offset):
    texture = _texture(seed)
    right = _blurred(texture, 1.0)
    brighter = np.clip(np.rint(right * gain + offset), 0, 255).astype(np.uint8)
    assert abs(relative_blur_px(texture, brighter) - relative_blur_px(texture, right)) < 0.1


def test_equal_focus_is_left_alone():
    texture = _texture(3)
    noisy = np.clip(texture + np.random.default_rng(4).normal(0, 2.0, texture.shape), 0, 255).astype(np.uint8)
    assert abs(relative_blur_px(texture, noisy)) < MIN_BLUR_PX
    left, right, _ = match_blur(texture, noisy)
    assert left is texture and right is noisy


def test_match_blur_blurs_the_sharper_image_only():
    texture = _texture(5)
    soft = _blurred(texture, 1.2)
    left, right, sigma = match_blur(texture, soft)
    assert right is soft and left is not texture
    assert abs(sigma - 1.2) < SIGMA_TOL_PX
    # Alike afterwards: what is left is the estimate's error, in quadrature
    # (sqrt(1.2**2 - 1.1**2) = 0.48 for an estimate 0.1 px short).
    assert abs(relative_blur_px(left, right)) < 0.5
    left, right, sigma = match_blur(soft, texture)
    assert left is soft and right is not texture and sigma < 0


def test_only_pixels_valid_in_both_images_count():
    texture = _texture(6)
    soft = _blurred(texture, 1.0)
    valid = np.ones(texture.shape, bool)
    valid[:, :120] = False
    left, right = texture.copy(), soft.copy()
    left[:, :120] = 0  # a black border where the rectified view has no source ...
    right[:, :120] = np.random.default_rng(7).integers(0, 256, (texture.shape[0], 120))  # ... or junk
    assert abs(relative_blur_px(left, right, valid, valid) - relative_blur_px(texture, soft)) < 0.1


@pytest.mark.parametrize("case", ["flat", "no common pixels", "not a blur"])
def test_nothing_to_measure_gives_zero(case):
    texture = _texture(8)
    if case == "flat":
        assert relative_blur_px(texture, np.full_like(texture, 100)) == 0.0
    elif case == "no common pixels":
        a = np.zeros(texture.shape, bool)
        a[:, :160] = True
        assert relative_blur_px(texture, texture, a, ~a) == 0.0
    else:  # more than MAX_BLUR_PX apart: no focus difference a Gaussian explains
        assert relative_blur_px(texture, _blurred(texture, 3.0 * MAX_BLUR_PX)) == 0.0


def test_rendered_webcams_focused_apart():
    """A realistic render whose right camera is a pixel blurrier than its left one (the
    renderer blurs each raw image; rectification resamples them)."""
    rng = np.random.default_rng(12)
    blurs = {"blur_sigma_px": 0.5, "right_blur_sigma_px": 1.3}
    spec = random_scene_spec(rng, profile="realistic", kind="stairs", **blurs)
    scene = render_scene(spec)
    sigma = relative_blur_px(scene.left, scene.right)
    assert abs(sigma - math.sqrt(1.3**2 - 0.5**2)) < SIGMA_TOL_PX


def test_a_floor_on_the_difference_reads_below_it_as_zero():
    texture = _texture(10)
    slight, clear = _blurred(texture, 0.15), _blurred(texture, 1.0)
    assert relative_blur_px(texture, slight, at_least_px=MIN_BLUR_PX) == 0.0
    full = relative_blur_px(texture, clear)
    assert abs(relative_blur_px(texture, clear, at_least_px=MIN_BLUR_PX) - full) < 0.05
    assert abs(relative_blur_px(clear, texture, at_least_px=MIN_BLUR_PX) + full) < 0.05
