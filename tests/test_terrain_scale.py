"""The staircase of the full-size image's lines where a frame with a rig found nothing
(``VerticalLinesConfig.finer_scale``, issue 11): a rig's frame finds its lines at half
size, where a staircase 2-4 m ahead loses its nosings and risers' ends."""

import dataclasses

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.evaluation import score_result
from stereo_terrain.gravity import SceneLines, VerticalLinesConfig, scene_lines, scene_segments
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.pipeline.second_opinions import staircase_of_finer_lines
from stereo_terrain.synthetic import oakd_overrides, random_scene_spec, render_scene

from .rounding import premise
from .test_vanishing import _bar_image, _rectification

UP = np.array([0.0, -1.0, 0.0])  # a level camera's up, rectified camera frame
BARS = [(150, 200, 500, 230), (100, 250, 100, 400), (300, 300, 300, 318), (40, 100, 640, 110)]

# benchmarks/bench_far_stairs.py --oakd's draws (seed 77): scene 5 is a wooden staircase
# of four 13.3 cm risers whose first riser is 3.03 m ahead, seen by an OAK-D-like sensor.
FAR_SEED, FAR_INDEX = 77, 5
RISE_TOL_M = 0.015


def test_scene_segments_sorts_one_pass_as_the_frames_lines_do():
    img = _bar_image(BARS)
    config = VerticalLinesConfig()
    without_rig = scene_lines(img, _rectification(), config)  # at detect_scale
    assert without_rig.scale == config.detect_scale == config.finer_scale
    alone = scene_segments(img, _rectification(), config, config.detect_scale)
    assert alone.scale == config.detect_scale and alone.up is None and alone.horizontal is None
    for name in ("segments", "at_border", "short"):
        assert np.array_equal(getattr(alone, name), getattr(without_rig, name))
    assert len(alone.segments) and len(alone.at_border) and len(alone.short)
    with_rig = scene_lines(img, _rectification(), config, known_up=UP)
    assert with_rig.scale == config.horizontal_scale < config.finer_scale
    half = scene_segments(img, _rectification(), config, config.horizontal_scale)
    assert np.array_equal(half.segments, with_rig.segments)
    nothing = scene_lines(img, _rectification(), config, known_up=UP, want_horizontal=False)
    assert nothing.scale is None and len(nothing.segments) == 0


def test_finer_scale_is_checked():
    for bad in (0.0, -0.5, 1.5):
        with pytest.raises(ConfigError, match="finer_scale"):
            VerticalLinesConfig(finer_scale=bad)


def _oakd_staircase():
    """The draws of ``bench_far_stairs.py --oakd`` up to scene ``FAR_INDEX``."""
    rng = np.random.default_rng(FAR_SEED)
    for _ in range(FAR_INDEX + 1):
        distance = float(rng.uniform(2.0, 4.0))
        sensor = oakd_overrides(rng)
        spec = random_scene_spec(
            rng, profile="realistic", kind="stairs", distance_m=distance, baseline_m=0.075, **sensor
        )
    return render_scene(spec)


def test_a_staircase_three_metres_ahead_is_found_in_the_full_size_lines():
    """With a rig the frame's half-size lines find nothing there; the full-size image's
    lines find every step at its rise."""
    scene = _oakd_staircase()
    truth = scene.truth["steps"]
    assert len(truth) == 4 and 2.9 < truth[0]["distance"] < 3.1
    config = PipelineConfig()
    found = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    score = score_result(found.to_json_dict(), scene.truth)
    assert score.count_right, found.terrain.note
    assert max(score.rise_errors_m) <= RISE_TOL_M
    premise("finer_scale" in found.terrain.note, "every opinion before the full-size lines misses the stairs")
    assert "finer_lines" in found.timing_ms

    off = dataclasses.replace(config.vanishing, finer_scale=config.vanishing.horizontal_scale)
    pipe = Pipeline(scene.calibration, scene.rig, dataclasses.replace(config, vanishing=off), warm_up=False)
    before = pipe.run(scene.left, scene.right)
    assert before.terrain.obstacle == "none"
    # Asked directly: nothing where the frame's lines were found at the finer scale already
    # or there are none; the staircase where they were at half size.
    left = before.rectified.left
    for lines in (None, SceneLines(None, None, np.empty((0, 4)), scale=1.0)):
        assert staircase_of_finer_lines(before, left, lines, config) is before
    half = SceneLines(None, None, np.empty((0, 4)), scale=0.5)
    again = staircase_of_finer_lines(before, left, half, config)
    assert len(again.terrain.steps) >= 3
