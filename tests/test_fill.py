"""Streak invalidation and row fill of the planar fill (stereo/fill.py)."""

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.stereo.fill import (
    PlanarFillConfig,
    fill_planar_regions,
    fill_rows,
    find_flat_regions,
    ill_posed_mask,
)

TOL_PX = 1e-4


def _grain(shape, rng):
    """Horizontal wood-like grain: rows of random brightness, nothing along rows."""
    rows = rng.integers(60, 200, (shape[0], 1))
    return np.repeat(rows, shape[1], axis=1).astype(np.uint8)


def test_horizontal_grain_is_ill_posed_and_random_texture_is_not():
    rng = np.random.default_rng(0)
    cfg = PlanarFillConfig()
    assert ill_posed_mask(_grain((120, 160), rng), cfg)[20:-20, 20:-20].all()
    assert ill_posed_mask(np.full((120, 160), 128, np.uint8), cfg).all()  # paint
    texture = rng.integers(0, 255, (120, 160)).astype(np.uint8)
    assert not ill_posed_mask(texture, cfg)[20:-20, 20:-20].any()
    vertical = _grain((160, 120), rng).T.copy()  # vertical stripes: matchable along rows
    assert not ill_posed_mask(vertical, cfg)[20:-20, 20:-20].any()
    # Pure grain has no |dI/dx| at all: the mean-gradient test alone catches it.
    assert ill_posed_mask(_grain((120, 160), rng), PlanarFillConfig(orientation_ratio=0.0))[
        20:-20, 20:-20
    ].all()


def test_valid_mask_limits_ill_posed_pixels():
    img = np.full((50, 60), 100, np.uint8)
    valid = np.zeros((50, 60), bool)
    valid[10:40, 10:50] = True
    assert np.array_equal(ill_posed_mask(img, PlanarFillConfig(), valid), valid)


def test_fill_rows_is_exact_on_a_plane_and_stops_at_depth_edges_and_long_gaps():
    true = np.fromfunction(lambda v, u: 20.0 + 0.03 * u + 0.01 * v, (40, 200)).astype(np.float32)
    disp = true.copy()
    holes = np.zeros(true.shape, bool)
    holes[:, 50:150] = True
    disp[holes] = np.nan
    out, mask = fill_rows(disp, holes, max_gap_px=200, max_step_px=4.0)
    assert mask[holes].all() and not mask[~holes].any()
    assert np.max(np.abs(out[holes] - true[holes])) < TOL_PX
    # Too long a gap: left NaN.
    _, mask = fill_rows(disp, holes, max_gap_px=50, max_step_px=4.0)
    assert not mask.any()
    # A depth edge (the anchors differ by more than max_step_px): no ramp across it.
    jump = disp.copy()
    jump[:, 150:] += 10.0
    out, mask = fill_rows(jump, holes, max_gap_px=200, max_step_px=4.0)
    assert not mask.any() and np.isnan(out[holes]).all()
    # No anchor on one side (the face runs off the image): not filled.
    open_right = disp.copy()
    open_right[:, 50:] = np.nan
    _, mask = fill_rows(open_right, np.isnan(open_right), max_gap_px=500, max_step_px=4.0)
    assert not mask.any()


def test_invalidate_turns_streaks_on_grain_into_nan_or_the_row_plane():
    rng = np.random.default_rng(3)
    left = rng.integers(0, 255, (120, 200)).astype(np.uint8)
    left[30:90, 40:160] = _grain((60, 120), rng)
    true = np.fromfunction(lambda v, u: 25.0 + 0.01 * u, (120, 200)).astype(np.float32)
    disp = true.copy()
    # Confident garbage on the grain; the face's ends (next to the texture) match right.
    disp[30:90, 50:150] = rng.uniform(5, 60, (60, 100))
    core = (slice(40, 80), slice(55, 145))
    off, _ = fill_planar_regions(disp, left)
    assert np.array_equal(off, disp)  # default: untouched (grain is not flat)
    nan, _ = fill_planar_regions(disp, left, PlanarFillConfig(invalidate=True))
    assert np.isnan(nan[core]).all()
    assert np.array_equal(nan[:20], disp[:20])  # texture untouched
    rows, mask = fill_planar_regions(disp, left, PlanarFillConfig(invalidate=True, row_fill_max_gap_px=200))
    assert mask[core].all()
    assert np.max(np.abs(rows[core] - true[core])) < 0.05


@pytest.mark.parametrize(
    "kw",
    [
        {"texture": "vertical"},
        {"horizontal_texture": 0.0},
        {"texture_window_px": 1},
        {"split_sigma_x_px": 0.0},
        {"orientation_ratio": -0.1},
        {"row_fill_max_gap_px": -1},
        {"row_fill_max_step_px": -1.0},
        {"invalidate": 1},
        {"edge_low_sigmas": 0.0},
        {"edge_low_sigmas": 5.0, "edge_high_sigmas": 4.0},
    ],
)
def test_bad_config_raises(kw):
    with pytest.raises(ConfigError):
        PlanarFillConfig(**kw)


def _painted_face(rng, noise_grey=2.0, shading_grey_per_px=0.3):
    """A near-uniform painted face (grey 150) on a darker one (grey 90), both lit unevenly
    (brightness falling along rows by ``shading_grey_per_px``: light fall-off, vignetting)
    and with sensor noise of ``noise_grey``: the face is rows 30-90, columns 40-200 of a
    120 x 240 image."""
    img = np.full((120, 240), 90.0)
    img[30:90, 40:200] = 150.0
    img += 60.0 - shading_grey_per_px * np.arange(240)[None, :]
    img += rng.normal(0.0, noise_grey, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def test_edges_mode_keeps_a_noisy_painted_face_one_region():
    """Uneven light and noise break a low-gradient test into crumbs; the face's outline
    does not move: the ``edges`` regions hold the whole face in one label."""
    img = _painted_face(np.random.default_rng(1))
    inner = (slice(36, 84), slice(46, 194))
    regions = find_flat_regions(img, PlanarFillConfig(texture="edges"))
    labels = regions.labels[inner]
    main = np.bincount(labels[labels > 0].ravel()).argmax()
    assert np.mean(labels == main) > 0.95
    # The background is another region: the face's outline separates them.
    assert regions.labels[10, 10] not in (0, main)


def test_edges_mode_fills_a_painted_face_from_its_outline():
    """Disparities only on the face's vertical ends (as a matcher gives them); inside, a
    streak of wrong values. The ``edges`` fill gives the whole face the ends' plane."""
    img = _painted_face(np.random.default_rng(2))
    true = np.fromfunction(lambda v, u: 30.0 + 0.02 * u - 0.01 * v, img.shape).astype(np.float32)
    disp = np.full(img.shape, np.nan, np.float32)
    for cols in (slice(36, 44), slice(196, 204)):  # the face's two vertical ends
        disp[30:90, cols] = true[30:90, cols]
    disp[50:55, 60:180] = 12.0  # a confident streak inside the face
    out, filled = fill_planar_regions(disp, img, PlanarFillConfig(texture="edges"), max_disparity_px=64)
    # The face away from its outline (the texture window's half-width and more) is the
    # texture-poor part that the plane fills; the outline keeps the matcher's values.
    face = (slice(40, 80), slice(50, 190))
    assert filled[face].mean() > 0.99
    assert np.max(np.abs(out[filled] - true[filled])) < 0.05
    assert np.array_equal(out[~filled], disp[~filled], equal_nan=True)
