"""Near-vertical edges from the grey levels (terrain/nosings/plumb.py, TerrainConfig.plumb_edges)."""

import dataclasses
import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.terrain import STAIRS
from stereo_terrain.terrain.nosings.plumb import plumb_segments

from .test_line_frame import _realistic

H, W = 240, 320


def _edge_image(x_top: float, y0: int, y1: int, tilt_deg: float, step: float, noise: float, seed: int = 0):
    """A flat grey image with a blurred step of ``step`` grey levels from row ``y0`` to
    ``y1``, its left side brighter, leaning ``tilt_deg`` from vertical; webcam noise."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    x_edge = x_top + (yy - y0) * math.tan(math.radians(tilt_deg))
    across = np.clip((xx - x_edge) / 2.0, -1.0, 1.0)  # a 4-px ramp, as a webcam's blur
    rows = (yy >= y0) & (yy <= y1)
    image = 110.0 + np.where(rows, -0.5 * step * across, 0.0)
    return np.clip(image + rng.normal(0.0, noise, image.shape), 0, 255).astype(np.uint8)


def test_a_faint_edge_under_noise_is_found_where_it_is():
    """A 12-level step under noise of 3 levels a pixel, 40 rows tall (a painted riser's
    end against a wall of nearly its grey): one line, on the edge, about its length."""
    image = _edge_image(150.0, 80, 119, 0.0, 12.0, 3.0)
    found = plumb_segments(image)
    near = found[np.abs(0.5 * (found[:, 0] + found[:, 2]) - 150.0) < 2.0]
    assert len(near) == 1
    x1, y1, x2, y2 = near[0]
    assert y1 < y2  # the top end first
    assert y1 == pytest.approx(80, abs=4) and y2 == pytest.approx(119, abs=4)
    assert x1 == pytest.approx(150.0, abs=1.0) and x2 == pytest.approx(150.0, abs=1.0)


def test_noise_alone_makes_no_lines():
    rng = np.random.default_rng(3)
    image = np.clip(110 + rng.normal(0, 3.0, (H, W)), 0, 255).astype(np.uint8)
    assert len(plumb_segments(image)) == 0


def test_a_textured_face_is_noise_to_it():
    """Speckled paint or carpet lines its grains up in near-vertical streaks; the noise
    around them (the vertical gradient's) is theirs, so none stands out, while a faint
    edge between flat greys beside it still does."""
    image = _edge_image(80.0, 60, 180, 0.0, 12.0, 3.0).astype(np.float64)
    rng = np.random.default_rng(5)
    speckle = cv2.GaussianBlur(rng.uniform(60.0, 160.0, (H, W)), (0, 0), 1.0)
    image[:, 160:] = speckle[:, 160:]
    found = plumb_segments(np.clip(image, 0, 255).astype(np.uint8))
    mid = 0.5 * (found[:, 0] + found[:, 2])
    assert np.any(np.abs(mid - 80.0) < 2.0)
    assert not np.any(mid > 175.0)


def test_lines_leaning_too_far_or_too_short_are_left_out():
    leaning = _edge_image(120.0, 60, 180, 20.0, 40.0, 1.0)
    assert len(plumb_segments(leaning)) == 0
    short = _edge_image(150.0, 100, 108, 0.0, 40.0, 1.0)
    assert len(plumb_segments(short)) == 0
    assert len(plumb_segments(short, min_length_px=5.0)) == 1


def test_the_valid_regions_outline_is_no_edge():
    """A rectified image's black surround ends in a straight edge of the image, not of the
    scene: no line along it, the scene's edge inside still found."""
    image = _edge_image(200.0, 60, 180, 0.0, 30.0, 1.0)
    valid = np.ones((H, W), dtype=bool)
    valid[:, :60] = False
    image[~valid] = 0
    found = plumb_segments(image, valid)
    mid = 0.5 * (found[:, 0] + found[:, 2])
    assert not np.any(mid < 70)
    assert np.any(np.abs(mid - 200.0) < 2.0)
    unmasked = plumb_segments(image)
    assert np.any(0.5 * (unmasked[:, 0] + unmasked[:, 2]) < 70)  # without the mask it is


@settings(max_examples=40, deadline=None)
@given(
    x=st.floats(40.0, 280.0),
    y0=st.integers(10, 120),
    length=st.integers(20, 100),
    tilt=st.floats(-8.0, 8.0),
    step=st.floats(10.0, 60.0),
    seed=st.integers(0, 1000),
)
def test_an_edge_is_found_along_its_length_and_lean(x, y0, length, tilt, step, seed):
    y1 = min(y0 + length, H - 12)
    image = _edge_image(x, y0, y1, tilt, step, 2.0, seed)
    found = plumb_segments(image)
    x_mid = x + 0.5 * (y1 - y0) * math.tan(math.radians(tilt))
    on = found[np.abs(0.5 * (found[:, 0] + found[:, 2]) - x_mid) < 2.5]
    assert len(on) >= 1
    best = on[np.argmax(on[:, 3] - on[:, 1])]
    assert best[3] - best[1] >= 0.7 * (y1 - y0)
    lean = math.degrees(math.atan2(best[2] - best[0], best[3] - best[1]))
    # its lean to a degree and a half, and the angle a pixel and a half over its length makes
    assert lean == pytest.approx(tilt, abs=1.5 + math.degrees(math.atan(1.5 / (y1 - y0))))


def test_a_painted_staircases_faint_ends_count_its_steps():
    """Realistic render 44 of seed 57 with its rig (five white steps of 21.2 cm against a
    grey wall, a post hiding their left ends): LSD finds the right ends of two risers in
    pieces and the chain stops at two steps; the grey levels show the others' and the
    staircase counts five, each riser within 10 cm of its place (the fifth, inferred a run
    beyond the fourth, 8.6 cm short)."""
    scene = _realistic(44, seed=57)
    truth = scene.truth["steps"]
    assert len(truth) == 5
    config = PipelineConfig()
    result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == STAIRS
    assert [s.distance_m for s in result.terrain.steps] == pytest.approx(
        [s["distance"] for s in truth], abs=0.10
    )
    off = dataclasses.replace(config, terrain=dataclasses.replace(config.terrain, plumb_edges=False))
    before = Pipeline(scene.calibration, scene.rig, off, warm_up=False).run(scene.left, scene.right)
    assert len(before.terrain.steps) == 2
