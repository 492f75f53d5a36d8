"""The right image's exposure mapped onto the left's before matching (issue 11: webcams
expose on their own; wood grain is too weak a texture to survive a 20 % gain)."""

import dataclasses

import numpy as np
import pytest

from stereo_terrain.stereo.opencv import OpenCVSGBM, OpenCVSGBMConfig, match_exposure

from .test_stereo import _shifted_pair

#: Grey levels the matched right image may differ from the left one's exposure by.
GREY_TOL = 1.5


def test_match_exposure_undoes_gain_and_offset() -> None:
    pair = _shifted_pair(0.0)
    darker = np.clip(np.rint(pair.left * 0.8 - 10.0), 0, 255).astype(np.uint8)
    back = match_exposure(pair.left, darker)
    assert back.dtype == np.uint8 and back.shape == darker.shape
    inside = (pair.left > 20) & (pair.left < 235)  # not clipped by the darkening
    assert np.median(np.abs(back[inside].astype(float) - pair.left[inside])) <= GREY_TOL
    assert match_exposure(pair.left, pair.left) is not pair.left  # a new array ...
    assert np.array_equal(match_exposure(pair.left, pair.left), pair.left)  # ... the same image


def test_match_exposure_counts_only_pixels_with_a_source() -> None:
    pair = _shifted_pair(0.0)
    right = pair.left.copy()
    right[:, :100] = 0  # black border of a rectification that keeps the whole view
    valid = np.ones(right.shape, bool)
    valid[:, :100] = False
    back = match_exposure(pair.left, right, valid, valid)
    assert np.abs(back[:, 100:].astype(float) - pair.left[:, 100:]).max() <= GREY_TOL


def test_flat_image_is_left_alone() -> None:
    pair = _shifted_pair(0.0)
    flat = np.full_like(pair.left, 90)
    assert match_exposure(pair.left, flat) is flat


@pytest.mark.parametrize("gain, offset", [(1.25, -12.0), (0.8, 12.0)])
def test_matching_with_another_exposure(gain: float, offset: float) -> None:
    pair = _shifted_pair(12.5)
    right = np.clip(np.rint(pair.right * gain + offset), 0, 255).astype(np.uint8)
    pair = dataclasses.replace(pair, right=right)
    d = OpenCVSGBM(OpenCVSGBMConfig(match_exposure=True)).compute(pair, 64).disparity[:, 80:]
    assert np.mean(np.abs(d - 12.5) <= 1.0) > 0.8


def test_penalties_scale_with_the_width() -> None:
    from stereo_terrain.errors import ConfigError
    from stereo_terrain.stereo.opencv import create_sgbm

    config = OpenCVSGBMConfig(p1_per_px=24, p2_per_px=200, penalty_width_px=640)
    half = create_sgbm(config, 64, width=320)
    assert (half.getP1(), half.getP2()) == (12 * 25, 100 * 25)
    full = create_sgbm(config, 64, width=640)
    assert (full.getP1(), full.getP2()) == (24 * 25, 200 * 25)
    unscaled = create_sgbm(OpenCVSGBMConfig(), 64, width=320)  # penalty_width_px 0: as given
    assert (unscaled.getP1(), unscaled.getP2()) == (8 * 25, 32 * 25)
    with pytest.raises(ConfigError):
        OpenCVSGBMConfig(penalty_width_px=-1)
