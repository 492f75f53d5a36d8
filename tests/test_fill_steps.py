"""The fills as a frame runs them (stereo_terrain.pipeline.fill_steps): the Manhattan fill
waits for up, or for a horizontal direction of the scene, when nothing gives it, and runs
once the frame has them (issue 11)."""

from __future__ import annotations

import math

import numpy as np

import stereo_terrain.pipeline.core as core
from stereo_terrain.cloud import GridSample
from stereo_terrain.frames import R_BODY_OPTICAL, Transform
from stereo_terrain.gravity import GravityEstimate, SceneLines, horizontal_direction
from stereo_terrain.msac import Plane
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.pipeline.fill_steps import fill_faces, fill_faces_later
from stereo_terrain.planes.orientation import VERTICAL, PlaneSegment, PlaneSet
from stereo_terrain.rectify import RectifiedPair
from stereo_terrain.stereo import DisparityMap
from stereo_terrain.stereo.fill import find_flat_regions
from stereo_terrain.synthetic import random_scene_spec, render_scene

from .test_manhattan import FILL_TOL_PX, _one_ended_riser

#: Up of the head-on scene of ``_one_ended_riser`` in its camera.
UP = np.array([0.0, -1.0, 0.0])
#: Its level yaw frame (x forward, y left, z up) from the camera.
T_YAW_CAMERA = Transform.from_rt(R_BODY_OPTICAL, np.zeros(3), "yaw", "camera_rect")


def _planes(*vertical_normals: np.ndarray) -> PlaneSet:
    """A plane set in the yaw frame holding vertical planes of these normals (each with
    more inliers than the one after it); its samples are not read."""
    empty = np.zeros((0, 3), np.float32)
    none = np.zeros(0, np.int32)
    samples = GridSample(empty, empty, np.zeros(0, np.float32), none, none, none, (0, 0), 4, "yaw")
    segments = tuple(
        PlaneSegment(Plane(n, 2.0), VERTICAL, np.arange(100 - k), 0.01)
        for k, n in enumerate(vertical_normals)
    )
    return PlaneSet(segments, samples, np.array([0.0, 0.0, 1.0]), "test", np.zeros(3))


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


def _filled_at_once(pair, disp, flat, lines, config):
    """The fill with up known from the start (a rig: the lines' job then finds the
    horizontal direction from the same segments)."""
    horizontal = horizontal_direction(lines.segments, pair.rectification, UP, config.vanishing)
    at_once = fill_faces(disp, pair, flat, SceneLines(None, horizontal, lines.segments), UP, True, config)
    assert not at_once.waited
    return at_once.disparity


def test_given_up_later_the_face_is_filled_as_with_up_at_once():
    pair, disp, flat, lines, config, riser, truth = _riser_frame()
    faces = fill_faces(disp, pair, flat, lines, None, True, config)
    later = fill_faces_later(disp, faces, pair, lines, _planes(), T_YAW_CAMERA, config)
    assert later is not None and later.filled is not None
    inner = riser.copy()
    inner[:, : 150 + 10] = False
    assert later.filled[inner].mean() > 0.9
    assert np.max(np.abs(later.disparity - truth)[inner & later.filled]) < FILL_TOL_PX
    at_once = _filled_at_once(pair, disp, flat, lines, config)
    np.testing.assert_array_equal(later.disparity, at_once.disparity)
    np.testing.assert_array_equal(later.filled, at_once.filled)


def test_without_a_horizontal_direction_the_largest_vertical_plane_gives_it():
    """Up known (a rig) but the lines give no horizontal direction: the fill waits, then
    takes it from the frame's largest vertical plane (here the riser's own, facing the
    camera, which a small plane 30 deg off does not outvote)."""
    pair, disp, flat, lines, config, riser, truth = _riser_frame()
    vertical = np.array([[100.0 + 40 * i, 20.0, 100.0 + 40 * i, 300.0] for i in range(8)])
    no_horizontal = SceneLines(None, None, vertical)
    faces = fill_faces(disp, pair, flat, no_horizontal, UP, True, config)
    assert faces.waited_for_horizontal and not faces.waited_for_up
    assert faces.disparity is faces.planar
    facing = np.array([-1.0, 0.0, 0.0])
    off = np.array([-math.cos(math.radians(30.0)), math.sin(math.radians(30.0)), 0.0])
    later = fill_faces_later(disp, faces, pair, no_horizontal, _planes(facing, off), T_YAW_CAMERA, config)
    assert later is not None and later.filled is not None
    inner = riser.copy()
    inner[:, : 150 + 10] = False
    assert later.filled[inner].mean() > 0.9
    assert np.max(np.abs(later.disparity - truth)[inner & later.filled]) < FILL_TOL_PX
    # No vertical plane and no lines: nothing to fill.
    assert fill_faces_later(disp, faces, pair, no_horizontal, _planes(), T_YAW_CAMERA, config) is None


def test_up_known_at_once_never_waits():
    pair, disp, flat, lines, config, _, _ = _riser_frame()
    horizontal = horizontal_direction(lines.segments, pair.rectification, UP, config.vanishing)
    assert not fill_faces(
        disp, pair, flat, SceneLines(None, horizontal, lines.segments), UP, True, config
    ).waited
    # Without the Manhattan fill, or without lines, there is nothing to wait for.
    assert not fill_faces(disp, pair, flat, lines, None, False, config).waited
    assert not fill_faces(disp, pair, flat, None, None, True, config).waited


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


def test_with_a_rig_and_no_horizontal_direction_the_planes_give_it(monkeypatch):
    """With a rig, where the image's lines give no horizontal direction (about one
    realistic frame in five), the faces wait for the frame's planes: the painted
    staircase of this scene is then filled and counted."""
    found_lines = core.scene_lines

    def no_horizontal(*args, **kwargs):
        return SceneLines(None, None, found_lines(*args, **kwargs).segments)

    monkeypatch.setattr(core, "scene_lines", no_horizontal)
    rng = np.random.default_rng(5)
    specs = [random_scene_spec(rng, kind="stairs", weak_texture=True) for _ in range(2)]
    scene = render_scene(specs[1])  # painted, 5 steps
    results = {}
    for after in (True, False):
        # (the band fill off: the rematch's bands would be counted as the fill's)
        config = PipelineConfig.from_dict(
            {"fill": {"manhattan_after_gravity": after}, "bands": {"enabled": False}}
        )
        results[after] = Pipeline(scene.calibration, scene.rig, config).run(scene.left, scene.right)
    on, off = results[True], results[False]
    assert on.gravity_source == "rig"
    assert on.disparity.filled is not None and off.disparity.filled is not None
    assert on.disparity.filled.sum() > 1.3 * off.disparity.filled.sum()
    assert on.terrain.obstacle == "stairs"
    assert len(on.terrain.steps) == len(scene.truth["steps"])
