"""Tests of the renderer's realistic profile and the scene parts it added: side walls,
handrails, nosing, webcam sensor (JPEG, shot noise); and that the default profile is
unchanged."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stereo_terrain.cli import main
from stereo_terrain.errors import InputError
from stereo_terrain.frames import load_rig
from stereo_terrain.synthetic import (
    SceneSpec,
    StairSpec,
    SyntheticScene,
    random_scene_spec,
    render_scene,
    render_scenes,
)

TINY = (160, 120)
SMALL = (320, 240)
#: A labelled wall pixel's reconstructed point from its truth plane (float32 depth).
PLANE_TOL_M = 2e-3

#: SceneSpec fields of version 1, and digests of the specs the default profile drew
#: with them before the realistic profile existed (seed, image size, kind). Floats are
#: rounded to 9 digits: on a new machine image one exact digest changed with no code change.
_V1_FIELDS = (
    "obstacle,camera_height_m,pitch_down_rad,baseline_m,image_size,body_rpy,weak_texture,seed,"
    "left_camera,right_camera,right_rotvec_rad,right_offset_m,right_disturbance_rotvec_rad,"
    "back_wall_m,ground,tread,riser,side,wall,light_azimuth_rad,light_elevation_rad,ambient,"
    "diffuse,exposure,sky_grey,noise_sigma,right_gain,right_offset_grey,vignetting,"
    "blur_sigma_px,supersample"
).split(",")
_V1_DIGESTS = [
    (5, (320, 240), None, "268ea43eb7dd57af"),
    (11, (640, 480), None, "92e64676e65e24e7"),
    (3, (320, 240), "box", "7fcb6fdbf7f05e7e"),
    (4, (320, 240), "none", "7634b6212534d060"),
]


def _rounded(value: Any) -> Any:
    """Floats to 9 significant digits: the libm of another machine may differ in the last bit."""
    if isinstance(value, float):
        return float(f"{value:.9g}")
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_rounded(v) for v in value]
    return value


def _digest(spec: SceneSpec) -> str:
    d = {f: getattr(spec, f) for f in _V1_FIELDS}
    for k, v in d.items():
        if dataclasses.is_dataclass(v):
            d[k] = dataclasses.asdict(v)
    d = _rounded(d)
    return hashlib.sha256(json.dumps(d, sort_keys=True, default=list).encode()).hexdigest()[:16]


def _realistic(seed: int, size=TINY, **kw) -> SceneSpec:
    return random_scene_spec(np.random.default_rng(seed), image_size=size, profile="realistic", **kw)


def _walled_stairs(**kw) -> SceneSpec:
    stairs = StairSpec(n_steps=3, rise_m=0.17, run_m=0.3, width_m=1.0, distance_m=1.4, yaw_rad=0.15)
    b_mid = stairs.lateral_m - stairs.distance_m * math.sin(stairs.yaw_rad)
    values = {
        "obstacle": stairs,
        "camera_height_m": 0.5,
        "pitch_down_rad": math.radians(-4.0),
        "image_size": TINY,
        "left_wall_m": b_mid + 0.52,
        "right_wall_m": b_mid - 0.55,
        "side_wall_start_m": 0.0,
        "back_wall_m": 3.5,
        "handrails": ("left", "right"),
        "supersample": 1,
        **kw,
    }
    return SceneSpec(**values)


def _to_yaw(scene: SyntheticScene, vs: np.ndarray, us: np.ndarray) -> np.ndarray:
    cal = scene.calibration
    pts = np.column_stack([us, vs]).astype(np.float64).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)
    xy = cv2.undistortPoints(pts, cal.K1, cal.D1, criteria=crit).reshape(-1, 2)
    z = scene.depth_left[vs, us].astype(np.float64)
    return scene.rig.T_yaw_camera.apply(np.column_stack([xy * z[:, None], z]))


# ----------------------------------------------------------------- default profile unchanged


@pytest.mark.parametrize(("seed", "size", "kind", "digest"), _V1_DIGESTS)
def test_default_profile_draws_the_version_1_specs(seed, size, kind, digest) -> None:
    spec = random_scene_spec(np.random.default_rng(seed), image_size=size, kind=kind)
    assert _digest(spec) == digest
    again = random_scene_spec(np.random.default_rng(seed), image_size=size, kind=kind, profile="default")
    assert again == spec
    assert spec.profile == "default"
    assert spec.left_wall_m is None and spec.right_wall_m is None and spec.handrails == ()
    assert spec.jpeg_quality is None and spec.shot_noise == 0.0 and spec.nosing_m == 0.0


def test_unknown_profile_is_one_line_input_error() -> None:
    for call in (
        lambda: random_scene_spec(np.random.default_rng(0), profile="photo"),
        lambda: render_scenes("/nonexistent/never", 1, 0, profile="photo"),
    ):
        with pytest.raises(InputError, match="default, realistic") as exc:
            call()
        assert "\n" not in str(exc.value)


# ----------------------------------------------------------------- realistic specs


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1))
def test_realistic_specs_respect_their_ranges(seed: int) -> None:
    spec = _realistic(seed, size=(640, 480))
    assert spec.profile == "realistic"
    for cam in (spec.left_camera, spec.right_camera):
        assert 0.92 - 1e-9 <= cam.fy / cam.fx <= 1.0 + 1e-9
        k1, k2 = cam.distortion[:2]
        assert -0.45 <= k1 <= -0.1 and 0.0 <= k2 <= 0.45
        assert abs(cam.cx - 319.5) <= 11.0 and abs(cam.cy - 239.5) <= 11.0
    assert spec.left_camera != spec.right_camera
    assert spec.jpeg_quality is not None and all(60 <= q <= 85 for q in spec.jpeg_quality)
    assert 0.5 <= spec.blur_sigma_px <= 1.5 and 0.5 <= spec.right_blur_sigma_px <= 1.5
    assert spec.shot_noise > 0 and spec.vignetting > 0
    assert 0.25 <= spec.camera_height_m <= 0.7
    assert math.radians(-5.0) <= spec.pitch_down_rad <= math.radians(10.0)
    assert abs(spec.body_rpy[0]) <= math.radians(3.0)
    ob = spec.obstacle
    if ob is not None:
        assert 0.8 <= ob.distance_m <= 2.0
        assert abs(ob.yaw_rad) <= math.radians(45.0)
    if isinstance(ob, StairSpec):
        assert 2 <= ob.n_steps <= 6
        assert 0.12 <= ob.rise_m <= 0.22 and 0.22 <= ob.run_m <= 0.35
        assert spec.back_wall_m is not None
        walls = {"left": spec.left_wall_m, "right": spec.right_wall_m}
        if any(walls[side] is None for side in spec.handrails):
            assert spec.balusters  # no rail floats over an open side
    if ob is None:
        assert spec.left_wall_m is not None and spec.right_wall_m is not None


def test_realistic_profile_is_deterministic_and_mixes_kinds() -> None:
    assert _realistic(7) == _realistic(7)
    rng = np.random.default_rng(1)
    specs = [random_scene_spec(rng, image_size=TINY, profile="realistic") for _ in range(40)]
    kinds = [type(s.obstacle).__name__ for s in specs]
    assert kinds.count("StairSpec") >= 24 and "BoxSpec" in kinds and "NoneType" in kinds
    assert any(s.left_wall_m is not None or s.right_wall_m is not None for s in specs)
    assert any(s.handrails for s in specs) and any(s.nosing_m > 0 for s in specs)
    assert {s.tread.texture for s in specs} >= {"planks", "carpet"}
    assert any(s.riser.texture == "paint" for s in specs)


def test_some_realistic_stairs_fill_the_view() -> None:
    """With no floor in front: the first riser's foot is below the image."""
    from stereo_terrain.synthetic.random_scenes.realistic_profile import _below_view, _stairs_points

    rng = np.random.default_rng(2)
    specs = [random_scene_spec(rng, image_size=TINY, profile="realistic", kind="stairs") for _ in range(40)]
    fills = [s for s in specs if _below_view(s, _stairs_points(s.obstacle, floor_edge=True)[:1])]
    assert 2 <= len(fills) <= 20
    for s in fills:
        assert s.obstacle.distance_m <= 1.0


def test_realistic_overrides_and_kind() -> None:
    spec = _realistic(3, kind="stairs", n_steps=5, rise_m=0.2, jpeg_quality=(70, 70))
    assert spec.obstacle.n_steps == 5 and spec.obstacle.rise_m == 0.2 and spec.jpeg_quality == (70, 70)
    assert _realistic(3, kind="none").obstacle is None
    with pytest.raises(InputError, match="unknown override"):
        _realistic(3, kind="none", rise_m=0.2)


# ----------------------------------------------------------------- walls, rails: geometry and truth


@pytest.fixture(scope="module")
def walled() -> SyntheticScene:
    return render_scene(_walled_stairs(balusters=False))


def test_side_walls_are_truth_planes_never_steps(walled: SyntheticScene) -> None:
    truth = walled.truth
    names = [p["name"] for p in truth["planes"]]
    assert names[-2:] == ["left_wall", "right_wall"]
    assert len(truth["steps"]) == walled.spec.obstacle.n_steps
    assert truth["obstacle"] == "stairs" and truth["profile"] == "default"
    for name in ("left_wall", "right_wall"):
        i = names.index(name)
        plane = truth["planes"][i]
        assert plane["kind"] == "vertical"
        vs, us = np.nonzero(walled.labels_left == i)
        assert vs.size > 50, name
        p = _to_yaw(walled, vs, us)
        n = np.array(plane["normal"])
        assert np.abs(p @ n + plane["offset"]).max() < PLANE_TOL_M
        # The normal points toward the camera (the stairs between the walls).
        cam = np.array(truth["camera_center_yaw"])
        assert cam @ n + plane["offset"] > 0


def test_handrails_are_drawn_but_not_planes(walled: SyntheticScene) -> None:
    bare = render_scene(dataclasses.replace(walled.spec, handrails=()))
    changed = walled.left.astype(int) != bare.left.astype(int)
    assert np.count_nonzero(changed) > 30
    # Only where a rail is: the textures of everything else stay (their own random stream).
    rail = (walled.depth_left != bare.depth_left) & np.isfinite(bare.depth_left)
    grown = cv2.dilate(rail.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert not np.any(changed & ~grown)
    # Rail pixels are labelled -1 (not a listed plane) where the bare scene had a plane.
    newly_unlabelled = (walled.labels_left == -1) & (bare.labels_left >= 0)
    assert np.count_nonzero(newly_unlabelled) > 10


def test_balusters_stand_on_treads() -> None:
    stairs = StairSpec(n_steps=3, rise_m=0.17, run_m=0.3, width_m=1.0, distance_m=1.4)
    base = SceneSpec(stairs, image_size=TINY, pitch_down_rad=0.1, supersample=1, handrails=("left",))
    with_b = render_scene(dataclasses.replace(base, balusters=True))
    without = render_scene(base)
    assert np.count_nonzero(with_b.depth_left != without.depth_left) > 20


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"left_wall_m": 0.0}, "beside the obstacle"),
        ({"right_wall_m": 0.0}, "beside the obstacle"),
        ({"handrails": ("top",)}, "handrails"),
        ({"jpeg_quality": (50, 101)}, "jpeg_quality"),
        ({"jpeg_quality": 70}, "jpeg_quality"),
        ({"profile": "photo"}, "profile"),
        ({"nosing_m": -0.01}, "nosing_m"),
        ({"texture_origin_m": (0.0, float("nan"))}, "texture_origin_m"),
        ({"texture_origin_m": 1.0}, "texture_origin_m"),
        ({"noise_seed": -1}, "noise_seed"),
        ({"noise_seed": 1.5}, "noise_seed"),
    ],
)
def test_bad_new_fields_raise(fields, match) -> None:
    stairs = StairSpec(n_steps=2, rise_m=0.17, run_m=0.3, width_m=1.0, distance_m=1.4)
    with pytest.raises(InputError, match=match):
        SceneSpec(stairs, **fields)


def test_handrails_need_stairs_and_cameras_between_walls() -> None:
    with pytest.raises(InputError, match="StairSpec"):
        SceneSpec(None, handrails=("left",))
    spec = SceneSpec(None, image_size=TINY, left_wall_m=-0.3, right_wall_m=-1.0, side_wall_start_m=-2.0)
    with pytest.raises(InputError, match="outside the side walls"):
        render_scene(spec)


# ----------------------------------------------------------------- sensor and materials


def test_jpeg_and_shot_noise_change_the_images() -> None:
    spec = _walled_stairs(noise_sigma=(0.0, 0.0))
    clean = render_scene(spec)
    jpeg = render_scene(dataclasses.replace(spec, jpeg_quality=(60, 60)))
    diff = np.abs(jpeg.left.astype(int) - clean.left.astype(int))
    assert 0 < diff.mean() < 3.0
    assert np.array_equal(jpeg.depth_left, clean.depth_left, equal_nan=True)
    shot = render_scene(dataclasses.replace(spec, shot_noise=0.5))
    resid = shot.left.astype(float) - clean.left.astype(float)
    bright = clean.left > 120
    dark = clean.left < 60
    if bright.sum() > 100 and dark.sum() > 100:
        assert resid[bright].std() > resid[dark].std()
    assert resid.std() > 2.0


def test_nosing_darkens_tread_front_edges() -> None:
    spec = _walled_stairs(noise_sigma=(0.0, 0.0), handrails=())
    plain = render_scene(spec)
    nosed = render_scene(dataclasses.replace(spec, nosing_m=0.04, nosing_reflectance=0.3))
    darker = nosed.left.astype(int) < plain.left.astype(int) - 5
    assert np.count_nonzero(darker) > 30
    assert not np.any(nosed.left.astype(int) > plain.left.astype(int) + 1)


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_realistic_scene_renders_with_its_stairs_in_view(seed: int) -> None:
    spec = _realistic(seed, size=TINY, kind="stairs")
    scene = render_scene(dataclasses.replace(spec, supersample=1))
    names = [p["name"] for p in scene.truth["planes"]]
    assert np.any(scene.labels_left == names.index("riser_1"))
    tread_ids = [i for i, n in enumerate(names) if n.startswith("tread_")]
    assert np.isin(scene.labels_left, tread_ids).any()
    assert all(not n.endswith("_wall") for n in names[: 1 + 2 * spec.obstacle.n_steps])
    assert scene.truth["profile"] == "realistic"


# ----------------------------------------------------------------- command line


def test_cli_render_realistic_writes_scenes(tmp_path, capsys) -> None:
    argv = ["render", "--out", str(tmp_path), "--count", "2", "--seed", "4", "--size", "160x120"]
    code = main([*argv, "--profile", "realistic"])
    out = capsys.readouterr().out.split()
    assert code == 0 and len(out) == 2
    for d in out:
        truth = json.loads((tmp_path / d.split("/")[-1] / "truth.json").read_text())
        assert truth["profile"] == "realistic" and truth["image_size"] == [160, 120]
        assert {"obstacle", "steps", "yaw", "planes", "camera_height_m", "pitch_down_rad"} <= set(truth)
        rig = load_rig(tmp_path / d.split("/")[-1] / "rig.yaml")
        spec = truth["spec"]
        # The rig is the true mounting: the camera height and body roll/pitch of the spec.
        assert rig.T_yaw_camera.translation[2] == pytest.approx(truth["camera_center_yaw"][2], abs=1e-9)
        assert list(rig.body_rpy) == pytest.approx(spec["body_rpy"])
        assert rig.T_body_camera.translation[2] == pytest.approx(spec["camera_height_m"])


def test_cli_render_bad_profile_is_exit_2_one_line(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["render", "--out", str(tmp_path), "--profile", "photo"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "realistic" in err


def test_the_noise_seed_draws_other_noise_over_the_same_scene() -> None:
    stairs = StairSpec(n_steps=2, rise_m=0.17, run_m=0.3, width_m=1.0, distance_m=1.4)
    spec = SceneSpec(stairs, image_size=TINY, supersample=1, noise_sigma=(3.0, 3.0))
    a, b = render_scene(spec), render_scene(dataclasses.replace(spec, noise_seed=1))
    quiet = render_scene(dataclasses.replace(spec, noise_sigma=(0.0, 0.0)))
    assert np.array_equal(render_scene(spec).left, a.left)  # None: the scene's seed alone, as before
    diff = a.left.astype(int) - b.left.astype(int)
    assert np.count_nonzero(diff) > 0.5 * diff.size
    # the same scene under the noise: both noisy images scatter about the noise-free one alike
    for img in (a, b):
        assert abs(np.mean(img.left.astype(float) - quiet.left.astype(float))) < 0.5
