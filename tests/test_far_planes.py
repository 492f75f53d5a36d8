"""The far planes (PipelineConfig.far_planes_sigmas, issue 11): when no pass finds an
obstacle, each pass's samples go through the plane stage again with the normal tests widened
by the far samples' noise, and a staircase whose steps agree, standing on the ground seen,
is kept. Wooden stairs 1.5-2.5 m ahead, as in the paper's lab, need it: there a riser's
samples have normals tens of degrees off."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.pipeline import Pipeline, PipelineConfig, second_opinions
from stereo_terrain.pipeline.second_opinions import replanned
from stereo_terrain.stereo.bands import BandFillConfig
from stereo_terrain.synthetic import default_scene_spec, random_scene_spec, render_scene
from stereo_terrain.terrain import TerrainConfig

from .rounding import premise

#: The far planes' own tests run with the band fill off: with it the rematch finds these
#: lab-like stairs before the far planes run (tests/test_bands.py tests the band fill);
#: likewise the risers moved to where both images put them (tests/test_photometric.py),
#: and the denoised opinions, which run after the far planes and find some of these stairs
#: where the far planes are off (tests/test_denoise.py).
NO_BANDS = PipelineConfig(
    bands=BandFillConfig(enabled=False), terrain=TerrainConfig(photometric_risers=False), rematch_denoised=0.0
)


def _lab_stairs(seed: int):
    """Wooden stairs like the paper's lab stairs (three steps of 20 cm rise and 31 cm run,
    1.5-2.5 m ahead, 7 cm baseline, realistic webcam images), as
    ``benchmarks/bench_far_stairs.py --lab`` draws them."""
    rng = np.random.default_rng(seed)
    while True:
        spec = random_scene_spec(
            rng,
            profile="realistic",
            kind="stairs",
            weak_texture=False,
            distance_m=float(rng.uniform(1.5, 2.5)),
            baseline_m=0.07,
            rise_m=0.2,
            run_m=0.31,
            n_steps=3,
        )
        if spec.tread.texture == "planks":
            return render_scene(spec)


@pytest.fixture(scope="module")
def lab_scene():
    return _lab_stairs(26)


def assert_steps_match_truth(steps, truth) -> None:
    """As many steps as the truth's, each within 2.5 cm of rise and 10 cm of distance."""
    assert len(steps) == len(truth)
    for got, want in zip(steps, truth, strict=True):
        assert abs(got.rise_m - want["rise"]) < 0.025
        assert abs(got.distance_m - want["distance"]) < 0.1


def test_far_wooden_stairs_are_found_by_the_far_planes(lab_scene):
    scene = lab_scene
    result = Pipeline(scene.calibration, scene.rig, NO_BANDS, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "stairs"
    assert "far planes" in result.terrain.note
    assert result.timing_ms["far_planes"] > 0
    assert result.plane_choice.startswith("orientation, normal tests widened")
    assert_steps_match_truth(result.terrain.steps, scene.truth["steps"])
    assert not result.terrain.steps[0].rise_inferred


def test_without_the_far_planes_the_same_stairs_are_not_found(lab_scene):
    scene = lab_scene
    # (the redrawn planes after them off too: other draws find these stairs as well; and
    # the staircase of the lines, which finds one there, a step too many and 13 cm near)
    no_lines = dataclasses.replace(NO_BANDS.terrain, lines_first_riser=False)
    off = dataclasses.replace(NO_BANDS, far_planes_sigmas=0.0, redraw_planes=0, terrain=no_lines)
    result = Pipeline(scene.calibration, scene.rig, off, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "none"
    assert "far_planes" not in result.timing_ms


def test_a_frame_without_second_opinions_runs_no_far_planes(lab_scene):
    """The live loop's every-other-pair frames (``run(rematch=False)``) skip them too."""
    scene = lab_scene
    pipeline = Pipeline(scene.calibration, scene.rig, warm_up=False)
    result = pipeline.run(scene.left, scene.right, rematch=False)
    assert result.terrain.obstacle == "none"
    assert "far_planes" not in result.timing_ms and "rematch" not in result.timing_ms


def test_a_frame_that_finds_its_staircase_does_not_run_the_far_planes():
    scene = render_scene(default_scene_spec())
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "stairs"
    assert "far_planes" not in result.timing_ms
    assert "far planes" not in result.terrain.note


def test_far_planes_config():
    assert PipelineConfig().far_planes_sigmas == 1.1
    assert PipelineConfig.from_dict({"far_planes_sigmas": 0}).far_planes_sigmas == 0
    with pytest.raises(ConfigError, match="far_planes_sigmas"):
        PipelineConfig(far_planes_sigmas=-0.5)
    # Only the orientation method has normal tests to widen.
    scene = render_scene(dataclasses.replace(default_scene_spec(), obstacle=None))
    for method in ("contour", "auto"):
        config = PipelineConfig(method=method)
        result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
        assert "far_planes" not in result.timing_ms


def _agreeing_staircase():
    """A staircase model whose steps agree (the default scene's, as found)."""
    scene = render_scene(default_scene_spec())
    terrain = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right).terrain
    assert terrain.obstacle == "stairs" and len(terrain.steps) >= 2
    assert second_opinions.steps_agree(terrain, PipelineConfig().terrain)
    return terrain


@pytest.mark.parametrize("first_inferred", [False, True])
def test_what_the_far_planes_keep(monkeypatch, first_inferred):
    """Doctored: the widened plane stage of an empty frame "finds" a staircase whose steps
    agree. It is kept when its first riser's foot was seen, not when the first rise was
    inferred (a real room's chair, Adirondack, made such a staircase)."""
    staircase = _agreeing_staircase()
    steps = list(staircase.steps)
    steps[0] = dataclasses.replace(steps[0], rise_inferred=first_inferred)
    staircase = dataclasses.replace(staircase, steps=tuple(steps))
    real_build = replanned.build_terrain

    def build(planes, config, **kwargs):
        if planes.parameters.get("doctored"):
            return staircase
        return real_build(planes, config, **kwargs)

    real_extract = replanned.extract_planes_orientation

    def extract(samples, config, **kwargs):
        planes = real_extract(samples, config, **kwargs)
        if config.normal_noise_sigmas > 0:  # the far planes' call
            planes = dataclasses.replace(planes, parameters={**planes.parameters, "doctored": True})
        return planes

    monkeypatch.setattr(replanned, "build_terrain", build)
    monkeypatch.setattr(replanned, "extract_planes_orientation", extract)
    scene = render_scene(dataclasses.replace(default_scene_spec(), obstacle=None))
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert "far_planes" in result.timing_ms
    if first_inferred:
        assert result.terrain.obstacle == "none"
    else:
        assert result.terrain.obstacle == "stairs"
        want = "found by the far planes (no pass found an obstacle; the coarse rematch's"
        assert want in result.terrain.note
        assert result.swing is not None and result.rematched  # a second opinion's


def test_the_wider_level_runs_only_where_the_first_keeps_nothing(monkeypatch):
    """On an empty view the far planes run at 1.1 sigmas (the usual 35 deg cap) and then,
    having kept nothing, at 1.6 sigmas capped at 40 deg; ``far_planes_wider_sigmas: 0``
    leaves the first level alone."""
    calls = []
    real_extract = replanned.extract_planes_orientation

    def extract(samples, config, **kwargs):
        if config.normal_noise_sigmas > 0:
            calls.append((config.normal_noise_sigmas, config.max_noise_tolerance_deg))
        return real_extract(samples, config, **kwargs)

    monkeypatch.setattr(replanned, "extract_planes_orientation", extract)
    empty = render_scene(random_scene_spec(np.random.default_rng(5), profile="realistic", kind="none"))
    # (the denoised opinions off: their passes' far planes run after all of these, in the
    # same order, tests/test_denoise.py)
    no_denoised = PipelineConfig(rematch_denoised=0.0)
    Pipeline(empty.calibration, empty.rig, no_denoised, warm_up=False).run(empty.left, empty.right)
    assert calls and {c[0] for c in calls} == {1.1, 1.6}
    first = [c for c in calls if c[0] == 1.1]
    assert calls[: len(first)] == first  # every pass at 1.1 before any at 1.6
    assert {c[1] for c in calls if c[0] == 1.6} == {40.0} and {c[1] for c in first} == {35.0}
    calls.clear()
    off = PipelineConfig(far_planes_wider_sigmas=0.0, rematch_denoised=0.0)
    Pipeline(empty.calibration, empty.rig, off, warm_up=False).run(empty.left, empty.right)
    assert calls and {c[0] for c in calls} == {1.1}


def test_wider_far_planes_config():
    config = PipelineConfig()
    assert (config.far_planes_wider_sigmas, config.far_planes_wider_max_deg) == (1.6, 40.0)
    assert PipelineConfig.from_dict({"far_planes_wider_sigmas": 0}).far_planes_wider_sigmas == 0
    with pytest.raises(ConfigError, match="far_planes_wider_sigmas"):
        PipelineConfig(far_planes_wider_sigmas=-1.0)
    with pytest.raises(ConfigError, match="far_planes_wider_max_deg"):
        PipelineConfig(far_planes_wider_max_deg=45.0)
    with pytest.raises(ConfigError, match="far_planes_wider_max_deg"):
        PipelineConfig(far_planes_wider_max_deg=10.0)
    assert PipelineConfig(far_planes_wider_sigmas=0.0, far_planes_wider_max_deg=50.0)  # off: not checked


def test_far_wooden_stairs_found_by_the_wider_level():
    scene = _lab_stairs(43)
    result = Pipeline(scene.calibration, scene.rig, NO_BANDS, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == "stairs"
    assert_steps_match_truth(result.terrain.steps, scene.truth["steps"])
    premise(
        "widened further" in result.terrain.note,
        "every opinion before the wider far planes misses the stairs",
    )
    assert "far_planes_wider_sigmas" in result.terrain.note
    assert result.plane_choice == "orientation, normal tests widened further (far_planes_wider_sigmas)"
    # (the redrawn planes after them off too: other draws find these stairs as well; and
    # the full-size image's lines, which find them 11 cm farther: vanishing.finer_scale)
    half = NO_BANDS.vanishing.horizontal_scale
    off_config = dataclasses.replace(
        NO_BANDS,
        far_planes_wider_sigmas=0.0,
        redraw_planes=0,
        vanishing=dataclasses.replace(NO_BANDS.vanishing, finer_scale=half),
    )
    off = Pipeline(scene.calibration, scene.rig, off_config, warm_up=False)
    assert off.run(scene.left, scene.right).terrain.obstacle == "none"
