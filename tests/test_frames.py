import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereo_terrain.errors import FrameError, InputError
from stereo_terrain.frames import (
    R_BODY_OPTICAL,
    Rig,
    Transform,
    camera_mount,
    load_rig,
    rotation_from_rpy,
    save_rig,
    yaw_from_body,
)

angles = st.floats(-np.pi, np.pi, allow_nan=False)
coords = st.floats(-10, 10, allow_nan=False)


def _T(r, p, y, t, to="a", frm="b"):
    return Transform.from_rt(rotation_from_rpy(r, p, y), t, to, frm)


@given(angles, angles, angles, st.tuples(coords, coords, coords))
def test_inverse_round_trip(r, p, y, t):
    T = _T(r, p, y, t)
    assert np.allclose((T.inverse() @ T).matrix, np.eye(4), atol=1e-9)
    assert (T @ T.inverse()).to_frame == "a"


@given(angles, angles, angles, st.tuples(coords, coords, coords), st.tuples(coords, coords, coords))
def test_apply_matches_matrix_and_preserves_distances(r, p, y, t, q):
    T = _T(r, p, y, t)
    pts = np.array([q, [0.0, 0.0, 0.0]])
    out = T.apply(pts)
    hom = (T.matrix @ np.c_[pts, np.ones(2)].T).T[:, :3]
    assert np.allclose(out, hom, atol=1e-9)
    assert np.isclose(np.linalg.norm(out[0] - out[1]), np.linalg.norm(pts[0] - pts[1]), atol=1e-9)


def test_compose_refuses_frames_that_do_not_chain():
    a = Transform.identity("x")
    b = Transform(np.eye(4), "body", "camera")
    with pytest.raises(FrameError, match="does not chain"):
        a @ b


def test_non_rigid_matrix_rejected():
    m = np.eye(4)
    m[0, 0] = 2.0
    with pytest.raises(FrameError, match="rotation"):
        Transform(m, "body", "camera")
    with pytest.raises(FrameError, match="4x4"):
        Transform(np.eye(3), "body", "camera")
    m = np.eye(4)
    m[1, 1] = np.nan
    with pytest.raises(FrameError, match="non-finite"):
        Transform(m, "body", "camera")


def test_level_camera_axes():
    T = camera_mount(0.5, 0.0)
    # optical z (forward) is body x, optical y (down) is body -z
    assert np.allclose(T.apply_vectors(np.array([0.0, 0.0, 1.0])), [1, 0, 0])
    assert np.allclose(T.apply_vectors(np.array([0.0, 1.0, 0.0])), [0, 0, -1])
    assert np.allclose(T.translation, [0, 0, 0.5])
    assert np.allclose(R_BODY_OPTICAL @ R_BODY_OPTICAL.T, np.eye(3))


def test_pitched_down_camera_looks_at_the_ground():
    T = camera_mount(0.5, np.radians(30))
    axis = T.apply_vectors(np.array([0.0, 0.0, 1.0]))
    assert axis[2] < 0 and np.isclose(np.degrees(np.arcsin(-axis[2])), 30)


@given(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5))
def test_yaw_frame_removes_roll_and_pitch(roll, pitch):
    R_world_body = rotation_from_rpy(roll, pitch, 0.3)
    up_in_body = R_world_body.T @ np.array([0.0, 0.0, 1.0])
    up_in_yaw = yaw_from_body(roll, pitch).apply_vectors(up_in_body)
    assert np.allclose(up_in_yaw, [0, 0, 1], atol=1e-9)


def test_rig_round_trip(tmp_path):
    rig = Rig(camera_mount(0.6, 0.2), (0.01, -0.02, 0.3))
    save_rig(rig, tmp_path / "rig.yaml")
    back = load_rig(tmp_path / "rig.yaml")
    assert np.allclose(back.T_body_camera.matrix, rig.T_body_camera.matrix)
    assert np.allclose(back.body_rpy, rig.body_rpy)


@pytest.mark.parametrize(
    "text, match",
    [
        ("T_body_camera: [[1, 0], [0, 1]]", "4x4"),
        ("T_body_camera: [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]", "rotation"),
        ("foo: 1", "T_body_camera"),
        ("T_body_camera: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\nbody_rpy: [1, 2]", "body_rpy"),
        ("{[", "YAML"),
        # a misspelt key would otherwise leave the body level, silently
        ("T_body_camera: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\nbody_rpy_deg: [0, 2, 0]", "body_rpy_deg"),
        # a key given twice: YAML keeps the last silently
        ("T_body_camera: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\nbody_rpy: []\nbody_rpy: []", "twice"),
    ],
)
def test_bad_rig_files(tmp_path, text, match):
    path = tmp_path / "rig.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        load_rig(path)


def test_missing_rig_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_rig(tmp_path / "nope.yaml")


@given(angles, angles, angles, st.tuples(coords, coords, coords), angles, st.tuples(coords, coords, coords))
def test_products_and_inverses_are_what_a_checked_construction_gives(r, p, y, t, r2, t2):
    """Issue 13: products and inverses skip the rigidity check; they are the transforms the
    checked constructor builds from the same matrix (equal, read-only, rigid)."""
    A, B = _T(r, p, y, t, "a", "b"), _T(r2, 0.3, -r2, t2, "b", "c")
    for got in (A @ B, A.inverse(), (A @ B).inverse()):
        checked = Transform(got.matrix, got.to_frame, got.from_frame)  # raises if not rigid
        assert (got.to_frame, got.from_frame) == (checked.to_frame, checked.from_frame)
        assert got.matrix.tobytes() == checked.matrix.tobytes()
        assert got.matrix.dtype == np.float64 and not got.matrix.flags.writeable
    assert (A @ B).name == "T_a_c" and A.inverse().name == "T_b_a"
