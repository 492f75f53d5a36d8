"""Stage 1: load and check a stereo pair, rectify it from the calibration.

Rectification uses OpenCV (``stereoRectify`` + ``initUndistortRectifyMap``); the maps are
computed once per calibration and cached in a :class:`Rectification`. Already rectified
calibrations (Middlebury, OAK-D) pass images through untouched.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .calibration import StereoCalibration
from .errors import CalibrationError, InputError
from .frames import Transform


@dataclass(frozen=True)
class Rectification:
    """Everything needed to rectify a pair and to reproject its disparities.

    Attributes
    ----------
    calibration : StereoCalibration
    focal_px : float
        Focal length of the rectified left camera, pixels.
    cx, cy : float
        Principal point of the rectified left camera, pixels.
    baseline_m : float
    doffs_px : float
        ``cx_right - cx_left`` of the rectified pair (0 unless already rectified that way);
        depth is ``Z = focal_px * baseline_m / (d + doffs_px)``.
    Q : (4, 4) float64
        OpenCV reprojection matrix.
    T_camera_rect : Transform
        Rectified left camera (``camera_rect``) to the raw left camera (``camera``).
    valid_roi : (x, y, w, h)
        Region of the rectified left image where every pixel has a source pixel.
    maps : 4 arrays or None
        ``initUndistortRectifyMap`` maps of the left and right cameras (None: pass-through).
    R1, R2 : (3, 3) float64 or None
        Rotations raw camera -> rectified camera (``stereoRectify``'s ``R1, R2``; ``R2``
        includes ``right_correction``). None when the calibration is already rectified.
    P1, P2 : (3, 4) float64 or None
        Projection matrices of the rectified cameras.
    right_correction : (3, 3) float64 or None
        Rotation applied to the rectified right camera on top of the calibration (online
        drift correction, :mod:`stereo_terrain.drift`); None for none.
    """

    calibration: StereoCalibration
    focal_px: float
    cx: float
    cy: float
    baseline_m: float
    doffs_px: float
    Q: np.ndarray = field(repr=False)
    T_camera_rect: Transform = field(repr=False)
    valid_roi: tuple[int, int, int, int]
    maps: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = field(default=None, repr=False)
    R1: np.ndarray | None = field(default=None, repr=False)
    R2: np.ndarray | None = field(default=None, repr=False)
    P1: np.ndarray | None = field(default=None, repr=False)
    P2: np.ndarray | None = field(default=None, repr=False)
    right_correction: np.ndarray | None = field(default=None, repr=False)

    @property
    def image_size(self) -> tuple[int, int]:
        return self.calibration.image_size

    def depth_from_disparity(self, disparity: np.ndarray) -> np.ndarray:
        """Depth Z in metres (NaN where disparity is NaN or non-positive after doffs)."""
        denom = disparity.astype(np.float32) + np.float32(self.doffs_px)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.float32(self.focal_px * self.baseline_m) / denom
        z[~(denom > 0)] = np.nan
        return z


def compute_rectification(
    calib: StereoCalibration, *, alpha: float = 0.0, right_correction: np.ndarray | None = None
) -> Rectification:
    """Build (and cache the maps of) the rectification for ``calib``.

    Parameters
    ----------
    alpha : float
        OpenCV free-scaling parameter: 0 keeps only valid pixels (default), 1 keeps all.
    right_correction : (3, 3) float64, optional
        A small rotation applied to the rectified right camera after ``stereoRectify``
        (``R2 <- right_correction @ R2``): undoes a rotation of the right camera that
        happened since calibration (:mod:`stereo_terrain.drift`). The left camera, ``Q``
        and ``T_camera_rect`` do not change, so depth and frames stay those of the
        calibration.
    """
    w, h = calib.image_size
    if calib.rectified and right_correction is not None:
        raise CalibrationError(
            "a rectification correction needs the raw calibration (K, D, R, T); this one is of "
            "images that were rectified elsewhere"
        )
    if calib.rectified:
        K1 = calib.K1
        f = float(K1[0, 0])
        cx, cy = float(K1[0, 2]), float(K1[1, 2])
        doffs = float(calib.K2[0, 2] - K1[0, 2])
        b = calib.baseline_m
        Q_rect = np.array(
            [[1, 0, 0, -cx], [0, 1, 0, -cy], [0, 0, 0, f], [0, 0, 1.0 / b, doffs / b]], dtype=np.float64
        )
        return Rectification(
            calib, f, cx, cy, b, doffs, Q_rect, Transform(np.eye(4), "camera", "camera_rect"), (0, 0, w, h)
        )
    try:
        R1, R2, P1, P2, Q, roi1, _roi2 = cv2.stereoRectify(
            calib.K1,
            calib.D1,
            calib.K2,
            calib.D2,
            (w, h),
            calib.R,
            calib.T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY,
            alpha=alpha,
        )
    except cv2.error as exc:
        first = str(exc.err).strip().splitlines()[0] if str(exc.err).strip() else "unknown error"
        raise CalibrationError(f"stereoRectify failed on this calibration: {first}") from None
    if abs(P2[0, 3]) < 1e-9 or abs(P2[1, 3]) > 1e-6 * abs(P2[0, 3]) + 1e-9:
        raise CalibrationError(
            "calibration baseline is not horizontal; this pipeline needs a side-by-side pair "
            "(right camera along +x of the left)"
        )
    if right_correction is not None:
        R2 = np.asarray(right_correction, dtype=np.float64).reshape(3, 3) @ R2
    m1x, m1y = cv2.initUndistortRectifyMap(calib.K1, calib.D1, R1, P1, (w, h), cv2.CV_16SC2)
    m2x, m2y = cv2.initUndistortRectifyMap(calib.K2, calib.D2, R2, P2, (w, h), cv2.CV_16SC2)
    f = float(P1[0, 0])
    baseline = float(-P2[0, 3] / P2[0, 0])
    if baseline <= 0:
        raise CalibrationError(
            "right camera is to the left of the left camera (T[0] > 0); swap the images or the "
            "calibration's cameras"
        )
    T_camera_rect = Transform.from_rt(R1.T, np.zeros(3), "camera", "camera_rect")
    roi: tuple[int, int, int, int] = (int(roi1[0]), int(roi1[1]), int(roi1[2]), int(roi1[3]))
    if roi[2] <= 0 or roi[3] <= 0:
        roi = (0, 0, w, h)
    return Rectification(
        calib,
        f,
        float(P1[0, 2]),
        float(P1[1, 2]),
        baseline,
        float(P2[0, 2] - P1[0, 2]),
        Q,
        T_camera_rect,
        roi,
        (m1x, m1y, m2x, m2y),  # type: ignore[arg-type]
        R1,
        R2,
        P1,
        P2,
        None if right_correction is None else np.asarray(right_correction, dtype=np.float64).reshape(3, 3),
    )


def rectify_points(points: np.ndarray, rectification: Rectification, side: str) -> np.ndarray:
    """Raw pixel positions -> rectified pixel positions (undistorted, rotated, reprojected).

    Parameters
    ----------
    points : (N, 2) float, pixels of the raw ``side`` image
    rectification : Rectification
    side : ``"left"`` or ``"right"``

    Returns
    -------
    (N, 2) float64, pixels of the rectified ``side`` image.
    """
    if side not in ("left", "right"):
        raise InputError(f"side must be 'left' or 'right', got {side!r}")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 1, 2)
    calib = rectification.calibration
    if side == "left":
        K, D, R, P = calib.K1, calib.D1, rectification.R1, rectification.P1
    else:
        K, D, R, P = calib.K2, calib.D2, rectification.R2, rectification.P2
    if R is None or P is None:  # already rectified: pixels pass through
        return pts.reshape(-1, 2).copy()
    # The iterative variant with a tight criterion: the default 5 iterations leave ~0.1 px
    # at the corners of a wide-angle lens, as large as the errors being measured.
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-10)
    out = cv2.undistortPoints(pts, K, D, R=R, P=P, criteria=criteria)
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)


@dataclass(frozen=True)
class RectifiedPair:
    """A rectified grey stereo pair.

    Attributes
    ----------
    left, right : (H, W) uint8
        Rectified grey images; epipolar lines are image rows.
    rectification : Rectification
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    rectification: Rectification


def to_grey(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Convert a uint8/uint16 grey, BGR or BGRA image to (H, W) uint8 grey."""
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 3 and img.shape[2] in (3, 4):
        code = cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        img = cv2.cvtColor(img, code)
    if img.ndim != 2:
        raise InputError(f"{name} must be a grey or BGR image, got array of shape {img.shape}")
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    elif img.dtype != np.uint8:
        raise InputError(f"{name} must be uint8 or uint16, got {img.dtype}")
    return img


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as (H, W) uint8 grey; :class:`InputError` if missing/unreadable."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path} is a folder, not an image file")
    if not path.is_file():
        raise InputError(f"image not found: {path}")
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None or img.size == 0:
        raise InputError(f"cannot decode image {path}: not a PNG/JPEG/PPM/... image or corrupt")
    return to_grey(img, name=str(path))


def check_same_size(left: np.ndarray, right: np.ndarray) -> None:
    """Raise :class:`InputError` unless the two images have the same width and height (what
    has fewer than two dimensions is left to the checks that read the images)."""
    ls, rs = np.shape(left), np.shape(right)
    if len(ls) >= 2 and len(rs) >= 2 and ls[:2] != rs[:2]:
        raise InputError(
            f"left image {ls[1]}x{ls[0]} and right image {rs[1]}x{rs[0]} differ in size; "
            "give a pair from the same rig"
        )


def check_pair(left: np.ndarray, right: np.ndarray, calib: StereoCalibration) -> None:
    """Raise :class:`InputError` unless both (grey) images match each other and the
    calibration."""
    check_same_size(left, right)
    h, w = left.shape[:2]
    if (w, h) != calib.image_size:
        raise InputError(
            f"images are {w}x{h} but the calibration is for {calib.width}x{calib.height}; "
            "use the calibration of this camera mode or resize the images"
        )


def rectify(left: np.ndarray, right: np.ndarray, rectification: Rectification) -> RectifiedPair:
    """Rectify a raw pair.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) uint8
        Raw images from the calibrated cameras (BGR is converted to grey).

    Returns
    -------
    RectifiedPair with (H, W) uint8 images, same size as the input.
    """
    left = to_grey(left, "left image")
    right = to_grey(right, "right image")
    check_pair(left, right, rectification.calibration)
    if rectification.maps is None:
        return RectifiedPair(left, right, rectification)
    m1x, m1y, m2x, m2y = rectification.maps
    lr = cv2.remap(left, m1x, m1y, cv2.INTER_LINEAR)
    rr = cv2.remap(right, m2x, m2y, cv2.INTER_LINEAR)
    return RectifiedPair(lr, rr, rectification)
