"""Speckle removal on the chosen disparities, with OpenCV's ``filterSpeckles``."""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

_INVALID_FIXED = -16  # "no disparity" in OpenCV's 4-bit fixed point


@njit(cache=True, nogil=True)
def _to_fixed_point(disp: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """Disparities in OpenCV's fixed point (int16, 1/16 px) for ``filterSpeckles``, NaN
    as ``_INVALID_FIXED`` (one compiled pass; NumPy's where/astype took 0.6 ms)."""
    fixed = np.empty(disp.shape, dtype=np.int16)
    for i in range(disp.shape[0]):
        for j in range(disp.shape[1]):
            v = disp[i, j]
            # (capped: a disparity of 2048 px or more does not fit OpenCV's fixed point)
            fixed[i, j] = np.int16(min(v * 16.0, 32767.0)) if np.isfinite(v) else _INVALID_FIXED
    return fixed


@njit(cache=True, nogil=True)
def _invalidate_where(disp: np.ndarray, fixed: np.ndarray) -> None:  # pragma: no cover - compiled
    """NaN wherever the speckle filter marked ``fixed`` invalid."""
    for i in range(disp.shape[0]):
        for j in range(disp.shape[1]):
            if fixed[i, j] == _INVALID_FIXED:
                disp[i, j] = np.nan


def remove_speckles(disp: np.ndarray, window_px: int, range_px: int) -> None:
    """NaN, in place, over each connected region of ``disp`` smaller than ``window_px``
    pixels whose neighbours differ by at most ``range_px`` (OpenCV's ``filterSpeckles``)."""
    fixed = _to_fixed_point(disp)
    cv2.filterSpeckles(fixed, _INVALID_FIXED, window_px, range_px * 16)
    _invalidate_where(disp, fixed)
