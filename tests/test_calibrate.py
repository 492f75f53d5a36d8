"""Checkerboard calibration: the real OpenCV chessboard set against OpenCV's reference,
the quality report, and one-line exit-2 errors for every bad input."""

from __future__ import annotations

import math
import shutil

import cv2
import numpy as np
import pytest

from stereo_terrain.calibrate import (
    BoardConfig,
    calibrate_from_globs,
    find_image_pairs,
    parse_pattern,
    quality_report,
    same_corner_order,
)
from stereo_terrain.calibration import read_calibration
from stereo_terrain.cli import main
from stereo_terrain.drift import DriftConfig, FeatureMatches, OnlineRectifier, check_matches, match_features
from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.rectify import compute_rectification, read_image, rectify, rectify_points

from . import board_views as bv
from .board_views import write_board_views

# OpenCV's reference left-camera result for this set (left_intrinsics.yml, 9x6, 0.025 m).
REF_F_PX, REF_CX, REF_CY = 535.916, 342.283, 235.571
FOCAL_TOL = 0.01  # the bound: 1 %
PP_TOL_PX = 3.0  # the bound on the principal point


@pytest.fixture(scope="module")
def board_dir(shared_data):
    d = shared_data / "calibration" / "opencv_chessboard_9x6"
    if not d.is_dir():
        pytest.skip(f"{d} is absent")
    return d


@pytest.fixture(scope="module")
def chessboard(board_dir):
    return calibrate_from_globs(
        str(board_dir / "left*.jpg"), str(board_dir / "right*.jpg"), BoardConfig(9, 6, 0.025)
    )


def test_real_chessboard_matches_the_opencv_reference(chessboard):
    K1 = chessboard.calibration.K1
    assert abs(K1[0, 0] - REF_F_PX) / REF_F_PX < FOCAL_TOL
    assert abs(K1[1, 1] - REF_F_PX) / REF_F_PX < FOCAL_TOL
    assert abs(K1[0, 2] - REF_CX) < PP_TOL_PX and abs(K1[1, 2] - REF_CY) < PP_TOL_PX
    q = chessboard.quality
    assert len(chessboard.views.names) == 13 and not chessboard.views.skipped
    # OpenCV's own run got 0.39 px on the left camera alone (aspect ratio fixed).
    assert 0.3 < q.rms_left_px < 0.5 and 0.3 < q.rms_px < 0.6
    assert q.per_view_rms_px.shape == (13, 2)
    # View 2 is the outlier of the reference run too (1.18 px there).
    assert q.worth_dropping == ("left02.jpg",)
    assert 0.07 < q.baseline_m < 0.1
    assert q.epipolar_median_px < 0.2
    assert 0.3 < q.coverage[0] < 0.7


def test_real_chessboard_rectifies_to_small_vertical_feature_disparity(chessboard, board_dir):
    rect = compute_rectification(chessboard.calibration)
    lefts, rights = [], []
    for lp, rp in find_image_pairs(str(board_dir / "left*.jpg"), str(board_dir / "right*.jpg")):
        m = match_features(rectify(read_image(lp), read_image(rp), rect))
        lefts.append(m.left)
        rights.append(m.right)
    pooled = FeatureMatches(np.concatenate(lefts), np.concatenate(rights))
    assert len(pooled) > 300
    dy = pooled.vertical_px
    assert abs(np.median(dy)) < 0.5 and np.median(np.abs(dy)) < 0.5  # the bound
    check = check_matches(pooled, rect)
    assert check.verdict == "ok", check


def test_cli_calibrate_writes_yaml_report_and_figure(board_dir, tmp_path, capsys, monkeypatch):
    import stereo_terrain.cli.outputs

    monkeypatch.setattr(
        stereo_terrain.cli.outputs, "is_terminal", lambda stream: True
    )  # progress drawn on a terminal only
    out, fig = tmp_path / "calib.yaml", tmp_path / "c.png"
    code = main(
        [
            "calibrate",
            "--left",
            str(board_dir / "left*.jpg"),
            "--right",
            str(board_dir / "right*.jpg"),
            "--pattern",
            "9x6",
            "--square",
            "0.025",
            "--out",
            str(out),
            "--figure",
            str(fig),
        ]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "13/13" in captured.err  # progress
    for words in ("RMS reprojection error", "worth dropping: left02.jpg", "coverage", "baseline", "epipolar"):
        assert words in captured.out
    calib = read_calibration(out)
    assert abs(calib.K1[0, 0] - REF_F_PX) / REF_F_PX < FOCAL_TOL
    assert fig.stat().st_size > 10_000


def test_quality_report_names_skipped_pairs(board_dir, tmp_path):
    for i in ("01", "03", "04", "06"):
        shutil.copy(board_dir / f"left{i}.jpg", tmp_path / f"left{i}.jpg")
        shutil.copy(board_dir / f"right{i}.jpg", tmp_path / f"right{i}.jpg")
    blank = np.full((480, 640), 128, np.uint8)
    cv2.imwrite(str(tmp_path / "right06.jpg"), blank)
    result = calibrate_from_globs(
        str(tmp_path / "left*.jpg"), str(tmp_path / "right*.jpg"), BoardConfig(9, 6, 0.025)
    )
    assert result.views.skipped == (("left06.jpg", "no 9x6 board in the right image"),)
    assert any("skipped left06.jpg" in line for line in quality_report(result))


# --------------------------------------------------------------------------- bad input


def _calibrate(capsys, left, right, *extra, pattern="9x6", square="0.025", out="unused.yaml"):
    code = main(
        ["calibrate", "--left", str(left), "--right", str(right), "--pattern", pattern, "--square", square]
        + ["--out", str(out), *map(str, extra)]
    )
    err = capsys.readouterr().err.strip().splitlines()
    return code, err[-1] if err else ""


def _one_line(code, last, *words):
    assert code == 2
    assert "Traceback" not in last
    for w in words:
        assert w in last, last


def _pairs(tmp_path, n, size=(640, 480), right_size=None, value=128):
    for i in range(n):
        cv2.imwrite(str(tmp_path / f"l{i}.png"), np.full(size[::-1], value, np.uint8))
        cv2.imwrite(str(tmp_path / f"r{i}.png"), np.full((right_size or size)[::-1], value, np.uint8))


def test_no_image_matches_the_glob(tmp_path, capsys):
    code, last = _calibrate(capsys, tmp_path / "nothing*.png", tmp_path / "r*.png")
    _one_line(code, last, "no left images match")


def test_no_corners_anywhere(tmp_path, capsys):
    _pairs(tmp_path, 2)
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png")
    _one_line(code, last, "no 9x6 checkerboard found", "--pattern")


def test_mismatched_counts(tmp_path, capsys):
    _pairs(tmp_path, 2)
    (tmp_path / "r1.png").unlink()
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png")
    _one_line(code, last, "2 left images but 1 right")


def test_mismatched_sizes(tmp_path, capsys):
    _pairs(tmp_path, 2, right_size=(320, 240))
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png")
    _one_line(code, last, "same size")


def test_pairs_of_different_sizes(tmp_path, capsys):
    _pairs(tmp_path, 1)
    cv2.imwrite(str(tmp_path / "l9.png"), np.zeros((240, 320), np.uint8))
    cv2.imwrite(str(tmp_path / "r9.png"), np.zeros((240, 320), np.uint8))
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png")
    _one_line(code, last, "one camera mode at a time")


@pytest.mark.parametrize(
    ("square", "words"),
    [("0", "positive"), ("-0.02", "positive"), ("nan", "positive"), ("25", "metres")],
)
def test_bad_square(tmp_path, capsys, square, words):
    _pairs(tmp_path, 1)
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png", square=square)
    _one_line(code, last, words)


@pytest.mark.parametrize(
    ("pattern", "words"), [("9by6", "COLSxROWS"), ("1x6", ">= 2"), ("6x6", "orientation")]
)
def test_bad_pattern(tmp_path, capsys, pattern, words):
    _pairs(tmp_path, 1)
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png", pattern=pattern)
    _one_line(code, last, words)


def test_too_few_good_pairs(board_dir, tmp_path, capsys):
    for i in ("01", "03"):
        shutil.copy(board_dir / f"left{i}.jpg", tmp_path / f"left{i}.jpg")
        shutil.copy(board_dir / f"right{i}.jpg", tmp_path / f"right{i}.jpg")
    code, last = _calibrate(capsys, tmp_path / "left*.jpg", tmp_path / "right*.jpg")
    _one_line(code, last, "only 2 pair(s)", "at least 3")


def test_library_errors_are_package_errors():
    with pytest.raises(InputError):
        parse_pattern("nine by six")
    with pytest.raises(ConfigError):
        BoardConfig(9, 6, 0.0)
    with pytest.raises(ConfigError):
        BoardConfig(9, True, 0.025)  # type: ignore[arg-type]
    obj = BoardConfig(9, 6, 0.025).object_points
    assert obj.shape == (54, 3) and np.isclose(obj[-1, 0], 8 * 0.025) and np.isclose(obj[-1, 1], 5 * 0.025)


def _square_size_error_mm(result, rect) -> float:
    """Mean |median triangulated square side - 25 mm| over the views, millimetres."""
    errors = []
    for cl, cr in zip(result.views.left, result.views.right, strict=True):
        pl, pr = rectify_points(cl, rect, "left"), rectify_points(cr, rect, "right")
        xyd = np.column_stack([pl, pl[:, 0] - pr[:, 0]]).reshape(-1, 1, 3)
        pts = cv2.perspectiveTransform(xyd, rect.Q).reshape(6, 9, 3)
        sides = np.r_[
            np.linalg.norm(np.diff(pts, axis=1), axis=2).ravel(),
            np.linalg.norm(np.diff(pts, axis=0), axis=2).ravel(),
        ]
        errors.append(abs(float(np.median(sides)) - 0.025))
    return 1000.0 * float(np.mean(errors))


def test_online_correction_does_not_spoil_a_good_real_calibration(chessboard, board_dir):
    """The guard on real images: run the online correction over the 13 real pairs and
    triangulate the boards; their 25 mm squares must stay as right as without it."""
    base = compute_rectification(chessboard.calibration)
    online = OnlineRectifier(base, DriftConfig(online=True, every_frames=1))
    for lp, rp in find_image_pairs(str(board_dir / "left*.jpg"), str(board_dir / "right*.jpg")):
        online.update(rectify(read_image(lp), read_image(rp), online.current))
    assert math.degrees(float(np.linalg.norm(online.correction_rotvec_rad))) < 0.1
    assert abs(online.correction_rotvec_rad[1]) < 1e-9  # no yaw from views that do not agree on one
    before = _square_size_error_mm(chessboard, base)
    after = _square_size_error_mm(chessboard, online.current)
    assert before < 0.1 and after < before + 0.02, (before, after)


def test_right_corners_labelled_from_the_other_end_are_reordered(chessboard):
    left, right = chessboard.views.left[0], chessboard.views.right[0]
    assert same_corner_order(left, right) is right
    assert np.array_equal(same_corner_order(left, right[::-1]), right)
    assert "median rectified epipolar error" in "\n".join(quality_report(chessboard))
    assert chessboard.quality.per_view_epipolar_px.shape == (13,)


def test_unwritable_outputs_fail_before_detection(tmp_path, capsys):
    _pairs(tmp_path, 1)
    code, last = _calibrate(capsys, tmp_path / "l*.png", tmp_path / "r*.png", out=tmp_path / "no" / "c.yaml")
    _one_line(code, last, "cannot write", "does not exist")
    code, last = _calibrate(
        capsys, tmp_path / "l*.png", tmp_path / "r*.png", "--figure", tmp_path / "no" / "f.png"
    )
    _one_line(code, last, "cannot write")


# --------------------------------------------------------------------------- rendered ground truth


@pytest.fixture(scope="module")
def rendered_boards(tmp_path_factory):
    out = tmp_path_factory.mktemp("boards")
    write_board_views(out, count=8, seed=0)
    return out


def test_rendered_boards_give_back_the_true_rig(rendered_boards):
    """Boards rendered through a known distorting rig: intrinsics, baseline and relative
    rotation come back (the real set has no reference extrinsics)."""
    result = calibrate_from_globs(
        str(rendered_boards / "left_*.png"),
        str(rendered_boards / "right_*.png"),
        BoardConfig(9, 6, bv.SQUARE_M),
    )
    c, q = result.calibration, result.quality
    assert len(result.views.names) >= 6
    for K, K_true in ((c.K1, bv.K_LEFT), (c.K2, bv.K_RIGHT)):
        assert np.allclose(np.diag(K)[:2], np.diag(K_true)[:2], rtol=0.003)
        assert np.allclose(K[:2, 2], K_true[:2, 2], atol=1.5)
    assert np.linalg.norm(c.T - bv.T_RIGHT) < 0.001  # metres
    rot_err_deg = np.degrees(np.linalg.norm(cv2.Rodrigues(c.R @ bv.R_RIGHT.T)[0]))
    assert rot_err_deg < 0.05
    assert q.rms_px < 0.2 and q.epipolar_median_px < 0.15


def test_duplicate_views_give_an_unusable_calibration_and_nothing_is_written(board_dir, tmp_path, capsys):
    """Four copies of one pair calibrate to nonsense: refused as one distinct view before the
    fit, and an existing calibration at --out is left as it was."""
    for i in range(4):
        shutil.copy(board_dir / "left01.jpg", tmp_path / f"left{i}.jpg")
        shutil.copy(board_dir / "right01.jpg", tmp_path / f"right{i}.jpg")
    out = tmp_path / "calib.yaml"
    out.write_text("previous calibration\n")
    args = ["--left", str(tmp_path / "left*.jpg"), "--right", str(tmp_path / "right*.jpg")]
    code = main(["calibrate", *args, "--pattern", "9x6", "--square", "0.025", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "distinct view" in err and err.count("\n") == 1
    assert out.read_text() == "previous calibration\n"


def test_calibrate_refuses_an_output_it_could_not_read_back(board_dir, tmp_path, capsys):
    args = ["--left", str(board_dir / "left*.jpg"), "--right", str(board_dir / "right*.jpg")]
    code = main(
        ["calibrate", *args, "--pattern", "9x6", "--square", "0.025", "--out", str(tmp_path / "c.json")]
    )
    assert code == 2 and ".yaml, .yml or .xml" in capsys.readouterr().err


def test_a_figure_that_cannot_be_written_leaves_no_calibration(
    rendered_boards, tmp_path, capsys, monkeypatch
):
    """Found in review: ``calibrate --out C --figure F`` whose figure failed (a full disk)
    left C written, a half-done command. Both or neither: nothing new, an older C as it
    was, no temporary file."""
    pytest.importorskip("matplotlib")
    import errno

    import stereo_terrain.viz.calibration as viz_calibration

    def fail(result, path):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(viz_calibration, "save_calibration_figure", fail)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    out, fig = out_dir / "calib.yaml", out_dir / "c.png"
    left, right = rendered_boards / "left_*.png", rendered_boards / "right_*.png"
    code, last = _calibrate(capsys, left, right, "--figure", fig, square=str(bv.SQUARE_M), out=out)
    _one_line(code, last, "cannot write", str(fig), "No space left")
    assert sorted(p.name for p in out_dir.iterdir()) == []
    out.write_text("previous calibration\n")
    code, last = _calibrate(capsys, left, right, "--figure", fig, square=str(bv.SQUARE_M), out=out)
    _one_line(code, last, "cannot write", str(fig))
    assert sorted(p.name for p in out_dir.iterdir()) == ["calib.yaml"]
    assert out.read_text() == "previous calibration\n"


def test_mistakes_that_looked_like_a_zero_baseline_are_named(tmp_path):
    """Both globs matching the same images, or a square side far below a millimetre, made
    a calibration whose baseline was zero, and the error said so; and a Middlebury
    calib.txt without its baseline line was called no calibration format at all."""
    for name in ("left01.png", "left02.png", "left03.png"):
        (tmp_path / name).write_bytes(b"not read")
    with pytest.raises(InputError, match="match the same files"):
        find_image_pairs(str(tmp_path / "left*.png"), str(tmp_path / "left*.png"))
    with pytest.raises(ConfigError, match="smaller than a millimetre"):
        BoardConfig(9, 6, 1e-6)
    assert BoardConfig(9, 6, 0.001).square_m == 0.001
    calib = tmp_path / "calib.txt"
    calib.write_text("cam0=[700 0 300; 0 700 200; 0 0 1]\ncam1=[700 0 310; 0 700 200; 0 0 1]\ndoffs=10\n"
                     "width=640\nheight=480\nndisp=64\n")  # fmt: skip
    with pytest.raises(InputError, match="lacks 'baseline'"):
        read_calibration(calib)
