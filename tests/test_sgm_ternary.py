"""The SGM engine's ternary census (``SGMConfig.census_epsilon_grey``, issue 11)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from stereo_terrain.errors import ConfigError
from stereo_terrain.rectify import RectifiedPair
from stereo_terrain.stereo.sgm import SGM, SGMConfig, census5x5, census_cost, census_ternary

from .test_stereo import _shifted_pair

SUBPIXEL_TOL_PX = 0.25


def _reference_codes(img: np.ndarray, eps: int) -> np.ndarray:
    """(H, W, 24) int8: -1 darker than the centre by more than eps, +1 brighter, 0 else
    (outside the image: 0), in the engine's neighbour order (rows, then columns)."""
    h, w = img.shape
    pad = np.pad(img.astype(np.int32), 2, mode="constant")
    inside = np.pad(np.ones((h, w), bool), 2, mode="constant")
    c = img.astype(np.int32)
    codes = []
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            if dy == 0 and dx == 0:
                continue
            v = pad[2 + dy : 2 + dy + h, 2 + dx : 2 + dx + w]
            ok = inside[2 + dy : 2 + dy + h, 2 + dx : 2 + dx + w]
            codes.append(np.where(ok & (v < c - eps), -1, np.where(ok & (v > c + eps), 1, 0)))
    return np.stack(codes, -1).astype(np.int8)


@settings(max_examples=25, deadline=None)
@given(
    arrays(np.uint8, st.tuples(st.integers(5, 12), st.integers(5, 12))),
    arrays(np.uint8, st.tuples(st.integers(5, 12), st.integers(5, 12))),
    st.integers(1, 40),
)
def test_ternary_cost_counts_neighbours_whose_codes_differ(a, b, eps):
    h, w = min(a.shape[0], b.shape[0]), min(a.shape[1], b.shape[1])
    a, b = np.ascontiguousarray(a[:h, :w]), np.ascontiguousarray(b[:h, :w])
    ra, rb = _reference_codes(a, eps), _reference_codes(b, eps)
    n = min(4, w)
    cost = census_cost(census_ternary(a, eps), census_ternary(b, eps), n).astype(int)
    for d in range(n):
        expected = np.full((h, w), 24)
        expected[:, d:] = np.sum(ra[:, d:] != rb[:, : w - d], axis=-1)
        assert np.array_equal(cost[:, :, d], expected)


def test_noise_below_the_threshold_gives_flat_costs():
    rng = np.random.default_rng(3)
    left = (120 + rng.integers(-2, 3, (40, 60))).astype(np.uint8)
    right = (120 + rng.integers(-2, 3, (40, 60))).astype(np.uint8)
    flat = census_cost(census_ternary(left, 4), census_ternary(right, 4), 16)
    assert not flat[:, 16:].any()  # every disparity costs 0: nothing to choose on noise
    plain = census_cost(census5x5(left), census5x5(right), 16)
    assert plain[:, 16:].mean() > 5  # the plain census follows the noise


def test_known_disparity_and_offset_invariance():
    pair = _shifted_pair(12.5)
    config = SGMConfig(census_epsilon_grey=4)
    dm = SGM(config).compute(pair, 64)
    assert dm.density > 0.8
    assert np.nanmedian(np.abs(dm.disparity[:, 80:] - 12.5)) < SUBPIXEL_TOL_PX
    brighter = np.clip(pair.right.astype(np.int16) + 25, 0, 255).astype(np.uint8)
    shifted = SGM(config).compute(RectifiedPair(pair.left, brighter, pair.rectification), 64)
    assert np.nanmedian(np.abs(shifted.disparity[:, 80:] - 12.5)) < SUBPIXEL_TOL_PX


def test_uniform_face_takes_its_outline_disparity():
    """A noisy face of uniform grey between textured borders: the plain census's costs
    follow the noise there; the ternary census's are flat, and SGM carries the borders'
    disparity across."""
    rng = np.random.default_rng(5)
    h, w, d_true = 60, 200, 9
    texture = rng.integers(0, 255, (h, w + d_true)).astype(np.uint8)
    left, right = texture[:, :w].copy(), texture[:, d_true:].copy()  # right(x - d) = left(x)
    left[:, 60:150] = (128 + rng.integers(-2, 3, (h, 90))).astype(np.uint8)  # the face, with
    right[:, 60 - d_true : 150 - d_true] = (128 + rng.integers(-2, 3, (h, 90))).astype(np.uint8)  # own noise
    pair = RectifiedPair(left, right, _shifted_pair(0.0).rectification)
    face = (slice(5, h - 5), slice(70, 140))
    config = SGMConfig(
        census_epsilon_grey=4, uniqueness_ratio_pct=0, speckle_window_px=0, lr_max_diff_px=1000.0
    )
    ternary = SGM(config).compute(pair, 32).disparity[face]
    plain = SGM(SGMConfig(uniqueness_ratio_pct=0, speckle_window_px=0, lr_max_diff_px=1000.0)).compute(
        pair, 32
    )
    assert np.mean(np.abs(ternary - d_true) <= 1.0) > 0.9
    assert np.mean(np.abs(plain.disparity[face] - d_true) <= 1.0) < 0.8


def test_config_checks():
    for bad in (-1, 65):
        with pytest.raises(ConfigError, match="census_epsilon_grey"):
            SGMConfig(census_epsilon_grey=bad)
    with pytest.raises(ConfigError, match="CPU only"):
        SGMConfig(census_epsilon_grey=4, device="cuda")
