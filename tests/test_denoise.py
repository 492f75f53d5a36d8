"""The denoised second opinions (stereo_terrain.stereo.denoise,
PipelineConfig.rematch_denoised, issue 11): where every other opinion leaves a frame
wanting one, the pair with the sensor's noise taken out is matched again."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.evaluation import score_result
from stereo_terrain.pipeline import Pipeline, PipelineConfig, core
from stereo_terrain.rectify import compute_rectification, rectify
from stereo_terrain.stereo.denoise import denoise_image, denoise_pair
from stereo_terrain.synthetic import default_scene_spec, random_scene_spec, render_scene

from .rounding import premise
from .test_bad_input_corpus import _calib
from .test_blur import _texture
from .test_focus_rematch import _passes

#: A webcam's noise after its own smoothing: blotches a pixel or two across (grey levels).
NOISE_GREY = 3.0


def _noisy(shape: tuple[int, int], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.normal(0.0, NOISE_GREY * 2.0, shape), (0, 0), 0.7)


def test_it_takes_the_noise_out_and_keeps_an_edge():
    edge = np.full((120, 160), 90.0)
    edge[:, 80:] = 150.0  # a nosing's edge: 60 grey levels
    image = np.clip(edge + _noisy(edge.shape, 1), 0, 255).astype(np.uint8)
    out = denoise_image(image, NOISE_GREY)
    assert out.shape == image.shape and out.dtype == np.uint8
    flat = (slice(10, 110), slice(10, 70))
    assert out[flat].std() < 0.5 * image[flat].std()
    step = out[:, 82:100].astype(float).mean() - out[:, 60:78].astype(float).mean()
    assert step == pytest.approx(60.0, abs=3.0)  # the edge is where it was, as high
    assert np.abs(out[:, 78:83].astype(float) - image[:, 78:83].astype(float)).mean() < 6.0


def test_both_images_of_a_pair_alike():
    calib = _calib(160, 120)
    image = np.clip(128 + _noisy((120, 160), 2), 0, 255).astype(np.uint8)
    pair = rectify(image, image, compute_rectification(calib))
    quiet = denoise_pair(pair, NOISE_GREY)
    assert np.array_equal(quiet.left, quiet.right)
    assert quiet.rectification is pair.rectification
    assert quiet.left.std() < pair.left.std()


def test_it_refuses_what_it_cannot_take():
    with pytest.raises(InputError, match="uint8"):
        denoise_image(np.zeros((10, 10), np.float32), 3.0)
    with pytest.raises(InputError, match="uint8"):
        denoise_image(np.zeros((10, 10, 3), np.uint8), 3.0)


@pytest.fixture(scope="module")
def painted_stairs():
    """Scene 37 of ``stereo-terrain render --profile realistic --seed 1313``: four painted
    steps that the first matcher and every opinion before the denoised ones miss."""
    rng = np.random.default_rng(1313)
    for _ in range(37):
        random_scene_spec(rng, profile="realistic")
    return render_scene(random_scene_spec(rng, profile="realistic"))


def test_stairs_the_noise_hides_are_found(painted_stairs):
    scene = painted_stairs
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "stairs"
    score = score_result(result.to_json_dict(), scene.truth)
    assert score.count_right
    assert score.first_distance_error_m is not None and score.first_distance_error_m < 0.05
    assert score.yaw_error_rad is not None and score.yaw_error_rad < 0.1
    assert len(score.rise_errors_m) == 4 and max(score.rise_errors_m) < 0.02
    premise(
        "the denoised coarse rematch's samples" in result.terrain.note,
        "every opinion before the denoised ones misses the stairs, and the risers' ends replace none",
    )
    assert result.rematched and result.timing_ms["denoise"] > 0


def test_without_them_they_are_not(painted_stairs):
    scene = painted_stairs
    config = PipelineConfig(rematch_denoised=0.0)
    result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "none"
    assert "denoise" not in result.timing_ms


def test_they_run_only_where_every_other_opinion_leaves_the_frame_wanting(monkeypatch):
    calib = _calib(640, 480)  # two identical cameras side by side
    image = cv2.resize(_texture(9), (640, 480))  # a textured wall at infinity: nothing to find
    default = Pipeline(calib, None, warm_up=False)
    assert _passes(monkeypatch, default, image, image) == 5  # first, rematch, coarse, and the two
    off = Pipeline(calib, None, PipelineConfig(rematch_denoised=0.0), warm_up=False)
    assert _passes(monkeypatch, off, image, image) == 3
    no_second = Pipeline(calib, None, PipelineConfig(rematch=False), warm_up=False)
    assert _passes(monkeypatch, no_second, image, image) == 1


def test_a_frame_may_skip_them_alone(monkeypatch):
    """``Pipeline.run(denoised=False)`` (the live loop's pairs between two that run them,
    ``LoopConfig.denoised_every``) runs the other second opinions and not these."""
    calib = _calib(640, 480)
    image = cv2.resize(_texture(9), (640, 480))
    pipeline = Pipeline(calib, None, warm_up=False)
    seen: list[dict[str, float]] = []
    original = pipeline.run

    def run(left, right, **options):
        result = original(left, right, **options)
        seen.append(result.timing_ms)
        return result

    monkeypatch.setattr(pipeline, "run", run)
    assert _passes(monkeypatch, pipeline, image, image) == 5
    assert "denoise" in seen[-1] and "rematch" in seen[-1]
    monkeypatch.setattr(pipeline, "run", lambda left, right: run(left, right, denoised=False))
    assert _passes(monkeypatch, pipeline, image, image) == 3
    assert "denoise" not in seen[-1] and "rematch" in seen[-1]


def test_stairs_the_first_pass_finds_are_not_denoised():
    scene = render_scene(default_scene_spec())
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "stairs" and not result.rematched
    assert "denoise" not in result.timing_ms


def _recorder(given: dict[str, list[list[str]]], name: str, real):
    def record(tried, kept, cfg):
        given.setdefault(name, []).append([n for n, _ in tried])
        return real(tried, kept, cfg)

    return record


def _opinions_given(monkeypatch, scene, rig, **config) -> dict[str, list[list[str]]]:
    """The pass names each later opinion is given on ``scene`` (with ``rig`` or None)."""
    given: dict[str, list[list[str]]] = {}
    for name in ("far_planes", "agreed_lone_step", "whole_box", "redrawn_planes"):
        monkeypatch.setattr(core, name, _recorder(given, name, getattr(core, name)))
    Pipeline(scene.calibration, rig, PipelineConfig(**config), warm_up=False).run(scene.left, scene.right)
    return given


@pytest.fixture(scope="module")
def empty_view():
    """A realistic view with nothing in it: every opinion runs and keeps nothing."""
    return render_scene(random_scene_spec(np.random.default_rng(5), profile="realistic", kind="none"))


def test_the_denoised_passes_get_their_own_later_opinions(monkeypatch, empty_view):
    empty = empty_view
    denoised = ["denoised rematch", "denoised coarse rematch"]
    given = _opinions_given(monkeypatch, empty, empty.rig)
    assert given["far_planes"][-1] == denoised
    assert given["agreed_lone_step"][-1] == ["first matcher", *denoised]  # it skips the first
    assert given["whole_box"][-1] == ["first matcher", *denoised]
    assert given["redrawn_planes"][-1] == denoised  # (the last of them is redrawn)
    # without the coarse rematch, the denoised rematch alone
    given = _opinions_given(monkeypatch, empty, empty.rig, rematch_coarse=False)
    assert given["far_planes"][-1] == ["denoised rematch"]
    assert given["redrawn_planes"][-1] == ["denoised rematch"]


def test_without_a_rig_no_box_from_a_denoised_pass_alone(monkeypatch, empty_view):
    """Without a rig the ground beyond a "box" is the floor the scene chose, in a room
    as likely a table's top (the real Middlebury Playroom, tests/test_terrain_clutter.py)."""
    given = _opinions_given(monkeypatch, empty_view, None)
    assert not any("denoised rematch" in names for names in given["whole_box"])
    assert any("denoised rematch" in names for names in given["agreed_lone_step"])


def test_the_config_reads_it():
    assert PipelineConfig().rematch_denoised == 3.0
    assert PipelineConfig.from_dict({"rematch_denoised": 4.5}).rematch_denoised == 4.5
    assert PipelineConfig.from_dict({"rematch_denoised": 3}).rematch_denoised == 3  # an int, as YAML gives
    for edge in (0, 50):
        assert PipelineConfig.from_dict({"rematch_denoised": edge}).rematch_denoised == edge
    assert dataclasses.replace(PipelineConfig(), rematch_denoised=0).rematch_denoised == 0
    for bad in (-1.0, 51.0):
        with pytest.raises(ConfigError, match="rematch_denoised"):
            PipelineConfig.from_dict({"rematch_denoised": bad})
