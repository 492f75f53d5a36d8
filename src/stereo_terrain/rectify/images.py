"""Stereo images read, written and checked: grey uint8 from any 8- or 16-bit file
(:func:`read_image`, :func:`to_grey`), a pair's sizes against each other and the
calibration (:func:`check_pair`)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..calibration import StereoCalibration
from ..errors import InputError

#: Images with more pixels are refused before they are decoded (a file whose header claims
#: 50000x50000 would otherwise allocate gigabytes): 64 megapixels, far above any webcam.
MAX_IMAGE_PIXELS = 1 << 26

#: An image file larger than this is refused before it is read (8 bytes a pixel of the
#: largest image accepted, with room for a header).
_MAX_IMAGE_BYTES = 8 * MAX_IMAGE_PIXELS + (1 << 20)

# What libjpeg and libpng print for a file they could only partly decode.
_CORRUPT_MARKERS = ("Premature end of JPEG", "Corrupt JPEG", "libpng error", "JPEG datastream", "Bogus")


def to_grey(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Convert a uint8/uint16 grey, grey+alpha, BGR or BGRA image to (H, W) uint8 grey.

    Alpha is dropped; 16-bit images keep their top 8 bits. Other sample types (float,
    signed) raise :class:`InputError`: their range is unknown.
    """
    img = np.asarray(image)
    if img.dtype not in (np.uint8, np.uint16):
        raise InputError(
            f"{name} must have 8- or 16-bit unsigned samples (uint8 or uint16), got {img.dtype} "
            "(save it as an 8- or 16-bit PNG)"
        )
    if img.ndim == 3 and img.shape[2] in (1, 2):  # grey, grey + alpha
        img = img[:, :, 0]
    if img.ndim == 3 and img.shape[2] in (3, 4):
        code = cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        img = cv2.cvtColor(np.ascontiguousarray(img), code)
    if img.ndim != 2 or img.size == 0:
        raise InputError(f"{name} must be a grey or colour image, got an array of shape {img.shape}")
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    return img


def _header_size(path: Path) -> tuple[int, int] | None:
    """(width, height) claimed by a PNG or JPEG header, None for other or unparsable files."""
    try:
        with path.open("rb") as f:
            head = f.read(24)
            if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
                return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
            if head[:2] != b"\xff\xd8":
                return None
            f.seek(2)
            for _ in range(1000):  # markers up to the first start-of-frame
                marker = f.read(2)
                if len(marker) < 2 or marker[0] != 0xFF:
                    return None
                if marker[1] in (0xD8, 0x01) or 0xD0 <= marker[1] <= 0xD7:
                    continue
                length = int.from_bytes(f.read(2), "big")
                if 0xC0 <= marker[1] <= 0xCF and marker[1] not in (0xC4, 0xC8, 0xCC):
                    body = f.read(5)
                    if len(body) < 5:
                        return None
                    return int.from_bytes(body[3:5], "big"), int.from_bytes(body[1:3], "big")
                if length < 2:
                    return None
                f.seek(length - 2, 1)
    except OSError:
        return None
    return None


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as (H, W) uint8 grey; :class:`InputError` if missing/unreadable.

    8- and 16-bit grey, grey+alpha, colour and colour+alpha images are accepted. A file
    whose header claims more than :data:`MAX_IMAGE_PIXELS`, one that does not decode, or
    one that libjpeg/libpng could only partly decode (truncated or corrupt) is refused;
    what those libraries print goes into the message, never to the terminal.
    """
    from ..checks import check_input_file
    from ..native import captured_native_stderr

    path = Path(path)
    check_input_file(path, "image")
    size = _header_size(path)
    if size is not None and size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise InputError(
            f"image {path} claims {size[0]}x{size[1]} pixels, more than {MAX_IMAGE_PIXELS} "
            "(a corrupt file or a decompression bomb)"
        )
    if size is not None and size[0] * size[1] == 0:
        raise InputError(f"cannot decode image {path}: its header says {size[0]}x{size[1]} pixels")
    if path.stat().st_size > _MAX_IMAGE_BYTES:
        raise InputError(f"image {path} is larger than {_MAX_IMAGE_BYTES >> 20} MiB")
    try:
        # Decoded from its bytes, not opened by OpenCV: imread crashes the process on a
        # file name that is not UTF-8 (Python hands it a str with surrogate escapes).
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise InputError(f"cannot read image {path}: {exc.strerror}") from None
    img = None
    try:
        with captured_native_stderr() as native:
            img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    except cv2.error:
        img = None
    problems = [
        line
        for line in native.lines()
        if any(m in line for m in _CORRUPT_MARKERS) and "extraneous bytes" not in line  # benign in MJPEG
    ]
    if img is None or img.size == 0:
        why = f" ({problems[0]})" if problems else ""
        raise InputError(f"cannot decode image {path}: not a PNG/JPEG/PPM/... image or corrupt{why}")
    if problems:
        raise InputError(f"image {path} is truncated or corrupt: {problems[0]}")
    return to_grey(img, name=f"image {path}")


def write_image(path: str | Path, image: np.ndarray) -> None:
    """Write ``image`` in the format of ``path``'s extension (``.png``, ``.jpg``, ...);
    :class:`InputError` when it cannot be encoded or written. Encoded by OpenCV and
    written by Python: OpenCV's own imwrite crashes the process on a file name that is not
    UTF-8."""
    path = Path(path)
    ext = path.suffix or ".png"
    try:
        ok, buf = cv2.imencode(ext, np.ascontiguousarray(image))
    except cv2.error:
        ok = False
    if not ok:
        raise InputError(f"cannot write {path}: OpenCV cannot encode a {ext} image of this type")
    try:
        path.write_bytes(buf.tobytes())
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror}") from None


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
