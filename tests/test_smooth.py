"""Local-plane smoothing of disparities (stereo/smooth.py, issue 11)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.stereo.sgm import SGM, SGMConfig
from stereo_terrain.stereo.smooth import smooth_planar

from .test_stereo import _shifted_pair

# A plane through whole-pixel terraces, recovered to a seventh of a pixel (median over the
# window's pixels) and a third at worst: where the terraces' period (1 / slope rows) does
# not divide the 11-pixel window, the fit keeps a phase-dependent bias (measured on a grid
# of slopes: median up to 0.13 px, worst pixel 0.21 px, at 0.25 px a row).
PLANE_MEDIAN_TOL_PX = 0.15
PLANE_MAX_TOL_PX = 0.3


def _plane(a: float, b: float, c: float, shape=(60, 80)) -> np.ndarray:
    y, x = np.mgrid[0 : shape[0], 0 : shape[1]]
    return (a * x + b * y + c).astype(np.float32)


@settings(max_examples=40, deadline=None)
@given(
    st.floats(-0.3, 0.3), st.floats(0.12, 0.3), st.sampled_from([-1, 1]), st.floats(5.0, 60.0),
    st.integers(0, 2**31 - 1),
)  # fmt: skip
def test_terraces_of_a_slanted_plane_become_the_plane(a, b, sign, c, seed):
    """A tread seen from a level camera: disparity changing by 0.12-0.3 px a row (a
    fronto-parallel plane's terraces, if any, carry no information on its fraction)."""
    truth = _plane(a, sign * b, c)
    rounded = np.floor(truth + 0.5)  # to the nearest pixel, halves up (np.round's halves
    # to even would bias a plane whose values step by exactly a quarter of a pixel)
    rounded[np.random.default_rng(seed).random(truth.shape) < 0.3] = np.nan  # holes
    out = smooth_planar(rounded, 5)
    inner = (slice(5, -5), slice(5, -5))
    good = np.isfinite(out[inner])
    assert good.mean() > 0.6
    assert np.nanmax(np.abs(out[inner] - truth[inner])) < PLANE_MAX_TOL_PX
    assert np.median(np.abs(out[inner][good] - truth[inner][good])) < PLANE_MEDIAN_TOL_PX
    assert not (np.isfinite(out) & ~np.isfinite(rounded)).any()  # never fills a hole


def test_outliers_and_step_edges_are_dropped_not_blended():
    d = _plane(0.0, 0.1, 20.0)
    d[:, 40:] += 8.0  # a step edge at x = 40
    d[30, 20] = 5.0  # an outlier
    out = smooth_planar(d, 4)
    assert np.isnan(out[30, 20])
    # Next to the edge the window's plane is a blend of both sides: those pixels go.
    assert np.isnan(out[10:50, 39:41]).all()
    # A plane is left as it is, away from the edge and from the outlier (the least-squares
    # plane is not robust: within the radius of the outlier it moves by a fraction of it).
    away = (slice(40, 55), slice(5, 30))
    assert np.nanmax(np.abs(out[away] - d[away])) < 1e-3


def test_bad_input():
    d = np.zeros((10, 10), np.float32)
    for radius in (0, -1, 2.5, True):
        with pytest.raises(InputError, match="radius_px"):
            smooth_planar(d, radius)
    with pytest.raises(InputError, match="shape"):
        smooth_planar(np.zeros(10, np.float32), 2)
    with pytest.raises(InputError, match="tol_px"):
        smooth_planar(d, 2, tol_px=0.0)
    with pytest.raises(ConfigError, match="plane_smooth_radius_px"):
        SGMConfig(plane_smooth_radius_px=-1)


def test_sgm_option_keeps_a_known_disparity():
    pair = _shifted_pair(12.5)
    dm = SGM(SGMConfig(plane_smooth_radius_px=4)).compute(pair, 32)
    assert dm.density > 0.7
    assert np.nanmedian(np.abs(dm.disparity[:, 80:] - 12.5)) < PLANE_MEDIAN_TOL_PX
