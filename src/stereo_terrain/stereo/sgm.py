"""The project's own Semi-Global Matching engine (Hirschmüller 2005), compiled with Numba.

Work in progress toward issue 3. It is correct and tested, but not yet tuned or
benchmarked against OpenCV, and it is not the pipeline's default.

Stages:

1. **Census cost.** A 5x5 census transform (24 bits) of both images. The matching cost is
   the Hamming distance between the two bit strings. It depends only on the order of
   intensities, so a gain or offset between cheap webcams leaves it unchanged.
2. **Aggregation along 4, 8 or 16 directions r**, the paper's recurrence:
   ``L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d±1) + P1, min_k L_r(p-r, k) + P2')
   - min_k L_r(p-r, k)``.
   P1 penalises 1-px disparity steps. ``P2' = max(P1 + 1, P2 / (1 + |I(p) - I(p-r)| /
   p2_gradient_scale))`` penalises larger jumps, less so across intensity edges.
   ``S(p, d) = sum_r L_r(p, d)`` is kept in uint16.
3. **Disparity selection.** Winner-take-all with a uniqueness ratio, parabola sub-pixel
   refinement, a left-right consistency check (the right image's disparities come from the
   same aggregated volume), and speckle removal. Invalid pixels become NaN.
4. **Confidence** of each pixel from its cost curve:
   ``(S_second - S_best) / S_second``, with the second best taken outside ``d_best ± 1``.

Memory: the cost volume (uint8) and one aggregate per sweep (uint16), ``5 * H * W * D``
bytes. That is 197 MB at 640x480x128 and 98 MB at 64 disparities.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np
from numba import njit

from ..checks import check_fields, check_min
from ..errors import ConfigError, InputError
from ..rectify import RectifiedPair
from . import DisparityMap, check_max_disparity

_MAX_COST = 24  # 5x5 census: 24 comparisons

# Directions (dy, dx) of the aggregation paths; 4 and 8 paths are prefixes of this list.
_DIRECTIONS_16 = (
    (0, 1),
    (0, -1),
    (1, 0),
    (-1, 0),
    (1, 1),
    (1, -1),
    (-1, 1),
    (-1, -1),
    (2, 1),
    (2, -1),
    (-2, 1),
    (-2, -1),
    (1, 2),
    (1, -2),
    (-1, 2),
    (-1, -2),
)


@dataclass(frozen=True)
class SGMConfig:
    """Parameters of the SGM engine (costs are in census bits, 0-24).

    Attributes
    ----------
    paths : int
        Aggregation directions: 4 (rows and columns), 8 (and diagonals) or 16 (and the
        knight moves (+-1, +-2), (+-2, +-1)).
    p1 : int
        Penalty for disparity changes of 1 px.
    p2 : int
        Penalty for larger changes (before adaptation to the image gradient).
    p2_gradient_scale : float
        Grey levels of intensity change that halve P2.
    uniqueness_ratio_pct : int
        The best cost must beat the second best (outside +-1 px) by this margin.
    lr_max_diff_px : float
        Left-right consistency tolerance.
    speckle_window_px, speckle_range_px : int
        Speckle filter (OpenCV's filterSpeckles on the result).
    """

    paths: int = 8
    p1: int = 7
    p2: int = 86
    p2_gradient_scale: float = 16.0
    uniqueness_ratio_pct: int = 5
    lr_max_diff_px: float = 1.0
    speckle_window_px: int = 100
    speckle_range_px: int = 2

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 0, "lr_max_diff_px", "speckle_window_px", "speckle_range_px")
        if self.paths not in (4, 8, 16):
            raise ConfigError(f"paths must be 4, 8 or 16, got {self.paths}")
        if not 0 < self.p1 < self.p2 <= 255:
            raise ConfigError(f"need 0 < p1 < p2 <= 255, got p1={self.p1}, p2={self.p2}")
        if self.p2_gradient_scale <= 0:
            raise ConfigError("p2_gradient_scale must be > 0")
        if not 0 <= self.uniqueness_ratio_pct < 100:
            raise ConfigError("uniqueness_ratio_pct must be in [0, 100)")


@njit(cache=True, nogil=True)
def census5x5(img: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """24-bit census of each pixel (outside the image counts as equal to the centre)."""
    h, w = img.shape
    out = np.zeros((h, w), dtype=np.uint32)
    for y in range(h):
        for x in range(w):
            c = img[y, x]
            bits = np.uint32(0)
            for dy in range(-2, 3):
                for dx in range(-2, 3):
                    if dy == 0 and dx == 0:
                        continue
                    yy, xx = y + dy, x + dx
                    v = c
                    if 0 <= yy < h and 0 <= xx < w:
                        v = img[yy, xx]
                    bits = (bits << np.uint32(1)) | np.uint32(1 if v < c else 0)
            out[y, x] = bits
    return out


@njit(cache=True, nogil=True)
def _popcount(v: np.uint32) -> int:  # pragma: no cover - compiled
    v = v - ((v >> np.uint32(1)) & np.uint32(0x55555555))
    v = (v & np.uint32(0x33333333)) + ((v >> np.uint32(2)) & np.uint32(0x33333333))
    v = (v + (v >> np.uint32(4))) & np.uint32(0x0F0F0F0F)
    return int((v * np.uint32(0x01010101)) >> np.uint32(24))


@njit(cache=True, nogil=True)
def census_cost(cl: np.ndarray, cr: np.ndarray, n_disp: int) -> np.ndarray:  # pragma: no cover
    """Hamming distances ``C[y, x, d]`` (uint8); no match (x - d < 0) costs the maximum."""
    h, w = cl.shape
    cost = np.empty((h, w, n_disp), dtype=np.uint8)
    for y in range(h):
        for x in range(w):
            a = cl[y, x]
            for d in range(n_disp):
                if x - d >= 0:
                    cost[y, x, d] = _popcount(a ^ cr[y, x - d])
                else:
                    cost[y, x, d] = _MAX_COST
    return cost


@njit(cache=True, nogil=True, inline="always")
def _adapted_p2(gradient: np.int32, p1: np.int32, p2: int, scale: float) -> np.int32:  # pragma: no cover
    """Hirschmüller's P2 lowered across intensity edges, never below P1 + 1."""
    return max(p1 + 1, np.int32(p2 / (1.0 + gradient / scale)))


# Row paths carried by a sweep, as (rows back, columns back) in the sweep's own direction;
# the path along the row is always carried. 4, 8 and 16 paths in all (two sweeps).
ROW_PATHS = {
    4: ((1, 0),),
    8: ((1, 0), (1, 1), (1, -1)),
    16: ((1, 0), (1, 1), (1, -1), (1, 2), (1, -2), (2, 1), (2, -1)),
}


@njit(cache=True, nogil=True)
def aggregate_sweep(
    cost: np.ndarray, img: np.ndarray, forward: bool, row_paths: np.ndarray, p1: int, p2: int, p2_scale: float
) -> np.ndarray:  # pragma: no cover - compiled
    """The paths one raster sweep can carry, summed (uint16).

    The forward sweep goes top to bottom and left to right. It carries the path along the
    row (from the left) and every path in ``row_paths``. A row path ``(b, c)`` comes from
    pixel ``(y - b, x - c)``: (1, 0) is straight down, (1, +-1) are the diagonals, and the
    16-path set adds the knight moves (1, +-2) and (2, +-1). The backward sweep mirrors
    all of them.

    Each path keeps only its last two rows plus the current one, with sentinels at d = -1
    and d = D, so the inner loop over d has no branches.
    """
    h, w, n = cost.shape
    big = np.int32(1 << 14)
    p1i = np.int32(p1)
    nk = row_paths.shape[0]
    total = np.empty((h, w, n), dtype=np.uint16)
    # The current row and the two before it, as three arrays rotated every row (separate
    # arrays, so that reads from the previous rows and writes to this one do not alias).
    cur = np.full((nk, w, n + 2), big, dtype=np.int32)
    prev1 = np.full((nk, w, n + 2), big, dtype=np.int32)
    prev2 = np.full((nk, w, n + 2), big, dtype=np.int32)
    cur_min = np.zeros((nk, w), dtype=np.int32)
    min1 = np.zeros((nk, w), dtype=np.int32)
    min2 = np.zeros((nk, w), dtype=np.int32)
    horiz = np.full(n + 2, big, dtype=np.int32)
    hnew = np.full(n + 2, big, dtype=np.int32)
    acc = np.zeros(n, dtype=np.int32)
    ci = np.zeros(n, dtype=np.int32)
    step = 1 if forward else -1
    hmin = np.int32(0)
    for i in range(h):
        y = i if forward else h - 1 - i
        for j in range(w):
            x = j if forward else w - 1 - j
            cmin = big
            for d in range(n):
                ci[d] = cost[y, x, d]
                if ci[d] < cmin:
                    cmin = ci[d]
            # Path along the row (from the previous pixel of this sweep).
            if j == 0:
                for d in range(n):
                    hnew[d + 1] = ci[d]
                    acc[d] = ci[d]
                m = cmin
            else:
                pm = hmin
                g = abs(np.int32(img[y, x]) - np.int32(img[y, x - step]))
                p2a = _adapted_p2(g, p1i, p2, p2_scale)
                jump = pm + p2a
                m = big
                for d in range(1, n + 1):
                    v = min(min(horiz[d], jump), min(horiz[d - 1], horiz[d + 1]) + p1i)
                    r = ci[d - 1] + v - pm
                    hnew[d] = r
                    acc[d - 1] = r
                    m = min(m, r)
            hmin = m
            horiz, hnew = hnew, horiz
            # Paths from earlier rows.
            for k in range(nk):
                back = row_paths[k, 0]
                xq = x - step * row_paths[k, 1]
                if i < back or xq < 0 or xq >= w:
                    for d in range(n):
                        cur[k, x, d + 1] = ci[d]
                        acc[d] += ci[d]
                    cur_min[k, x] = cmin
                    continue
                yq = y - step * back
                pm = min1[k, xq] if back == 1 else min2[k, xq]
                g = abs(np.int32(img[y, x]) - np.int32(img[yq, xq]))
                p2a = _adapted_p2(g, p1i, p2, p2_scale)
                jump = pm + p2a
                cm = big
                pr = prev1[k, xq] if back == 1 else prev2[k, xq]
                for d in range(1, n + 1):
                    v = min(min(pr[d], jump), min(pr[d - 1], pr[d + 1]) + p1i)
                    r = ci[d - 1] + v - pm
                    cur[k, x, d] = r
                    acc[d - 1] += r
                    cm = min(cm, r)
                cur_min[k, x] = cm
            for d in range(n):
                total[y, x, d] = acc[d]
        prev2, prev1, cur = prev1, cur, prev2
        min2, min1, cur_min = min1, cur_min, min2
    return total


@njit(cache=True, nogil=True)
def select_disparity(
    total: np.ndarray, uniqueness: float, lr_max_diff: float
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """WTA + uniqueness + parabola sub-pixel + left-right check; NaN where rejected.

    Returns (disparity float32, confidence float32).
    """
    h, w, n = total.shape
    disp = np.full((h, w), np.nan, dtype=np.float32)
    conf = np.zeros((h, w), dtype=np.float32)
    right_best = np.empty(w, dtype=np.int32)
    # A pixel with only a few candidate disparities (near the left border, where most of
    # the search range falls outside the right image) cannot pass a uniqueness test.
    min_x = max(4, n // 4)
    best_arg = np.empty(w, dtype=np.int32)
    best_cost = np.empty(w, dtype=np.int32)
    right_min = np.empty(w, dtype=np.int32)
    for y in range(h):
        # One contiguous pass: each pixel's winner, and the right image's winner at each
        # column xr = x - d (min over the diagonal of the volume).
        right_min[:] = 1 << 30
        right_best[:] = -1
        for x in range(w):
            best, arg = 1 << 30, 0
            top = min(n, x + 1)
            for d in range(top):
                v = int(total[y, x, d])
                if v < best:
                    best, arg = v, d
                if v < right_min[x - d]:
                    right_min[x - d] = v
                    right_best[x - d] = d
            best_arg[x] = arg
            best_cost[x] = best
        for x in range(min_x, w):
            arg, best = best_arg[x], best_cost[x]
            second = 1 << 30
            for d in range(min(n, x + 1)):
                if d < arg - 1 or d > arg + 1:
                    v = int(total[y, x, d])
                    if v < second:
                        second = v
            if second >= (1 << 30):
                continue
            conf[y, x] = (second - best) / max(second, 1)
            if best * (1.0 + uniqueness) > second:
                continue
            sub = float(arg)
            if 0 < arg < n - 1 and arg + 1 <= x:
                a = float(total[y, x, arg - 1])
                b = float(total[y, x, arg])
                cc = float(total[y, x, arg + 1])
                den = a - 2.0 * b + cc
                if den > 0:
                    sub = arg + 0.5 * (a - cc) / den
            xr = x - arg
            if right_best[xr] < 0 or abs(right_best[xr] - arg) > lr_max_diff:
                continue
            disp[y, x] = sub
    return disp, conf


_POOL: ThreadPoolExecutor | None = None


def _sweep_pool() -> ThreadPoolExecutor:
    """One two-thread pool for the forward and backward sweeps, shared by all engines."""
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="sgm")
    return _POOL


class SGM:
    """The project's SGM engine behind the :class:`DisparityBackend` interface."""

    name = "sgm"

    def __init__(self, config: SGMConfig | None = None) -> None:
        self.config = config or SGMConfig()

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
        left, right = pair.left, pair.right
        if left.dtype != np.uint8 or left.ndim != 2 or left.shape != right.shape:
            raise InputError(
                f"SGM needs two (H, W) uint8 images of one size, got {left.shape} {left.dtype} and "
                f"{right.shape} {right.dtype}"
            )
        n = check_max_disparity(max_disparity_px, left.shape[1])
        c = self.config
        cost = census_cost(census5x5(left), census5x5(right), n)
        paths = np.array(ROW_PATHS[c.paths], dtype=np.int64)
        sweeps = [
            _sweep_pool().submit(aggregate_sweep, cost, left, fwd, paths, c.p1, c.p2, c.p2_gradient_scale)
            for fwd in (True, False)
        ]
        total = sweeps[0].result()
        total += sweeps[1].result()
        disp, conf = select_disparity(total, c.uniqueness_ratio_pct / 100.0, c.lr_max_diff_px)
        if c.speckle_window_px > 0:
            fixed = np.where(np.isfinite(disp), disp * 16.0, -16.0).astype(np.int16)
            cv2.filterSpeckles(fixed, -16, c.speckle_window_px, c.speckle_range_px * 16)
            disp[fixed == -16] = np.nan
        return DisparityMap(disp, n, pair.rectification, conf, self.name)
