"""Streak invalidation and row fill of the planar fill (stereo/fill.py)."""

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.stereo.fill import PlanarFillConfig, fill_planar_regions, fill_rows, ill_posed_mask

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
    ],
)
def test_bad_config_raises(kw):
    with pytest.raises(ConfigError):
        PlanarFillConfig(**kw)
