"""Stereo calibration: the value object and its file formats.

Formats read (see ``docs/conventions.md``):

* OpenCV FileStorage YAML/XML with ``K1, D1, K2, D2, R, T, image_width, image_height``
  (``X_right = R X_left + T``, T in metres) -- what ``cv2.stereoCalibrate`` users keep.
* Middlebury 2014 ``calib.txt`` (already rectified; baseline in mm), tolerant of the
  irregular spacing of the originals.
* stereodemo's ``stereodemo_calibration.json`` (already rectified; the OAK-D scenes).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .checks import MAX_NESTING, nesting_depth, read_text_file
from .errors import CalibrationError, InputError

#: A longer baseline is taken for a unit mistake (millimetres instead of metres).
MAX_BASELINE_M = 2.0

#: Focal lengths outside this range (pixels) are not of a camera: a unit or file mistake.
FOCAL_RANGE_PX = (1.0, 1.0e6)

#: Largest image side accepted, pixels.
MAX_IMAGE_SIDE_PX = 65536

#: Calibration files are small; a larger one is not a calibration.
MAX_CALIBRATION_BYTES = 4 << 20


def _as_count(value: object, what: str) -> int:
    """A positive whole number from a file (``image_width: .inf`` and 640.5 refused)."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v != int(v) or not 0 < v <= MAX_IMAGE_SIDE_PX:
        raise CalibrationError(
            f"{what} must be a positive whole number (at most {MAX_IMAGE_SIDE_PX}), got {value!r}"
        )
    return int(v)


def _read_text(path: Path, what: str = "calibration file") -> str:
    """The whole file as UTF-8 text; :class:`InputError` when it is not."""
    return read_text_file(path, what, max_bytes=MAX_CALIBRATION_BYTES)


@dataclass(frozen=True)
class StereoCalibration:
    """Intrinsics and extrinsics of a stereo pair.

    Attributes
    ----------
    K1, K2 : (3, 3) float64
        Camera matrices of the left and right cameras, pixels.
    D1, D2 : (N,) float64
        OpenCV distortion coefficients (N in 4, 5, 8, 12, 14).
    R : (3, 3) float64
        Rotation of the right camera from the left: ``X_right = R X_left + T``.
    T : (3,) float64, metres
    image_size : (width, height) in pixels
    rectified : bool
        True when the images are already rectified (Middlebury, OAK-D): no remapping.
    ndisp : int or None
        Disparity range suggested by the file (Middlebury ``ndisp``).
    """

    K1: np.ndarray = field(repr=False)
    D1: np.ndarray = field(repr=False)
    K2: np.ndarray = field(repr=False)
    D2: np.ndarray = field(repr=False)
    R: np.ndarray = field(repr=False)
    T: np.ndarray = field(repr=False)
    image_size: tuple[int, int]
    rectified: bool = False
    ndisp: int | None = None
    source: str = ""

    def __post_init__(self) -> None:
        arrays = {
            "K1": (self.K1, (3, 3)),
            "K2": (self.K2, (3, 3)),
            "R": (self.R, (3, 3)),
            "T": (self.T, (3,)),
            "D1": (self.D1, None),
            "D2": (self.D2, None),
        }
        where = f" in {self.source}" if self.source else ""
        for name, (value, shape) in arrays.items():
            try:
                a = np.array(value, dtype=np.float64)
            except (TypeError, ValueError, OverflowError):
                raise CalibrationError(f"calibration{where}: {name} is not numeric") from None
            if shape is None:
                a = a.reshape(-1)
                if a.size not in (4, 5, 8, 12, 14):
                    raise CalibrationError(
                        f"calibration{where}: {name} must have 4, 5, 8, 12 or 14 distortion "
                        f"coefficients, got {a.size}"
                    )
            else:
                if a.size != int(np.prod(shape)):
                    raise CalibrationError(
                        f"calibration{where}: {name} must have shape {shape}, got {a.shape}"
                    )
                a = a.reshape(shape)
            if not np.all(np.isfinite(a)):
                raise CalibrationError(
                    f"calibration{where}: {name} has non-finite values (NaN or inf); recalibrate "
                    "or fix the file"
                )
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        for name in ("K1", "K2"):
            k = getattr(self, name)
            if k[0, 0] <= 0 or k[1, 1] <= 0 or not np.allclose(k[2], [0, 0, 1]):
                raise CalibrationError(
                    f"calibration{where}: {name} is not a camera matrix (need fx, fy > 0 and "
                    f"last row [0, 0, 1]), got {k.tolist()}"
                )
            lo, hi = FOCAL_RANGE_PX
            if not (lo <= k[0, 0] <= hi and lo <= k[1, 1] <= hi):
                raise CalibrationError(
                    f"calibration{where}: {name} focal lengths fx={k[0, 0]:.6g}, fy={k[1, 1]:.6g} px are "
                    f"outside [{lo:g}, {hi:g}] px; K must be in pixels"
                )
            if np.any(np.abs(k[:2, 2]) > 10 * MAX_IMAGE_SIDE_PX) or abs(k[0, 1]) > hi:
                raise CalibrationError(f"calibration{where}: {name} has an absurd principal point or skew")
        for name in ("D1", "D2"):
            if np.any(np.abs(getattr(self, name)) > 1e6):
                raise CalibrationError(f"calibration{where}: {name} has absurd distortion coefficients")
        r = self.R
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or np.linalg.det(r) < 0.5:
            raise CalibrationError(f"calibration{where}: R is not a rotation matrix")
        if np.linalg.norm(self.T) < 1e-4:
            raise CalibrationError(f"calibration{where}: baseline |T| is zero; T must be in metres")
        if np.linalg.norm(self.T) > MAX_BASELINE_M:
            raise CalibrationError(
                f"calibration{where}: baseline |T| = {np.linalg.norm(self.T):.3g} looks like millimetres; "
                "T must be in metres (docs/conventions.md)"
            )
        try:
            w_in, h_in = self.image_size
        except (TypeError, ValueError):
            raise CalibrationError(f"calibration{where}: image_size must be (width, height)") from None
        w = _as_count(w_in, f"calibration{where}: image width")
        h = _as_count(h_in, f"calibration{where}: image height")
        object.__setattr__(self, "image_size", (w, h))
        if self.ndisp is not None:
            object.__setattr__(self, "ndisp", _as_count(self.ndisp, f"calibration{where}: ndisp"))

    @property
    def baseline_m(self) -> float:
        return float(np.linalg.norm(self.T))

    @property
    def width(self) -> int:
        return self.image_size[0]

    @property
    def height(self) -> int:
        return self.image_size[1]


def read_calibration(path: str | Path) -> StereoCalibration:
    """Read a calibration file of any supported format (chosen from name and content)."""
    path = Path(path)
    text = _read_text(path)  # (missing, a folder, a pipe: read_text_file says which)
    if not text.strip():
        raise CalibrationError(f"calibration file {path} is empty")
    if _MB_KEY.search(text):
        # (its reader names a missing key, such as the baseline line)
        return read_middlebury_calib(path)
    if path.suffix.lower() == ".json" or text.lstrip().startswith(("{", "[")):
        return read_stereodemo_json(path)
    return read_opencv_yaml(path)


# A Middlebury key at the start of a line (not "cam0" inside a YAML comment or value).
_MB_KEY = re.compile(r"^\s*cam0\s*=", re.MULTILINE)


def read_opencv_yaml(path: str | Path) -> StereoCalibration:
    """Read an OpenCV FileStorage (YAML or XML) stereo calibration."""
    path = Path(path)
    text = _read_text(path)
    if nesting_depth(text) > MAX_NESTING:
        raise CalibrationError(f"calibration file {path} nests brackets deeper than {MAX_NESTING} levels")
    try:
        # From the text, not the path: OpenCV's own open crashes the process on a file name
        # that is not UTF-8 (Python hands it a str with surrogate escapes).
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError):  # OpenCV's parser raises SystemError on garbage
        raise CalibrationError(
            f"calibration file {path} is not OpenCV FileStorage YAML/XML (nor Middlebury calib.txt "
            "or stereodemo JSON)"
        ) from None
    if not fs.isOpened():
        raise CalibrationError(f"calibration file {path} could not be opened as OpenCV YAML/XML")
    try:
        if not fs.root().isMap():
            raise CalibrationError(
                f"calibration file {path}: the top level must be a mapping of K1, D1, K2, D2, R, T, "
                "image_width, image_height"
            )
        values: dict[str, np.ndarray] = {}
        for key in ("K1", "D1", "K2", "D2", "R", "T"):
            node = fs.getNode(key)
            if node.empty():
                raise CalibrationError(
                    f"calibration file {path} lacks '{key}'; expected K1, D1, K2, D2, R, T, "
                    "image_width, image_height (see docs/conventions.md)"
                )
            values[key] = _read_matrix(node, key, path)
        size = []
        for key in ("image_width", "image_height"):
            node = fs.getNode(key)
            if node.empty():
                raise CalibrationError(f"calibration file {path} lacks '{key}'")
            if not (node.isInt() or node.isReal()):
                raise CalibrationError(f"calibration file {path}: '{key}' must be a number")
            size.append(_as_count(node.real(), f"calibration file {path}: '{key}'"))
    except cv2.error:
        raise CalibrationError(
            f"calibration file {path} is not a readable OpenCV YAML/XML calibration"
        ) from None
    finally:
        fs.release()
    return StereoCalibration(
        values["K1"],
        values["D1"],
        values["K2"],
        values["D2"],
        values["R"],
        values["T"].reshape(-1),
        (size[0], size[1]),
        source=str(path),
    )


def _read_matrix(node, key: str, path: Path) -> np.ndarray:
    """An ``!!opencv-matrix`` or a plain sequence of numbers; CalibrationError otherwise."""
    try:
        if node.isMap():
            mat = node.mat()
        elif node.isSeq():
            items = [node.at(i) for i in range(node.size())]
            if not all(it.isInt() or it.isReal() for it in items):
                raise CalibrationError(f"calibration file {path}: '{key}' must contain only numbers")
            mat = np.array([it.real() for it in items])
        else:
            raise CalibrationError(f"calibration file {path}: '{key}' must be a matrix or a list of numbers")
    except cv2.error:
        raise CalibrationError(f"calibration file {path}: '{key}' is not a readable matrix") from None
    if mat is None:
        raise CalibrationError(f"calibration file {path}: '{key}' is not a readable matrix")
    return np.asarray(mat, dtype=np.float64)


def write_opencv_yaml(calib: StereoCalibration, path: str | Path) -> None:
    """Write ``calib`` as OpenCV FileStorage YAML, or XML for a ``.xml`` path (readable by
    :func:`read_opencv_yaml`)."""
    path = Path(path)
    # Composed in memory and written by Python: OpenCV's own open crashes the process on a
    # file name that is not UTF-8.
    kind = ".xml" if path.suffix.lower() == ".xml" else ".yaml"
    fs = cv2.FileStorage(kind, cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    try:
        fs.write("image_width", int(calib.width))
        fs.write("image_height", int(calib.height))
        fs.write("K1", np.ascontiguousarray(calib.K1))
        fs.write("D1", np.ascontiguousarray(calib.D1.reshape(1, -1)))
        fs.write("K2", np.ascontiguousarray(calib.K2))
        fs.write("D2", np.ascontiguousarray(calib.D2.reshape(1, -1)))
        fs.write("R", np.ascontiguousarray(calib.R))
        fs.write("T", np.ascontiguousarray(calib.T.reshape(3, 1)))
    finally:
        text = fs.releaseAndGetString()
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot write calibration to {path}: {exc.strerror}") from None


_MB_MATRIX = re.compile(r"(cam[01])\s*=\s*\[([^\]]*)\]")
_MB_SCALAR = re.compile(r"(\w+)\s*=\s*(\S+)")


def read_middlebury_calib(path: str | Path) -> StereoCalibration:
    """Read a Middlebury 2014 ``calib.txt`` (rectified pair; baseline in millimetres).

    Whitespace is free: ``cam0=[ 713.1 0 356.0 ; 0 713.1 238.2 ; 0 0 1 ]`` and keys spread
    over lines with leading blanks are accepted. ``doffs`` is the x-offset of the right
    principal point, carried by ``K2[0, 2] - K1[0, 2]``.
    """
    path = Path(path)
    text = _read_text(path)
    mats: dict[str, np.ndarray] = {}
    for name, body in _MB_MATRIX.findall(text):
        try:
            nums = [float(v) for v in body.replace(";", " ").split()]
        except ValueError:
            raise CalibrationError(f"{path}: {name} is not a 3x3 matrix of numbers") from None
        if len(nums) != 9:
            raise CalibrationError(f"{path}: {name} must have 9 numbers, got {len(nums)}")
        mats[name] = np.array(nums).reshape(3, 3)
    text_wo = _MB_MATRIX.sub("", text)
    scalars: dict[str, float] = {}
    for k, v in _MB_SCALAR.findall(text_wo):
        try:
            scalars[k] = float(v)
        except ValueError:
            raise CalibrationError(f"{path}: '{k}' must be a number, got '{v}'") from None
        if not math.isfinite(scalars[k]):
            raise CalibrationError(f"{path}: '{k}' must be a finite number, got '{v}'")
    for key in ("baseline", "width", "height"):
        if key not in scalars:
            raise CalibrationError(f"{path}: Middlebury calib.txt lacks '{key}'")
    for key in ("cam0", "cam1"):
        if key not in mats:
            raise CalibrationError(f"{path}: Middlebury calib.txt lacks '{key}'")
    K1, K2 = mats["cam0"], mats["cam1"]
    if "doffs" in scalars and abs((K2[0, 2] - K1[0, 2]) - scalars["doffs"]) > 0.05:
        raise CalibrationError(
            f"{path}: doffs={scalars['doffs']} disagrees with cam1.cx - cam0.cx = {K2[0, 2] - K1[0, 2]:.3f}"
        )
    baseline_m = scalars["baseline"] / 1000.0
    if baseline_m <= 0:
        raise CalibrationError(f"{path}: baseline must be positive (millimetres), got {scalars['baseline']}")
    ndisp = _as_count(scalars["ndisp"], f"{path}: 'ndisp'") if "ndisp" in scalars else None
    return StereoCalibration(
        K1,
        np.zeros(5),
        K2,
        np.zeros(5),
        np.eye(3),
        np.array([-baseline_m, 0.0, 0.0]),
        (_as_count(scalars["width"], f"{path}: 'width'"), _as_count(scalars["height"], f"{path}: 'height'")),
        rectified=True,
        ndisp=ndisp,
        source=str(path),
    )


def read_stereodemo_json(path: str | Path) -> StereoCalibration:
    """Read stereodemo's ``stereodemo_calibration.json`` (rectified pair, metres)."""
    path = Path(path)
    text = _read_text(path)
    if nesting_depth(text) > MAX_NESTING:
        raise CalibrationError(f"{path}: JSON nests brackets deeper than {MAX_NESTING} levels")
    try:
        d = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        raise CalibrationError(f"{path}: not valid JSON") from None
    if not isinstance(d, dict):
        raise CalibrationError(
            f"{path}: a stereodemo calibration must be a JSON object, got {type(d).__name__}"
        )
    try:
        if any(isinstance(d[k], bool) for k in ("fx", "fy", "cx0", "cx1", "cy", "baseline_meters")):
            raise TypeError  # JSON true is no focal length (Python's float(True) is 1.0)
        fx, fy = float(d["fx"]), float(d["fy"])
        cx0, cx1, cy = float(d["cx0"]), float(d["cx1"]), float(d["cy"])
        baseline = float(d["baseline_meters"])
        size = (d["width"], d["height"])
    except KeyError as exc:
        raise CalibrationError(f"{path}: stereodemo calibration lacks {exc}") from None
    except (TypeError, ValueError, OverflowError):
        raise CalibrationError(f"{path}: stereodemo calibration has non-numeric values") from None
    if not all(math.isfinite(v) for v in (fx, fy, cx0, cx1, cy, baseline)):
        raise CalibrationError(f"{path}: stereodemo calibration has non-finite values (NaN or Infinity)")
    if isinstance(size[0], bool) or isinstance(size[1], bool):
        raise CalibrationError(f"{path}: width and height must be numbers")
    if baseline <= 0:
        raise CalibrationError(f"{path}: baseline_meters must be positive, got {baseline}")
    K1 = np.array([[fx, 0, cx0], [0, fy, cy], [0, 0, 1]])
    K2 = np.array([[fx, 0, cx1], [0, fy, cy], [0, 0, 1]])
    return StereoCalibration(
        K1,
        np.zeros(5),
        K2,
        np.zeros(5),
        np.eye(3),
        np.array([-baseline, 0.0, 0.0]),
        size,
        rectified=True,
        source=str(path),
    )
