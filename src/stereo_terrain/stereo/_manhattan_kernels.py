"""The Manhattan fill's per-pixel pass in one compiled loop (see :mod:`.manhattan`).

A face's pixels (tens of thousands on a wall) each need their line coordinate, the
nearest support interval and the plane's disparity: about fifteen NumPy passes over the
face, which made the fill cost 25-60 ms a frame on realistic scenes. One loop does it.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def fill_face(
    ext: np.ndarray,
    x0: int,
    y0: int,
    s: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    normal: np.ndarray,
    line_dir: np.ndarray,
    camera: np.ndarray,
    x_ref: float,
    reach: float,
    max_disparity: float,
    out: np.ndarray,
    mask: np.ndarray,
    face_of: np.ndarray,
    face_base: int,
) -> None:  # pragma: no cover - compiled
    """Fill the pixels of ``ext`` (a box at ``x0, y0``) with the plane of normal ``normal``
    whose support interval of lines (``lo[j]..hi[j]``, distance ``s[j]``) is nearest to the
    pixel's line along ``line_dir``, when within ``reach``; ``camera`` = (f, cx, cy,
    doffs). Writes ``out`` (disparity), ``mask`` and ``face_of`` (``face_base + j``) where
    the value is in ``(0, max_disparity)``."""
    f, cx, cy, doffs = camera[0], camera[1], camera[2], camera[3]
    h, w = ext.shape
    for yy in range(h):
        for xx in range(w):
            if not ext[yy, xx]:
                continue
            u = np.float64(xx + x0)
            v = np.float64(yy + y0)
            du = f * line_dir[0] - (u - cx) * line_dir[2]
            dv = f * line_dir[1] - (v - cy) * line_dir[2]
            if abs(du) < 1e-9:
                du = 1e-9
            lam = v + (x_ref - u) * (dv / du)
            best, best_gap = -1, np.inf
            for j in range(s.shape[0]):
                gap = max(0.0, max(lo[j] - lam, lam - hi[j]))
                if gap < best_gap:
                    best, best_gap = j, gap
            if best < 0 or best_gap > reach:
                continue
            g = normal[0] * (u - cx) / f + normal[1] * (v - cy) / f + normal[2]
            value = s[best] * g - doffs
            if value > 0.0 and value < max_disparity:
                out[yy + y0, xx + x0] = np.float32(value)
                mask[yy + y0, xx + x0] = True
                face_of[yy + y0, xx + x0] = face_base + best
