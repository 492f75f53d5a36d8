"""Disparity files: Middlebury PFM (float32, rows bottom to top, invalid = inf), NumPy
``.npy`` (float32, NaN invalid) and 16-bit PNG (disparity x 256, 0 invalid, KITTI style)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..rectify import write_image

#: Largest PFM accepted (values); the header is checked against it and the file size
#: before anything is allocated.
MAX_PFM_VALUES = 1 << 28


def read_pfm(path: str | Path) -> np.ndarray:
    """Read a grey PFM as (H, W) float32 in top-to-bottom row order; inf/NaN stay as is.

    :class:`InputError` for a missing file, a colour (``PF``) or malformed header, zero,
    negative or huge dimensions, a zero or non-finite scale, or fewer values than the
    header claims.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path} is a folder, not a PFM file")
    try:
        with path.open("rb") as f:
            kind = f.readline(16).strip()
            if kind != b"Pf":
                raise InputError(f"{path}: not a grey PFM (header {kind[:10]!r}, expected b'Pf')")
            dims = f.readline(64).split()
            scale_line = f.readline(64)
            try:
                w, h = (int(v) for v in dims)
                scale = float(scale_line)
            except (ValueError, UnicodeDecodeError):
                raise InputError(
                    f"{path}: malformed PFM header (need 'Pf', 'WIDTH HEIGHT', 'SCALE')"
                ) from None
            if not (0 < w and 0 < h and w * h <= MAX_PFM_VALUES):
                raise InputError(
                    f"{path}: PFM dimensions {w}x{h} must be positive and at most {MAX_PFM_VALUES} values"
                )
            if not (math.isfinite(scale) and scale != 0):
                raise InputError(f"{path}: PFM scale must be a non-zero finite number, got {scale}")
            start = f.tell()
            size = f.seek(0, 2)
            if size - start < 4 * w * h:
                raise InputError(f"{path}: PFM truncated ({(size - start) // 4} of {w * h} values)")
            f.seek(start)
            data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4", count=w * h)
    except FileNotFoundError:
        raise InputError(f"disparity file not found: {path}") from None
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror}") from None
    if data.size != w * h:
        raise InputError(f"{path}: PFM truncated ({data.size} of {w * h} values)")
    return np.flipud(data.reshape(h, w)).astype(np.float32)


def write_pfm(path: str | Path, disparity: np.ndarray) -> None:
    """Write (H, W) float32 as Middlebury writes it: little endian, rows bottom to top,
    invalid (NaN) as inf."""
    d = np.asarray(disparity, dtype=np.float32)
    if d.ndim != 2:
        raise InputError(f"disparity must be (H, W), got {d.shape}")
    out = np.where(np.isfinite(d), d, np.inf).astype("<f4")
    h, w = d.shape
    with Path(path).open("wb") as f:
        f.write(b"Pf\n" + f"{w} {h}\n".encode() + b"-1.0\n")
        f.write(np.flipud(out).tobytes())


def write_disparity(path: str | Path, disparity: np.ndarray) -> None:
    """Write by extension: ``.pfm``, ``.npy`` or ``.png`` (uint16, disparity x 256, 0 invalid)."""
    path = Path(path)
    ext = path.suffix.lower()
    try:
        if ext == ".pfm":
            write_pfm(path, disparity)
        elif ext == ".npy":
            np.save(path, disparity.astype(np.float32))
        elif ext == ".png":
            d = np.where(np.isfinite(disparity), np.clip(disparity * 256.0, 1, 65535), 0).astype(np.uint16)
            write_image(path, d)
        else:
            raise InputError(f"unknown disparity file type '{ext}'; use .pfm, .npy or .png")
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror}") from None
