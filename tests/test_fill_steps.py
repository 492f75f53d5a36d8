"""The fills as a frame runs them (stereo_terrain.pipeline.fill_steps): the Manhattan fill
waits for up when nothing gives it, and runs once the scene has fixed it (issue 11)."""

from __future__ import annotations

import numpy as np

import stereo_terrain.pipeline.core as core
from stereo_terrain.gravity import GravityEstimate, SceneLines, horizontal_direction
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.pipeline.fill_steps import fill_faces, fill_faces_with_up
from stereo_terrain.rectify import RectifiedPair
from stereo_terrain.stereo import DisparityMap
from stereo_terrain.stereo.fill import find_flat_regions
from stereo_terrain.synthetic import random_scene_spec, render_scene

from .test_manhattan import FILL_TOL_PX, _one_ended_riser

#: Up of the head-on scene of ``_one_ended_riser`` in its camera.
UP = np.array([0.0, -1.0, 0.0])


def _riser_frame():
    """The one-ended painted riser as the pipeline's fills get it: the pair, the matcher's
    disparity, the flat regions, and lines whose vertical segments do not fix up (only the
    riser's horizontal edges are segments)."""
    rect, img, disparity, riser, truth = _one_ended_riser(np.random.default_rng(3))
    pair = RectifiedPair(img, img, rect)
    disp = DisparityMap(disparity, 64, rect)
    # The first estimate of up from the planar-filled disparity is never sure enough here.
    config = PipelineConfig.from_dict({"fill": {"manhattan_max_up_sigma_deg": 0.0}})
    flat = find_flat_regions(img, config.fill)
    segments = np.array(
        [[160.0, y, 630.0, y] for y in range(326, 336)] + [[160.0, y, 630.0, y] for y in range(396, 406)]
    )
    unsure = GravityEstimate(np.full(3, np.nan), "camera_rect", np.inf, False, reason="too few lines")
    return pair, disp, flat, SceneLines(unsure, None, segments), config, riser, truth


def test_without_up_the_manhattan_fill_waits_and_leaves_the_planar_fill():
    pair, disp, flat, lines, config, riser, _ = _riser_frame()
    faces = fill_faces(disp, pair, flat, lines, None, True, config)
    assert faces.waited_for_up
    assert faces.disparity is faces.planar
    assert faces.planar.filled is not None and faces.planar.filled[riser].mean() < 0.1


def test_given_up_later_the_face_is_filled_as_with_up_at_once():
    pair, disp, flat, lines, config, riser, truth = _riser_frame()
    faces = fill_faces(disp, pair, flat, lines, None, True, config)
    later = fill_faces_with_up(disp, faces, pair, lines, UP, config)
    assert later is not None and later.filled is not None
    inner = riser.copy()
    inner[:, : 150 + 10] = False
    assert later.filled[inner].mean() > 0.9
    assert np.max(np.abs(later.disparity - truth)[inner & later.filled]) < FILL_TOL_PX
    # The same fill as one with up known from the start (a rig: the lines' job then finds
    # the horizontal direction from the same segments).
    horizontal = horizontal_direction(lines.segments, pair.rectification, UP, config.vanishing)
    with_rig_lines = SceneLines(None, horizontal, lines.segments)
    at_once = fill_faces(disp, pair, flat, with_rig_lines, UP, True, config)
    assert not at_once.waited_for_up
    np.testing.assert_array_equal(later.disparity, at_once.disparity.disparity)
    np.testing.assert_array_equal(later.filled, at_once.disparity.filled)


def test_up_known_at_once_never_waits():
    pair, disp, flat, lines, config, _, _ = _riser_frame()
    assert not fill_faces(disp, pair, flat, lines, UP, True, config).waited_for_up
    # Without the Manhattan fill, or without lines, there is nothing to wait for.
    assert not fill_faces(disp, pair, flat, lines, None, False, config).waited_for_up
    assert not fill_faces(disp, pair, flat, None, None, True, config).waited_for_up


def test_no_horizontal_direction_for_the_new_up_fills_nothing():
    pair, disp, flat, lines, config, _, _ = _riser_frame()
    faces = fill_faces(disp, pair, flat, lines, None, True, config)
    vertical = np.array([[100.0 + 40 * i, 50.0, 100.0 + 40 * i, 300.0] for i in range(8)])
    vertical_only = SceneLines(lines.up, None, vertical)
    assert fill_faces_with_up(disp, faces, pair, vertical_only, UP, config) is None


def test_the_pipeline_fills_the_faces_once_the_scene_has_fixed_up(monkeypatch):
    """No rig, and nothing fixes up before the fill (the image's vertical lines are made
    unsure here, and the first estimate is never sure enough): the painted faces wait,
    and the scene's planes then fix up; the faces are filled with it and the planes found
    again, on the refilled disparity (``fill.manhattan_after_gravity``)."""
    found_lines = core.scene_lines

    def unsure_lines(*args, **kwargs):
        found = found_lines(*args, **kwargs)
        return SceneLines(None, None, found.segments)

    monkeypatch.setattr(core, "scene_lines", unsure_lines)
    rng = np.random.default_rng(5)
    specs = [random_scene_spec(rng, kind="stairs", weak_texture=True) for _ in range(6)]
    scene = render_scene(specs[5])  # painted risers and treads
    results = {}
    for after in (True, False):
        fill = {"manhattan_max_up_sigma_deg": 0.0, "manhattan_after_gravity": after}
        config = PipelineConfig.from_dict({"fill": fill})
        results[after] = Pipeline(scene.calibration, None, config).run(scene.left, scene.right)
    on, off = results[True], results[False]
    assert on.gravity_source == off.gravity_source == "scene"
    assert on.disparity.filled is not None and off.disparity.filled is not None
    # Off: the planar fill alone. On: the Manhattan fill's faces too, and the planes are
    # those of the refilled disparity.
    assert np.all(on.disparity.filled >= off.disparity.filled)
    assert on.disparity.filled.sum() > 1.3 * off.disparity.filled.sum()
    assert len(on.planes.samples) != len(off.planes.samples) or not np.array_equal(
        on.planes.samples.points, off.planes.samples.points
    )
    # The gravity is the scene's either way: the refill comes after it.
    np.testing.assert_allclose(on.T_yaw_camera_rect.matrix[:3, :3], off.T_yaw_camera_rect.matrix[:3, :3])
