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


@njit(cache=True, nogil=True)
def mostly_filled(filled: np.ndarray, region: np.ndarray) -> bool:  # pragma: no cover - compiled
    """``filled[region].mean() > 0.5`` of a non-empty ``region`` in one pass (issue 13): with
    integer counts the mean exceeds one half exactly when twice the filled count exceeds
    the region's."""
    n = 0
    covered = 0
    h, w = region.shape
    for y in range(h):
        for x in range(w):
            if region[y, x]:
                n += 1
                if filled[y, x]:
                    covered += 1
    return 2 * covered > n


@njit(cache=True, nogil=True)
def finite_samples(
    region: np.ndarray, values: np.ndarray, most: int
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """``np.nonzero(region & isfinite(values))`` taken every ``max(1, n // most)``-th (``n``
    pixels in all), as int64 rows and columns in row-major order, without the full-box
    temporaries (issue 13)."""
    h, w = region.shape
    n = 0
    for y in range(h):
        for x in range(w):
            if region[y, x] and np.isfinite(values[y, x]):
                n += 1
    step = max(1, n // most)
    vs = np.empty((n + step - 1) // step, np.int64)
    us = np.empty_like(vs)
    i = 0
    for y in range(h):
        for x in range(w):
            if region[y, x] and np.isfinite(values[y, x]):
                if i % step == 0:
                    vs[i // step], us[i // step] = y, x
                i += 1
    return vs, us


@njit(cache=True, nogil=True)
def outline_edges(
    ring: np.ndarray,
    core: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    stride: int,
    strong: np.float32,
    cos_vertical: np.float32,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Every ``stride``-th pixel of the outline ``ring & ~core`` (0/1 bytes) in row-major
    order, as ``np.nonzero(ring & ~core)`` sliced ``[::stride]`` gives them, kept when its
    gradient (``gx``, ``gy``, float32) is strong (``|g| > strong``) and not vertical
    (``|gx| < |g| cos_vertical``), in float32 as NumPy computes it; without the full-box
    temporaries (issue 13). Returns rows, columns (int64), ``gx``, ``gy`` and ``|g|`` there."""
    h, w = ring.shape
    cap = (h * w + stride - 1) // stride
    vs = np.empty(cap, np.int64)
    us = np.empty(cap, np.int64)
    gxs = np.empty(cap, np.float32)
    gys = np.empty(cap, np.float32)
    ms = np.empty(cap, np.float32)
    n = 0
    skip = 0  # outline pixels to pass before the next sample
    for y in range(h):
        for x in range(w):
            if not ring[y, x] or core[y, x]:
                continue
            if skip == 0:
                skip = stride
                gxv, gyv = gx[y, x], gy[y, x]
                m = np.hypot(gxv, gyv)
                if m > strong and abs(gxv) < m * cos_vertical:
                    vs[n], us[n], gxs[n], gys[n], ms[n] = y, x, gxv, gyv, m
                    n += 1
            skip -= 1
    return vs[:n].copy(), us[:n].copy(), gxs[:n].copy(), gys[:n].copy(), ms[:n].copy()


@njit(cache=True, nogil=True)
def fill_targets(
    ring: np.ndarray, labels: np.ndarray, label: int, large: np.ndarray, filled: np.ndarray, refit: bool
) -> np.ndarray:  # pragma: no cover - compiled
    """The pixels a face fills, (h, w) bool: its ``ring`` (0/1 bytes, the region ``labels ==
    label`` dilated) less the pixels of the other ``large`` regions and those already
    ``filled`` (bar the region's own when it is ``refit``), in one pass (issue 13)."""
    h, w = ring.shape
    ext = np.zeros((h, w), np.bool_)
    for y in range(h):
        for x in range(w):
            k = labels[y, x]
            own = k == label
            if ring[y, x] and (own or not large[k]) and (not filled[y, x] or (refit and own)):
                ext[y, x] = True
    return ext


@njit(cache=True, nogil=True)
def hypothesis_costs(
    target: np.ndarray, g: np.ndarray, idx: np.ndarray, hyp: np.ndarray, thr2: float
) -> np.ndarray:  # pragma: no cover - compiled
    """MSAC's cost of each plane ``s = hyp[j]``: the sum over the points ``idx`` of
    ``min((target - s g)^2, thr2)``, summed point by point in order, as NumPy's
    ``np.minimum(residual**2, thr2).sum(axis=0)`` of the (points, hypotheses) residuals
    does, without them (issue 13)."""
    costs = np.zeros(hyp.shape[0])
    for i in idx:
        t, gi = target[i], g[i]
        for j in range(hyp.shape[0]):
            r = t - hyp[j] * gi
            costs[j] += min(r * r, thr2)
    return costs
