"""Stage 0: checkerboard calibration of the stereo pair, with a quality report.

What ``stereo-terrain calibrate`` does: find the pairs of images (two globs, paired in
sorted order), detect the board's inner corners to sub-pixel in both images of each pair
(pairs where either side fails are skipped and named), calibrate each camera
(``calibrateCamera``, 5-coefficient distortion), then the pair (``stereoCalibrate`` from
those intrinsics, refining all of them), and measure how good the result is:

* RMS reprojection error overall and per view (left and right);
* the views worth dropping (per-view RMS more than ``drop_factor`` x the median view and
  ``drop_margin_px`` above it: usually a blurred or mis-detected board);
* coverage: the fraction of each image inside the union of the boards seen (corners near
  the edges are what pins the distortion down);
* the baseline;
* the rectified epipolar error: the corners of every pair rectified with the result, the
  rows of matching corners compared (0 for a perfect calibration).

The result is written as the OpenCV FileStorage YAML of ``docs/conventions.md``.
"""

from __future__ import annotations

import glob as globlib
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import cv2
import numpy as np

from .calibration import MAX_BASELINE_M, StereoCalibration
from .errors import CalibrationError, ConfigError, InputError
from .rectify import compute_rectification, read_image, rectify_points

log = logging.getLogger(__name__)

#: Fewer good pairs than this cannot pin down intrinsics, distortion and extrinsics.
MIN_VIEWS = 3


@dataclass(frozen=True)
class BoardConfig:
    """The checkerboard and how its corners are found.

    Attributes
    ----------
    cols, rows : int
        Inner corners along the board's width and height (a board of 10 x 7 squares has
        9 x 6 inner corners).
    square_m : float
        Side of one square, metres (sets the scale of ``T``).
    subpix_window_px : int
        Half-size of the ``cornerSubPix`` search window, pixels.
    drop_factor, drop_margin_px : float
        A view is worth dropping when its RMS exceeds ``drop_factor`` x the median view's
        and ``median + drop_margin_px``.
    """

    cols: int
    rows: int
    square_m: float
    subpix_window_px: int = 11
    drop_factor: float = 2.5
    drop_margin_px: float = 0.3

    def __post_init__(self) -> None:
        for name in ("cols", "rows"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 2:
                raise ConfigError(f"board {name} must be an integer >= 2 (inner corners), got {v!r}")
        if self.cols == self.rows:
            # A square board is ambiguous under a 90-degree turn: corners get mislabelled.
            raise ConfigError(
                f"board {self.cols}x{self.rows} has as many inner corners in both directions; use a "
                "board with different numbers (e.g. 9x6) so its orientation is unambiguous"
            )
        sq = self.square_m
        if isinstance(sq, bool) or not isinstance(sq, int | float) or not np.isfinite(sq) or sq <= 0:
            raise ConfigError(f"square size must be a positive number of metres, got {sq!r}")
        if sq > 1.0:
            raise ConfigError(
                f"square size {sq} m is larger than a metre; give it in metres (25 mm is 0.025)"
            )
        if sq < 1e-3:
            # Smaller than a printer draws; the baseline comes out at that scale, and the
            # calibration then says "baseline is zero", which points at the wrong mistake.
            raise ConfigError(
                f"square size {sq} m is smaller than a millimetre; give it in metres (25 mm is 0.025)"
            )
        if self.subpix_window_px < 1:
            raise ConfigError(f"subpix_window_px must be >= 1, got {self.subpix_window_px}")

    @property
    def pattern(self) -> tuple[int, int]:
        return (self.cols, self.rows)

    @property
    def object_points(self) -> np.ndarray:
        """(cols * rows, 3) float32, metres: the corners on the board plane z = 0, row-major."""
        obj = np.zeros((self.cols * self.rows, 3), np.float32)
        obj[:, :2] = np.mgrid[0 : self.cols, 0 : self.rows].T.reshape(-1, 2) * self.square_m
        return obj


def parse_pattern(text: str) -> tuple[int, int]:
    """``"9x6"`` -> ``(9, 6)``; :class:`InputError` otherwise."""
    try:
        cols, rows = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise InputError(f"pattern must be COLSxROWS of inner corners like 9x6, got '{text}'") from None
    return cols, rows


def find_image_pairs(left_glob: str, right_glob: str) -> list[tuple[Path, Path]]:
    """Pair the files matching two globs, in sorted order.

    Raises
    ------
    InputError
        If a glob matches no file, or the two match different numbers of files.
    """
    found = []
    for side, pattern in (("left", left_glob), ("right", right_glob)):
        paths = sorted(Path(p) for p in globlib.glob(str(pattern)) if Path(p).is_file())
        if not paths:
            raise InputError(
                f"no {side} images match '{pattern}'; quote the glob so the shell does not expand it, "
                "and check the folder"
            )
        found.append(paths)
    left, right = found
    if len(left) != len(right):
        extra = (left if len(left) > len(right) else right)[min(len(left), len(right))]
        raise InputError(
            f"{len(left)} left images but {len(right)} right images; every left image needs its right "
            f"partner (first unmatched in sorted order: {extra})"
        )
    same = [a for a, b in zip(left, right, strict=True) if a.resolve() == b.resolve()]
    if same:
        raise InputError(
            f"the left and right globs match the same files (first: {same[0]}); give each camera's "
            "images, e.g. --left 'left*.png' --right 'right*.png'"
        )
    return list(zip(left, right, strict=True))


def detect_corners(image: np.ndarray, board: BoardConfig) -> np.ndarray | None:
    """Sub-pixel inner corners of the board in a grey image.

    Returns
    -------
    (cols * rows, 2) float32 pixels in the board's row-major order, or None when the whole
    board is not found.
    """
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
    found, corners = cv2.findChessboardCorners(image, board.pattern, flags=flags)
    if not found:
        # FAST_CHECK can reject a board in poor light; one slower try without it.
        found, corners = cv2.findChessboardCorners(
            image, board.pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        )
    if not found:
        return None
    win = board.subpix_window_px
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    corners = cv2.cornerSubPix(image, corners, (win, win), (-1, -1), criteria)
    return np.asarray(corners, dtype=np.float32).reshape(-1, 2)


def same_corner_order(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """``right``'s corners in the order of ``left``'s.

    A board with an odd and an even number of inner corners still has a 180-degree
    ambiguity: ``findChessboardCorners`` may start from opposite corners in the two
    images, and a stereo calibration of mislabelled corners is garbage. Side-by-side
    cameras see the board turned the same way, so the first-to-last-corner diagonals must
    point the same way; if they do not, the right corners are reversed.

    Parameters
    ----------
    left, right : (N, 2) float32, pixels
    """
    if float(np.dot(left[-1] - left[0], right[-1] - right[0])) < 0.0:
        return np.ascontiguousarray(right[::-1])
    return right


@dataclass(frozen=True)
class BoardViews:
    """Corners found in the pairs where both sides saw the whole board.

    Attributes
    ----------
    names : tuple of str
        One name per kept pair (the left file's name).
    left, right : (V, cols * rows, 2) float32, raw pixels
    image_size : (width, height), pixels
    skipped : tuple of (name, reason)
        Pairs left out and why.
    """

    names: tuple[str, ...]
    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    image_size: tuple[int, int]
    skipped: tuple[tuple[str, str], ...] = ()


def detect_board_views(
    pairs: Sequence[tuple[Path, Path]],
    board: BoardConfig,
    *,
    progress: Callable[[int, int, str, str | None], None] | None = None,
) -> BoardViews:
    """Detect the board in every pair; skip (and name) pairs where either side fails.

    Parameters
    ----------
    pairs : sequence of (left path, right path)
    board : BoardConfig
    progress : callable, optional
        Called after each pair as ``progress(done, total, name, reason)``; ``reason`` is
        None for a kept pair, else why it was skipped.

    Raises
    ------
    InputError
        If the two images of a pair, or two pairs, differ in size; if an image cannot be
        read; if no pair has the board on both sides.
    """
    size: tuple[int, int] | None = None
    names, lefts, rights, skipped = [], [], [], []
    for i, (lp, rp) in enumerate(pairs):
        left, right = read_image(lp), read_image(rp)
        if left.shape != right.shape:
            raise InputError(
                f"{lp.name} is {left.shape[1]}x{left.shape[0]} but {rp.name} is "
                f"{right.shape[1]}x{right.shape[0]}; both cameras must capture at the same size"
            )
        this = (left.shape[1], left.shape[0])
        if size is None:
            size = this
        elif this != size:
            raise InputError(
                f"{lp.name} is {this[0]}x{this[1]} but the first pair is {size[0]}x{size[1]}; calibrate "
                "one camera mode at a time"
            )
        cl, cr = detect_corners(left, board), detect_corners(right, board)
        reason = None
        if cl is None or cr is None:
            sides = [s for s, c in (("left", cl), ("right", cr)) if c is None]
            reason = f"no {board.cols}x{board.rows} board in the {' and '.join(sides)} image"
            skipped.append((lp.name, reason))
        else:
            names.append(lp.name)
            lefts.append(cl)
            rights.append(same_corner_order(cl, cr))
        if progress is not None:
            progress(i + 1, len(pairs), lp.name, reason)
    if not names:
        raise InputError(
            f"no {board.cols}x{board.rows} checkerboard found on both sides of any of the {len(pairs)} "
            "pairs; check --pattern (inner corners, COLSxROWS: a board of 10x7 squares has 9x6) and "
            "the images"
        )
    return BoardViews(
        tuple(names), np.stack(lefts), np.stack(rights), cast(tuple[int, int], size), tuple(skipped)
    )


# A calibration whose own board corners, rectified, are further apart vertically than this
# (RMS) is unusable: the reference chessboard set gives 0.26 px.
MAX_EPIPOLAR_RMS_PX = 2.0


@dataclass(frozen=True)
class CalibrationQuality:
    """How good a checkerboard calibration is.

    Attributes
    ----------
    rms_px : float
        Overall RMS reprojection error of the stereo calibration, pixels.
    rms_left_px, rms_right_px : float
        RMS reprojection error of each camera calibrated alone, pixels.
    per_view_rms_px : (V, 2) float64
        RMS reprojection error of every view, left and right camera, pixels.
    worth_dropping : tuple of str
        Names of views whose error (worse camera) exceeds ``drop_limit_px``.
    drop_limit_px : float
        ``max(drop_factor * median, median + drop_margin_px)`` of the views' worse-camera
        RMS (see :class:`BoardConfig`).
    coverage : (2,) float64
        Fraction of the left and right image inside the union of the boards seen.
    baseline_m : float
    epipolar_median_px, epipolar_rms_px, epipolar_max_px : float
        ``|y_left - y_right|`` of the corners after rectification with the result, pixels.
    per_view_epipolar_px : (V,) float64
        Median ``|y_left - y_right|`` of each view's rectified corners, pixels.
    """

    rms_px: float
    rms_left_px: float
    rms_right_px: float
    per_view_rms_px: np.ndarray = field(repr=False)
    worth_dropping: tuple[str, ...]
    drop_limit_px: float
    coverage: np.ndarray = field(repr=False)
    baseline_m: float
    epipolar_median_px: float
    epipolar_rms_px: float
    epipolar_max_px: float
    per_view_epipolar_px: np.ndarray = field(repr=False)

    @property
    def usable(self) -> bool:
        """Whether the rectified corners line up (RMS of ``|y_left - y_right|`` within
        :data:`MAX_EPIPOLAR_RMS_PX`); duplicate or too similar views give hundreds of px."""
        return bool(self.epipolar_rms_px <= MAX_EPIPOLAR_RMS_PX)  # NaN: not usable


@dataclass(frozen=True)
class CheckerboardCalibration:
    """A stereo calibration from checkerboard views, with its quality and its evidence.

    Attributes
    ----------
    calibration : StereoCalibration
    quality : CalibrationQuality
    views : BoardViews
    board : BoardConfig
    """

    calibration: StereoCalibration
    quality: CalibrationQuality
    views: BoardViews = field(repr=False)
    board: BoardConfig


#: Two views whose corners are all closer than this (pixels, both cameras) are one view.
DUPLICATE_VIEW_PX = 1.0


def _distinct_views(views: BoardViews) -> list[int]:
    """Indices of the views that are not copies of an earlier one (same board pose: every
    corner within :data:`DUPLICATE_VIEW_PX` on both sides). Copies add no information but
    weigh the fit toward one pose, which biases the baseline."""
    kept: list[int] = []
    for i in range(len(views.names)):
        if not any(
            np.max(np.abs(views.left[i] - views.left[j])) < DUPLICATE_VIEW_PX
            and np.max(np.abs(views.right[i] - views.right[j])) < DUPLICATE_VIEW_PX
            for j in kept
        ):
            kept.append(i)
    return kept


def calibrate_stereo(views: BoardViews, board: BoardConfig) -> CheckerboardCalibration:
    """Calibrate both cameras and the pair from detected board views.

    Raises
    ------
    CalibrationError
        With fewer than :data:`MIN_VIEWS` views, or when OpenCV fails or returns a rig
        this package cannot use (baseline not horizontal, zero or over 2 m).
    """
    n = len(views.names)
    if n < MIN_VIEWS:
        raise CalibrationError(
            f"only {n} pair(s) show the whole board on both sides; need at least {MIN_VIEWS} "
            "(better 10-20, tilted and spread over the image)"
        )
    distinct = _distinct_views(views)
    if len(distinct) < MIN_VIEWS:
        copies = [name for i, name in enumerate(views.names) if i not in distinct]
        raise CalibrationError(
            f"only {len(distinct)} distinct view(s) of the board among {n} pairs "
            f"({', '.join(copies[:4])}{' ...' if len(copies) > 4 else ''} repeat an earlier view); "
            f"need at least {MIN_VIEWS} different poses of the board (better 10-20)"
        )
    obj = [board.object_points] * n
    il = [c.reshape(-1, 1, 2) for c in views.left]
    ir = [c.reshape(-1, 1, 2) for c in views.right]
    size = views.image_size
    try:
        # Each camera alone first (a good start), then the pair refining everything.
        rms_l, K1, D1, *_ = cv2.calibrateCameraExtended(obj, il, size, np.eye(3), np.zeros(5))
        rms_r, K2, D2, *_ = cv2.calibrateCameraExtended(obj, ir, size, np.eye(3), np.zeros(5))
        out = cv2.stereoCalibrateExtended(
            obj, il, ir, K1, D1, K2, D2, size, np.eye(3), np.zeros(3), flags=cv2.CALIB_USE_INTRINSIC_GUESS
        )
    except cv2.error as exc:
        first = str(exc.err).strip().splitlines()[0] if str(exc.err).strip() else "unknown error"
        raise CalibrationError(f"OpenCV calibration failed: {first}") from None
    rms, K1, D1, K2, D2, R, T = out[:7]
    per_view = np.asarray(out[-1], dtype=np.float64).reshape(n, 2)
    T = np.asarray(T, dtype=np.float64).reshape(3)
    baseline = float(np.linalg.norm(T))
    if not 0 < baseline <= MAX_BASELINE_M:
        raise CalibrationError(
            f"calibrated baseline is {baseline:.3g} m; check --square (metres) and that the globs give "
            "the left and the right camera"
        )
    calib = StereoCalibration(K1, D1.ravel(), K2, D2.ravel(), R, T, size, source="checkerboard calibration")
    rect = compute_rectification(calib)
    pl = rectify_points(views.left.reshape(-1, 2), rect, "left")
    pr = rectify_points(views.right.reshape(-1, 2), rect, "right")
    dy = np.abs(pl[:, 1] - pr[:, 1])
    limit = _drop_limit_px(per_view, board)
    quality = CalibrationQuality(
        float(rms),
        float(rms_l),
        float(rms_r),
        per_view,
        tuple(name for name, e in zip(views.names, per_view.max(axis=1), strict=True) if e > limit),
        limit,
        np.array([_coverage(views.left, size), _coverage(views.right, size)]),
        baseline,
        float(np.median(dy)),
        float(np.sqrt(np.mean(dy**2))),
        float(np.max(dy)),
        np.median(dy.reshape(n, -1), axis=1),
    )
    return CheckerboardCalibration(calib, quality, views, board)


def _drop_limit_px(per_view: np.ndarray, board: BoardConfig) -> float:
    med = float(np.median(per_view.max(axis=1)))
    return max(board.drop_factor * med, med + board.drop_margin_px)


def _coverage(corners: np.ndarray, size: tuple[int, int], scale: int = 4) -> float:
    """Fraction of the image inside the union of the boards' outlines (rasterised at 1/scale)."""
    w, h = size
    mask = np.zeros(((h + scale - 1) // scale, (w + scale - 1) // scale), np.uint8)
    for view in corners:
        hull = cv2.convexHull((view / scale).astype(np.float32)).astype(np.int32)
        cv2.fillConvexPoly(mask, hull, 1)
    return float(mask.mean())


def calibrate_from_globs(
    left_glob: str,
    right_glob: str,
    board: BoardConfig,
    *,
    progress: Callable[[int, int, str, str | None], None] | None = None,
) -> CheckerboardCalibration:
    """:func:`find_image_pairs` + :func:`detect_board_views` + :func:`calibrate_stereo`."""
    pairs = find_image_pairs(left_glob, right_glob)
    views = detect_board_views(pairs, board, progress=progress)
    return calibrate_stereo(views, board)


def quality_report(result: CheckerboardCalibration) -> list[str]:
    """The quality report as lines of text (what ``stereo-terrain calibrate`` prints)."""
    q, c, v = result.quality, result.calibration, result.views
    lines = [
        f"pairs used: {len(v.names)}, skipped: {len(v.skipped)}",
        *(f"  skipped {name}: {why}" for name, why in v.skipped),
        f"RMS reprojection error: stereo {q.rms_px:.3f} px (left alone {q.rms_left_px:.3f}, "
        f"right alone {q.rms_right_px:.3f})",
        "per view: RMS reprojection error left, right; median rectified epipolar error (px)",
    ]
    dropped = set(q.worth_dropping)
    for name, (el, er), ee in zip(v.names, q.per_view_rms_px, q.per_view_epipolar_px, strict=True):
        mark = "   <- worth dropping" if name in dropped else ""
        lines.append(f"  {name:<24} {el:6.3f} {er:6.3f}   {ee:6.3f}{mark}")
    lines.append("views worth dropping: " + (", ".join(q.worth_dropping) if q.worth_dropping else "none"))
    lines.append(
        f"coverage of the image by the boards: left {q.coverage[0]:.0%}, right {q.coverage[1]:.0%}"
        + ("  (low: show the board near the edges and corners too)" if q.coverage.min() < 0.5 else "")
    )
    for name, K, D in (("left", c.K1, c.D1), ("right", c.K2, c.D2)):
        lines.append(
            f"{name} camera: fx {K[0, 0]:.2f} fy {K[1, 1]:.2f} cx {K[0, 2]:.2f} cy {K[1, 2]:.2f} px, "
            f"distortion {np.array2string(D, precision=4, separator=', ')}"
        )
    angle = float(np.degrees(np.linalg.norm(cv2.Rodrigues(c.R)[0])))
    lines.append(f"baseline: {q.baseline_m * 1000:.1f} mm, relative rotation {angle:.2f} deg")
    lines.append(
        f"rectified epipolar error of the corners: median {q.epipolar_median_px:.3f} px, "
        f"RMS {q.epipolar_rms_px:.3f} px, max {q.epipolar_max_px:.3f} px"
    )
    return lines
