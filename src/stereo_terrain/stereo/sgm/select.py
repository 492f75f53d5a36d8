"""Disparity selection from the aggregated costs S: winner-take-all, uniqueness, parabola
sub-pixel refinement, left-right check, and each pixel's confidence."""

from __future__ import annotations

import numpy as np
from numba import njit

from ..subpixel import parabola_peak

MAX_DISPARITIES = 4096  # the selection packs a disparity index into 12 bits


@njit(cache=True, nogil=True, inline="always")
def select_row(total, y, uniqueness, lr_max_diff, disp, conf, work, sub):  # pragma: no cover
    """:func:`select_disparity_rows` for row y. ``work``: int32 (4, W) and ``sub``:
    float32 (W,) work rows.

    Everything that reads S is done in one pass per pixel, while its costs are in L1:
    read again later from the row (82 KB at 64 disparities, out of L1 by then), the three
    costs of the sub-pixel parabola took as long as the rest of the selection.
    """
    w = total.shape[1]
    n = total.shape[2]
    never = np.int16(32000)
    # key_row: packed (best cost, winner), then the winner or -1; cost_row: the second
    # best cost, then the best one (for the right image's winners).
    key_row, cost_row, right_cost, right_d = work[0], work[1], work[2], work[3]
    # A pixel with only a few candidate disparities (near the left border, where most of
    # the search range falls outside the right image) cannot pass a uniqueness test.
    min_x = max(4, n // 4)
    for x in range(w):
        # The best cost and its first index in one pass: S and d packed in one int32
        # (S < 2**15, d < 2**12), whose minimum gives both.
        key = np.int32(1 << 30)
        for d in range(n):
            key = min(key, (np.int32(total[y, x, d]) << 12) | np.int32(d))
        arg = np.int16(key & 4095)
        # Index comparisons in int16 too, so that this loop vectorises 32 wide.
        second = never
        lo, hi = np.int16(arg - 1), np.int16(arg + 1)
        for d in range(n):
            far = (np.int16(d) < lo) | (np.int16(d) > hi)
            second = min(second, total[y, x, d] if far else never)
        key_row[x] = key
        cost_row[x] = second
        sub[x] = arg
        if 0 < arg < n - 1 and arg + 1 <= x:  # both neighbours exist
            sub[x] = parabola_peak(arg, total[y, x, arg - 1], total[y, x, arg], total[y, x, arg + 1])
    # Confidence and uniqueness, without branches; key_row becomes the winner or -1.
    for x in range(w):
        m = key_row[x] >> 12
        arg = key_row[x] & 4095
        second = cost_row[x]
        # Not the winner: no match for it (arg > x), nothing else, or too few candidates.
        ok = (x >= min_x) & (arg <= x) & (second < never)
        conf[y, x] = float(second - m) / max(float(second), 1.0) if ok else 0.0
        key_row[x] = arg if ok & (m * (1.0 + uniqueness) <= second) else -1
        cost_row[x] = m
        right_cost[x] = 1 << 30
        right_d[x] = -1
    # The right image's winners: each left winner (x, d) is a candidate for right pixel
    # x - d, and the candidate of lowest cost wins there.
    for x in range(w):
        arg = key_row[x]
        if arg >= 0 and cost_row[x] < right_cost[x - arg]:
            right_cost[x - arg] = cost_row[x]
            right_d[x - arg] = arg
    for x in range(w):
        arg = key_row[x]
        ok = arg >= 0 and abs(right_d[x - arg] - arg) <= lr_max_diff
        disp[y, x] = sub[x] if ok else np.nan


@njit(cache=True, nogil=True)
def select_disparity_rows(
    total: np.ndarray,
    y0: int,
    y1: int,
    uniqueness: float,
    lr_max_diff: float,
    disp: np.ndarray,
    conf: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """WTA + uniqueness + parabola sub-pixel + left-right check for rows ``y0 .. y1 - 1``.

    ``total`` is S, the sum over all paths (int16, (H, W, D)). Writes ``disp`` (NaN where
    rejected) and ``conf`` (``(S_second - S_best) / S_second``, second best outside
    ``d_best +- 1``).

    The left-right check uses the right image's winners as OpenCV's SGBM does: each left
    winner (x, d) is a candidate for right pixel x - d, and the candidate of lowest cost
    wins there. That needs one pass over the winners instead of a second pass over the
    volume along its diagonals.
    """
    w = total.shape[1]
    work = np.empty((4, w), dtype=np.int32)
    sub = np.empty(w, dtype=np.float32)
    for y in range(y0, y1):
        select_row(total, y, uniqueness, lr_max_diff, disp, conf, work, sub)
