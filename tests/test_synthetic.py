"""Tests of the synthetic scene renderer: determinism, geometry, calibration, realism."""

from __future__ import annotations

import dataclasses
import json
import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.calibration import read_opencv_yaml
from stereo_terrain.errors import InputError
from stereo_terrain.frames import Rig, camera_mount, load_rig
from stereo_terrain.rectify import compute_rectification, rectify
from stereo_terrain.synthetic import (
    BoxSpec,
    CameraIntrinsics,
    SceneSpec,
    StairSpec,
    SyntheticScene,
    _undistort,
    default_scene_spec,
    random_scene_spec,
    render_scene,
    render_scenes,
    write_scene,
)

#: Distance of a reconstructed ground point from z = 0 (float32 depth, exact rays).
GROUND_TOL_M = 2e-4
#: A reconstructed riser point's distance from its truth plane, and the x-axis distance.
PLANE_TOL_M = 2e-4
#: Round trip pixel -> ray -> pixel of the renderer's undistortion.
UNDISTORT_TOL_PX = 1e-6
#: Edges of faces found from labelled pixels (a pixel is ~2.5 mm at 1.3 m, 640 px).
EDGE_TOL_M = 0.01
#: Rectified pairs: median vertical offset of tracked features.
RECTIFIED_DY_PX = 0.3
#: Raw pairs must be clearly unrectified.
RAW_DY_MIN_PX = 3.0
#: Measured vs. true disparity of tracked features after rectification (median).
DISPARITY_TOL_PX = 0.3

SMALL = (320, 240)


@pytest.fixture(scope="module")
def demo() -> SyntheticScene:
    return render_scene(default_scene_spec())


def _undistort_cv(calib_K, calib_D, uv: np.ndarray) -> np.ndarray:
    """Independent undistortion (OpenCV, iterated to convergence) -> normalized (N, 2)."""
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)
    pts = np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2)
    return cv2.undistortPoints(pts, calib_K, calib_D, criteria=crit).reshape(-1, 2)


def _to_yaw(scene: SyntheticScene, uv: np.ndarray) -> np.ndarray:
    """Left pixels (integer) with their truth depth -> (N, 3) points in the yaw frame."""
    cal = scene.calibration
    xy = _undistort_cv(cal.K1, cal.D1, uv)
    z = scene.depth_left[uv[:, 1].astype(int), uv[:, 0].astype(int)].astype(np.float64)
    p_cam = np.column_stack([xy * z[:, None], z])
    return scene.rig.T_yaw_camera.apply(p_cam)


def _plane(scene: SyntheticScene, name: str) -> tuple[int, dict]:
    for i, p in enumerate(scene.truth["planes"]):
        if p["name"] == name:
            return i, p
    raise KeyError(name)


# ----------------------------------------------------------------- smoke, shapes, determinism


def test_demo_shapes_and_types(demo: SyntheticScene) -> None:
    assert demo.left.shape == demo.right.shape == (480, 640)
    assert demo.left.dtype == demo.right.dtype == np.uint8
    assert demo.depth_left.shape == (480, 640) and demo.depth_left.dtype == np.float32
    assert demo.labels_left.shape == (480, 640)
    assert demo.calibration.image_size == (640, 480)
    assert not demo.calibration.rectified
    assert 0.075 <= demo.calibration.baseline_m <= 0.085
    t = demo.truth
    assert t["version"] == 1 and t["frame"] == "yaw" and t["obstacle"] == "stairs"
    assert [s["rise"] for s in t["steps"]] == pytest.approx([0.17] * 3)
    assert [s["run"] for s in t["steps"]] == [0.29, 0.29, None]
    assert t["steps"][0]["distance"] == pytest.approx(1.3)
    assert t["yaw"] == pytest.approx(math.radians(10))
    assert t["image_size"] == [640, 480]
    # Every listed plane is seen by some pixel (the back wall included).
    assert set(np.unique(demo.labels_left)) >= set(range(len(t["planes"])))


def test_same_seed_same_images_different_seed_differs() -> None:
    spec_a = random_scene_spec(np.random.default_rng(7), image_size=SMALL, kind="stairs")
    spec_b = random_scene_spec(np.random.default_rng(7), image_size=SMALL, kind="stairs")
    assert spec_a == spec_b
    a, b = render_scene(spec_a), render_scene(spec_b)
    np.testing.assert_array_equal(a.left, b.left)
    np.testing.assert_array_equal(a.right, b.right)
    np.testing.assert_array_equal(a.depth_left, b.depth_left)
    assert a.truth == b.truth
    c = render_scene(random_scene_spec(np.random.default_rng(8), image_size=SMALL, kind="stairs"))
    assert np.mean(np.abs(a.left.astype(int) - c.left.astype(int))) > 5.0
    # Only the seed changed: textures and noise differ, the geometry does not.
    d = render_scene(dataclasses.replace(spec_a, seed=spec_a.seed + 1))
    np.testing.assert_array_equal(a.depth_left, d.depth_left)
    assert not np.array_equal(a.left, d.left)


@pytest.mark.parametrize(("size", "supersample"), [((320, 240), 2), ((1280, 720), 1)])
def test_other_image_sizes(size: tuple[int, int], supersample: int) -> None:
    spec = random_scene_spec(np.random.default_rng(3), image_size=size, kind="box", supersample=supersample)
    scene = render_scene(spec)
    w, h = size
    assert scene.left.shape == scene.right.shape == scene.depth_left.shape == (h, w)
    assert scene.calibration.image_size == size
    K = scene.calibration.K1
    assert 0.8 * w <= K[0, 0] <= 0.9 * w
    assert abs(K[0, 2] - (w - 1) / 2) < 5 and abs(K[1, 2] - (h - 1) / 2) < 5
    assert scene.truth["obstacle"] == "box" and len(scene.truth["steps"]) == 1
    assert scene.left.std() > 5


def test_render_scenes_is_deterministic(tmp_path) -> None:
    a = render_scenes(tmp_path / "a", 2, seed=11, image_size=(160, 120))
    b = render_scenes(tmp_path / "b", 2, seed=11, image_size=(160, 120))
    assert [p.name for p in a] == ["scene_000", "scene_001"]
    for pa, pb in zip(a, b, strict=True):
        for name in ("left.png", "right.png", "truth.json", "calib.yaml", "rig.yaml"):
            assert (pa / name).read_bytes() == (pb / name).read_bytes()
    assert (a[0] / "left.png").read_bytes() != (a[1] / "left.png").read_bytes()


# ----------------------------------------------------------------- geometry


def test_level_camera_sees_ground_below_centre() -> None:
    """Sign conventions: below the image centre of a level camera is the ground ahead."""
    spec = SceneSpec(
        obstacle=None, camera_height_m=0.5, pitch_down_rad=0.0, image_size=SMALL, noise_sigma=(0.0, 0.0)
    )
    scene = render_scene(spec)
    K = scene.calibration.K1
    u, v = int(round(K[0, 2])), int(round(K[1, 2])) + 60
    z = float(scene.depth_left[v, u])
    assert z == pytest.approx(0.5 * K[1, 1] / (v - K[1, 2]), rel=1e-5)
    p = _to_yaw(scene, np.array([[u, v]]))[0]
    assert p[0] > 0.5 and abs(p[1]) < 0.01 and abs(p[2]) < GROUND_TOL_M
    # Above the horizon a level camera sees nothing (no back wall): NaN depth, no label.
    assert np.isnan(scene.depth_left[5, u]) and scene.labels_left[5, u] == -1


def test_ground_pixels_lie_on_the_ground(demo: SyntheticScene) -> None:
    vs, us = np.nonzero((demo.labels_left == 0) & (demo.depth_left < 20.0))
    assert vs.size > 10_000
    sel = np.arange(0, vs.size, 37)
    p = _to_yaw(demo, np.column_stack([us[sel], vs[sel]]))
    assert np.max(np.abs(p[:, 2])) < GROUND_TOL_M
    # Tread and riser pixels lie on their planes too.
    for name in ("tread_1", "riser_2", "tread_3", "back_wall"):
        i, plane = _plane(demo, name)
        vs, us = np.nonzero(demo.labels_left == i)
        sel = np.arange(0, vs.size, 11)
        p = _to_yaw(demo, np.column_stack([us[sel], vs[sel]]))
        resid = p @ np.array(plane["normal"]) + plane["offset"]
        assert np.max(np.abs(resid)) < PLANE_TOL_M, name


def test_first_riser_centre_has_truth_distance(demo: SyntheticScene) -> None:
    ob = demo.spec.obstacle
    assert isinstance(ob, StairSpec)
    v_axis = np.array([-math.sin(ob.yaw_rad), math.cos(ob.yaw_rad), 0.0])
    centre = np.array([ob.distance_m, 0.0, ob.rise_m / 2]) + ob.lateral_m * v_axis
    T_cam_yaw = demo.rig.T_yaw_camera.inverse()
    cal = demo.calibration
    uv, _ = cv2.projectPoints(T_cam_yaw.apply(centre[None]), np.zeros(3), np.zeros(3), cal.K1, cal.D1)
    u, v = (int(round(c)) for c in uv.reshape(2))
    i, plane = _plane(demo, "riser_1")
    assert demo.labels_left[v, u] == i
    p = _to_yaw(demo, np.array([[u, v]]))[0]
    assert np.linalg.norm(p - centre) < 0.01  # one pixel at ~1.3 m is ~2.4 mm
    n = np.array(plane["normal"])
    assert abs(n @ p + plane["offset"]) < PLANE_TOL_M
    # The plane through the reconstructed point meets the x axis at the truth distance.
    x_axis_hit = (n @ p) / n[0]
    assert x_axis_hit == pytest.approx(demo.truth["steps"][0]["distance"], abs=PLANE_TOL_M)
    # And the truth distance of step 2 is one run further along the stair axis.
    d = [s["distance"] for s in demo.truth["steps"]]
    assert d[1] - d[0] == pytest.approx(ob.run_m / math.cos(ob.yaw_rad))


def _local(points: np.ndarray, yaw: float) -> np.ndarray:
    """Yaw-frame points -> obstacle frame (a along the axis, b lateral, z)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack(
        [c * points[:, 0] + s * points[:, 1], -s * points[:, 0] + c * points[:, 1], points[:, 2]]
    )


def _face_points(scene: SyntheticScene, name: str) -> np.ndarray:
    i, _ = _plane(scene, name)
    vs, us = np.nonzero(scene.labels_left == i)
    return _local(_to_yaw(scene, np.column_stack([us, vs])), scene.spec.obstacle.yaw_rad)


def test_obstacle_extent(demo: SyntheticScene) -> None:
    """The riser's edges are where the spec puts them (width, lateral offset, rise)."""
    ob = demo.spec.obstacle
    b_mid = ob.lateral_m - ob.distance_m * math.sin(ob.yaw_rad)
    p = _face_points(demo, "riser_1")
    assert p[:, 1].min() == pytest.approx(b_mid - ob.width_m / 2, abs=EDGE_TOL_M)
    assert p[:, 1].max() == pytest.approx(b_mid + ob.width_m / 2, abs=EDGE_TOL_M)
    assert p[:, 2].min() == pytest.approx(0.0, abs=EDGE_TOL_M)
    assert p[:, 2].max() == pytest.approx(ob.rise_m, abs=EDGE_TOL_M)
    p = _face_points(demo, "riser_3")
    assert p[:, 2].min() == pytest.approx(2 * ob.rise_m, abs=EDGE_TOL_M)
    assert p[:, 2].max() == pytest.approx(3 * ob.rise_m, abs=EDGE_TOL_M)


def test_box_truth() -> None:
    box = BoxSpec(height_m=0.2, depth_m=0.5, width_m=0.8, distance_m=1.4, yaw_rad=-0.2, lateral_m=0.1)
    scene = render_scene(SceneSpec(obstacle=box, image_size=SMALL))
    t = scene.truth
    assert t["obstacle"] == "box"
    assert t["steps"] == [{"rise": 0.2, "run": 0.5, "distance": pytest.approx(1.4), "width": 0.8}]
    assert [p["name"] for p in t["planes"]] == ["ground", "riser_1", "tread_1"]
    i, plane = _plane(scene, "tread_1")
    vs, us = np.nonzero(scene.labels_left == i)
    p = _to_yaw(scene, np.column_stack([us, vs]))
    assert np.max(np.abs(p[:, 2] - 0.2)) < PLANE_TOL_M
    # The whole box is in view: its top spans the spec's depth and width.
    b_mid = box.lateral_m - box.distance_m * math.sin(box.yaw_rad)
    a0 = box.distance_m * math.cos(box.yaw_rad)
    top = _local(p, box.yaw_rad)
    assert top[:, 0].min() == pytest.approx(a0, abs=3 * EDGE_TOL_M)
    assert top[:, 0].max() == pytest.approx(a0 + box.depth_m, abs=3 * EDGE_TOL_M)
    assert top[:, 1].min() == pytest.approx(b_mid - box.width_m / 2, abs=EDGE_TOL_M)
    assert top[:, 1].max() == pytest.approx(b_mid + box.width_m / 2, abs=EDGE_TOL_M)


def test_renderer_undistortion_is_exact() -> None:
    cam = CameraIntrinsics(520.0, 521.0, 318.0, 242.0, (-0.25, 0.03, 4e-4, -3e-4, 0.0))
    vv, uu = np.mgrid[0:480:7, 0:640:7].astype(np.float64)
    x, y, *_ = _undistort(uu.ravel(), vv.ravel(), cam)
    uv, _ = cv2.projectPoints(
        np.column_stack([x, y, np.ones_like(x)]),
        np.zeros(3),
        np.zeros(3),
        cam.matrix,
        np.array(cam.distortion),
    )
    err = np.abs(uv.reshape(-1, 2) - np.column_stack([uu.ravel(), vv.ravel()]))
    assert err.max() < UNDISTORT_TOL_PX


def test_write_scene_round_trip(demo: SyntheticScene, tmp_path) -> None:
    out = write_scene(demo, tmp_path / "scene")
    truth = json.loads((out / "truth.json").read_text())
    assert truth == demo.truth
    np.testing.assert_array_equal(cv2.imread(str(out / "left.png"), cv2.IMREAD_UNCHANGED), demo.left)
    np.testing.assert_array_equal(cv2.imread(str(out / "right.png"), cv2.IMREAD_UNCHANGED), demo.right)
    np.testing.assert_array_equal(np.load(out / "depth_left.npy"), demo.depth_left)
    cal = read_opencv_yaml(out / "calib.yaml")
    for name in ("K1", "D1", "K2", "D2", "R", "T"):
        np.testing.assert_allclose(getattr(cal, name), getattr(demo.calibration, name), atol=1e-12)
    rig = load_rig(out / "rig.yaml")
    np.testing.assert_allclose(rig.T_body_camera.matrix, demo.rig.T_body_camera.matrix)
    assert rig.body_rpy == pytest.approx(demo.rig.body_rpy)


# ----------------------------------------------------------------- calibration vs. images


def _track(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel feature matches left -> right (KLT with a forward-backward check)."""
    pts = cv2.goodFeaturesToTrack(left, 600, 0.01, 7)
    lk = {
        "winSize": (21, 21),
        "maxLevel": 4,
        "criteria": (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-3),
    }
    nxt, st1, _ = cv2.calcOpticalFlowPyrLK(left, right, pts, None, **lk)
    back, st2, _ = cv2.calcOpticalFlowPyrLK(right, left, nxt, None, **lk)
    ok = (st1.ravel() == 1) & (st2.ravel() == 1)
    ok &= np.linalg.norm((back - pts).reshape(-1, 2), axis=1) < 0.1
    return pts.reshape(-1, 2)[ok], nxt.reshape(-1, 2)[ok]


def test_images_are_unrectified_and_calibration_rectifies_them(demo: SyntheticScene) -> None:
    p_raw, q_raw = _track(demo.left, demo.right)
    assert len(p_raw) > 100
    assert np.median(np.abs(q_raw[:, 1] - p_raw[:, 1])) > RAW_DY_MIN_PX

    rect = compute_rectification(demo.calibration)
    pair = rectify(demo.left, demo.right, rect)
    p, q = _track(pair.left, pair.right)
    assert len(p) > 100
    assert np.median(np.abs(q[:, 1] - p[:, 1])) < RECTIFIED_DY_PX

    # Disparities agree with the depth truth: rectified left pixel -> raw left pixel ->
    # truth depth -> depth in the rectified frame -> f b / Z.
    R_raw_rect = rect.T_camera_rect.rotation
    rays = np.column_stack(
        [(p[:, 0] - rect.cx) / rect.focal_px, (p[:, 1] - rect.cy) / rect.focal_px, np.ones(len(p))]
    )
    rays_raw = rays @ R_raw_rect.T
    cal = demo.calibration
    uv, _ = cv2.projectPoints(rays_raw, np.zeros(3), np.zeros(3), cal.K1, cal.D1)
    uv = uv.reshape(-1, 2)
    ui, vi = np.rint(uv[:, 0]).astype(int), np.rint(uv[:, 1]).astype(int)
    h, w = demo.depth_left.shape
    inside = (ui >= 1) & (ui < w - 1) & (vi >= 1) & (vi < h - 1)
    ui, vi, uv, rays_raw, p, q = (a[inside] for a in (ui, vi, uv, rays_raw, p, q))
    z_raw = cv2.remap(
        demo.depth_left,
        uv[:, 0].astype(np.float32).reshape(-1, 1),
        uv[:, 1].astype(np.float32).reshape(-1, 1),
        cv2.INTER_LINEAR,
    ).ravel()
    patch = np.stack([demo.depth_left[vi + dv, ui + du] for dv in (-1, 0, 1) for du in (-1, 0, 1)])
    smooth = np.isfinite(z_raw) & (np.nanmax(patch, 0) - np.nanmin(patch, 0) < 0.05)
    z_rect = z_raw[smooth] / rays_raw[smooth, 2]  # rays have z = 1 in the rectified frame
    expected = rect.focal_px * rect.baseline_m / z_rect - rect.doffs_px
    measured = p[smooth, 0] - q[smooth, 0]
    assert smooth.sum() > 50
    assert np.median(np.abs(measured - expected)) < DISPARITY_TOL_PX


# ----------------------------------------------------------------- photometry


def _small_spec(seed: int, **overrides) -> SceneSpec:
    return random_scene_spec(np.random.default_rng(seed), image_size=SMALL, kind="stairs", **overrides)


@pytest.mark.parametrize("gain", [0.88, 1.12])
def test_right_camera_brightness_differs(gain: float) -> None:
    scene = render_scene(_small_spec(5, right_gain=gain, right_offset_grey=0.0))
    ratio = scene.right.mean() / scene.left.mean()
    assert ratio == pytest.approx(gain, abs=0.04)


def test_sensor_noise_is_present() -> None:
    noisy = render_scene(_small_spec(6, noise_sigma=(2.0, 2.8)))
    clean = render_scene(dataclasses.replace(noisy.spec, noise_sigma=(0.0, 0.0)))
    for img_n, img_c, sigma in ((noisy.left, clean.left, 2.0), (noisy.right, clean.right, 2.8)):
        ok = (img_c > 10) & (img_c < 245)
        diff = img_n.astype(float)[ok] - img_c.astype(float)[ok]
        assert np.std(diff) == pytest.approx(sigma, rel=0.15)
        assert abs(np.mean(diff)) < 0.2


def _riser_local_std(scene: SyntheticScene) -> float:
    names = {i for i, p in enumerate(scene.truth["planes"]) if p["name"].startswith("riser")}
    mask = np.isin(scene.labels_left, list(names)).astype(np.uint8)
    mask = cv2.erode(mask, np.ones((9, 9), np.uint8)).astype(bool)
    assert mask.sum() > 200
    img = scene.left.astype(np.float32)
    mean = cv2.blur(img, (7, 7))
    var = np.maximum(cv2.blur(img * img, (7, 7)) - mean * mean, 0.0)
    return float(np.median(np.sqrt(var)[mask]))


def test_weak_texture_has_low_contrast_on_risers() -> None:
    for seed in (21, 22):
        over = {"noise_sigma": (0.0, 0.0), "blur_sigma_px": 0.0}
        weak = render_scene(_small_spec(seed, weak_texture=True, **over))
        textured = render_scene(_small_spec(seed, weak_texture=False, **over))
        assert weak.spec.weak_texture and weak.truth["weak_texture"]
        assert not textured.spec.weak_texture
        assert weak.spec.riser.contrast < 0.05 < textured.spec.riser.contrast
        s_weak, s_tex = _riser_local_std(weak), _riser_local_std(textured)
        assert s_weak < 1.5
        assert s_tex > 3.0 and s_tex > 4.0 * s_weak


# ----------------------------------------------------------------- random specs


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["stairs", "box", "none", None]))
def test_random_specs_are_in_range_and_in_view(seed: int, kind: str | None) -> None:
    spec = random_scene_spec(np.random.default_rng(seed), kind=kind)
    assert 0.4 <= spec.camera_height_m <= 0.8
    assert 0.0 <= spec.pitch_down_rad <= math.radians(30)
    assert 0.075 <= spec.baseline_m <= 0.085
    assert max(abs(spec.body_rpy[0]), abs(spec.body_rpy[1])) <= math.radians(3)
    assert 0.85 <= spec.right_gain <= 1.15 and abs(spec.right_offset_grey) <= 10
    assert all(1.0 <= s <= 3.0 for s in spec.noise_sigma)
    angle = math.degrees(np.linalg.norm(spec.right_rotvec_rad))
    assert 0.3 <= angle <= 2.0
    assert -0.25 <= spec.left_camera.distortion[0] <= 0.05
    assert abs(spec.right_camera.fx / spec.left_camera.fx - 1) <= 0.011
    ob = spec.obstacle
    if ob is None:
        return
    assert 0.9 <= ob.distance_m <= 2.0 and abs(ob.yaw_rad) <= math.radians(25)
    if isinstance(ob, StairSpec):
        assert 2 <= ob.n_steps <= 5 and 0.10 <= ob.rise_m <= 0.22 and 0.25 <= ob.run_m <= 0.35
    else:
        assert 0.10 <= ob.height_m <= 0.30
    # The first riser's centre projects into the left image (independent projection).
    rig = Rig(camera_mount(spec.camera_height_m, spec.pitch_down_rad), spec.body_rpy)
    v_axis = np.array([-math.sin(ob.yaw_rad), math.cos(ob.yaw_rad), 0.0])
    centre = np.array([ob.distance_m, 0.0, 0.0]) + ob.lateral_m * v_axis
    cam = spec.left_camera
    uv, _ = cv2.projectPoints(
        rig.T_yaw_camera.inverse().apply(centre[None]),
        np.zeros(3),
        np.zeros(3),
        cam.matrix,
        np.array(cam.distortion),
    )
    u, v = uv.reshape(2)
    w, h = spec.image_size
    assert 0 <= u < w and 0 <= v < h


def test_random_spec_overrides() -> None:
    rng = np.random.default_rng(0)
    spec = random_scene_spec(rng, kind="stairs", rise_m=0.2, n_steps=4, camera_height_m=0.6)
    assert spec.obstacle.rise_m == 0.2 and spec.obstacle.n_steps == 4
    assert spec.camera_height_m == 0.6
    kinds = {random_scene_spec(rng, image_size=(64, 48)).obstacle.__class__.__name__ for _ in range(30)}
    assert kinds == {"StairSpec", "BoxSpec", "NoneType"}


# ----------------------------------------------------------------- bad input


def _stairs(**kw) -> StairSpec:
    args = {"n_steps": 3, "rise_m": 0.17, "run_m": 0.29, "width_m": 1.0, "distance_m": 1.5}
    return StairSpec(**{**args, **kw})


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: _stairs(n_steps=0), "n_steps"),
        (lambda: _stairs(n_steps=2.5), "n_steps"),
        (lambda: _stairs(rise_m=-0.1), "rise_m"),
        (lambda: _stairs(run_m=float("nan")), "run_m"),
        (lambda: BoxSpec(0.2, 0.5, 0.0, 1.0), "width_m"),
        (lambda: SceneSpec(None, image_size=(0, 480)), "image_size"),
        (lambda: SceneSpec(None, image_size=(640,)), "image_size"),
        (lambda: SceneSpec(_stairs(), camera_height_m=-1.0), "camera_height_m"),
        (lambda: SceneSpec(_stairs(), back_wall_m=2.0), "back_wall_m"),
        (lambda: SceneSpec("stairs"), "obstacle"),
        (lambda: SceneSpec(None, supersample=0), "supersample"),
        (
            lambda: SceneSpec(None, left_camera=CameraIntrinsics(544, 544, 320, 240, (-0.6, 0, 0, 0, 0))),
            "not invertible",
        ),
        (lambda: random_scene_spec(np.random.default_rng(0), image_size=(0, 0)), "image_size"),
        (lambda: random_scene_spec(np.random.default_rng(0), kind="ramp"), "kind"),
        (lambda: random_scene_spec(np.random.default_rng(0), kind="box", n_steps=3), "unknown override"),
        (lambda: random_scene_spec(0), "Generator"),
        (lambda: render_scene({"obstacle": None}), "SceneSpec"),
        (lambda: render_scenes("/tmp/never", -1, seed=0), "count"),
    ],
)
def test_bad_input_raises_input_error(make, match: str) -> None:
    with pytest.raises(InputError, match=match):
        make()


def test_input_error_is_value_error() -> None:
    with pytest.raises(ValueError, match="rise_m must be > 0"):
        _stairs(rise_m=0.0)
