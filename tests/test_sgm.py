"""The project's own SGM engine: accuracy on known shifts, robustness to gain, bad input."""

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import RectifiedPair
from stereo_terrain.stereo import make_backend
from stereo_terrain.stereo.sgm import SGM, SGMConfig, census5x5
from stereo_terrain.synthetic import default_scene_spec, render_scene

from .test_stereo import _shifted_pair

SUBPIXEL_TOL_PX = 0.25


@pytest.fixture(scope="module")
def shifted():
    return _shifted_pair(12.5)


def test_known_disparity(shifted):
    dm = SGM().compute(shifted, 64)
    d = dm.disparity[:, 80:]
    assert dm.backend == "sgm" and dm.density > 0.8
    assert np.nanmedian(np.abs(d - 12.5)) < SUBPIXEL_TOL_PX
    cols = np.arange(640)[None, :]
    assert not (dm.disparity > cols).any()  # never matched outside the right image
    assert not (dm.disparity == 0).any()  # invalid is NaN, never 0
    assert dm.confidence is not None and dm.confidence.shape == d.shape[:1] + (640,)


def test_census_cost_ignores_gain_and_offset(shifted):
    right = np.clip(shifted.right.astype(np.float32) * 0.8 + 20, 0, 255).astype(np.uint8)
    dm = SGM().compute(RectifiedPair(shifted.left, right, shifted.rectification), 64)
    assert np.nanmedian(np.abs(dm.disparity[:, 80:] - 12.5)) < SUBPIXEL_TOL_PX
    # A monotonic brightness change leaves the census unchanged (away from saturation).
    img = (shifted.left // 2).astype(np.uint8)
    assert np.array_equal(census5x5(img), census5x5(img + np.uint8(40)))


@pytest.mark.parametrize("paths", [4, 16])
def test_path_counts(shifted, paths):
    dm = SGM(SGMConfig(paths=paths)).compute(shifted, 32)
    assert np.nanmedian(np.abs(dm.disparity[:, 80:] - 12.5)) < SUBPIXEL_TOL_PX


def test_bad_input(shifted):
    with pytest.raises(ConfigError):
        SGMConfig(paths=6)
    with pytest.raises(ConfigError):
        SGMConfig(p1=50, p2=10)
    with pytest.raises(ConfigError):
        SGM().compute(shifted, 40)  # not a multiple of 16
    bad = RectifiedPair(shifted.left.astype(np.float32), shifted.right, shifted.rectification)
    with pytest.raises(InputError, match="uint8"):
        SGM().compute(bad, 64)
    assert make_backend("sgm").name == "sgm"


def test_rendered_staircase_through_the_pipeline():
    scene = render_scene(default_scene_spec())
    result = Pipeline(scene.calibration, scene.rig, PipelineConfig(backend="sgm")).run(
        scene.left, scene.right
    )
    data = result.to_json_dict()
    assert data["obstacle"] == "stairs" and len(data["steps"]) == 3
    for got, want in zip(data["steps"], scene.truth["steps"], strict=True):
        assert abs(got["rise"] - want["rise"]) < 0.015
        assert abs(got["distance"] - want["distance"]) < 0.03
