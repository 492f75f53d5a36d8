"""Aggregation: the paper's path recurrence along 4, 8 or 16 directions, in two raster
sweeps (one per core) that compute the matching costs as they go."""

from __future__ import annotations

import numpy as np
from numba import njit

from .census import census_cost_row
from .noalias import njit_no_overlap
from .select import select_row

NO_VALUE = 16000  # "no value" in the int16 path buffers; + P2 (<= 255) still fits in int16
_ROW_GROUP = 4  # rows whose paths along the row advance together
_PAD = 2  # padding columns of the row buffers: row paths step at most 2 columns


def p2_table(p1: int, p2: int, p2_scale: float) -> np.ndarray:
    """Hirschmüller's P2 lowered across intensity edges, for every grey-level step 0-255.

    ``P2' = max(P1 + 1, P2 / (1 + |I(p) - I(p - r)| / p2_scale))``, as int16: one table
    look-up per pixel and path instead of a division.
    """
    g = np.arange(256, dtype=np.float64)
    return np.maximum(p1 + 1, (p2 / (1.0 + g / p2_scale)).astype(np.int32)).astype(np.int16)


@njit_no_overlap
def _path_update(cost, cy, y, x, prev, pk, px, out, ok, ox, total, keep, pm, jump, p1):  # pragma: no cover
    """One step of a path, the paper's recurrence for pixel (y, x) and every disparity:

    ``L(p, d) = C(p, d) + min(L(q, d), L(q, d±1) + P1, min_k L(q, k) + P2') - min_k L(q, k)``

    with q the previous pixel on the path: ``prev[pk, px]`` holds L(q) (with sentinels at
    d = -1 and d = D, so the loop has no branch), ``pm`` its minimum and ``jump`` = pm + P2'.
    The costs C(p) are ``cost[cy, x]``. Writes L(p) to ``out[ok, ox]``, sets
    ``total[y, x] = keep * total[y, x] + L(p)`` and returns min_d L(p).

    Everything stays int16 (L <= 24 + 255) and every intermediate is cast back to int16,
    so LLVM vectorises the loop 32 disparities to an AVX-512 register. ``keep`` (0 or 1)
    is a factor, not a branch: a branch inside the loop stops the vectorisation (measured
    4x slower). With keep = 0, whatever ``total`` held (even uninitialised) is multiplied
    by zero.

    Compiled with ``noalias`` (:func:`_allow_noalias_option`), so ``cost``, ``prev``,
    ``out`` and ``total`` must be four separate arrays: every caller passes its own
    buffers. LLVM inlines it into its callers all the same.
    """
    m = np.int16(NO_VALUE)
    for d in range(cost.shape[2]):
        a = np.int16(min(prev[pk, px, d], prev[pk, px, d + 2]) + p1)
        v = min(a, min(prev[pk, px, d + 1], jump))
        r = np.int16(np.int16(cost[cy, x, d]) + np.int16(v - pm))
        out[ok, ox, d + 1] = r
        total[y, x, d] = np.int16(keep * total[y, x, d] + r)
        m = min(m, r)
    return m


@njit(cache=True, nogil=True, inline="always")
def _jump(lut, pm, grey, grey_before):  # pragma: no cover - compiled
    """``pm + P2'`` for a path stepping from a pixel of grey level ``grey_before`` to one
    of ``grey`` (``lut`` is :func:`p2_table`); int16."""
    return np.int16(pm + lut[abs(np.int32(grey) - np.int32(grey_before))])


@njit(cache=True, nogil=True, inline="always")
def _grey_clamped(img, y, x):  # pragma: no cover - compiled
    """Grey level of pixel (y, x) clamped into the image: where a path starts outside,
    its buffers hold zeros and P2 does not matter."""
    h, w = img.shape
    return img[min(max(y, 0), h - 1), min(max(x, 0), w - 1)]


@njit(cache=True, nogil=True, inline="always")
def _in_sweep_order(i: int, size: int, forward: bool) -> int:  # pragma: no cover - compiled
    """The i-th row (or column) a sweep visits: i forward, size - 1 - i backward."""
    return i if forward else size - 1 - i


@njit_no_overlap
def _row_path_row(
    cost, cy, img, y, forward, k, back, dx, prev, prev_min, cur, cur_min, total, keep, lut, p1
):  # pragma: no cover
    """Path k over row y (``cost[cy]``), each pixel (y, x) from pixel (y - back * s,
    x - dx * s) of an earlier row, s = 1 forward and -1 backward: reads that row's L from
    ``prev`` / ``prev_min``, writes row y's to ``cur`` / ``cur_min`` and adds it to
    ``total``. A function of its own, with ``noalias``, so that the loop over d needs no
    overlap checks (the buffers are separate arrays)."""
    w = img.shape[1]
    step = 1 if forward else -1
    yq = y - step * back
    # The pixels of the row are independent: visited left to right in both sweeps
    # (ascending addresses; the backward sweep was slower going right to left).
    for x in range(w):
        xq = x - step * dx
        pm = prev_min[k, xq + _PAD]
        jump = _jump(lut, pm, img[y, x], _grey_clamped(img, yq, xq))
        cur_min[k, x + _PAD] = _path_update(
            cost, cy, y, x, prev, k, xq + _PAD, cur, k, x + _PAD, total, keep, pm, jump, p1
        )


@njit_no_overlap
def _three_paths_row(
    cost, cy, img, y, forward, dx, prev, prev_min, cur, cur_min, total, keep, lut, p1
):  # pragma: no cover
    """Paths 0, 1 and 2 over row y, all from the row before, with column offsets ``dx[0:3]``:
    :func:`_row_path_row` three times in one loop over d, which loads the costs and
    loads and stores S once for the three (the loop is bound by loads and stores: a
    sweep takes about 10% less time). ``keep`` as in :func:`_path_update`."""
    w = img.shape[1]
    step = 1 if forward else -1
    yq = y - step
    dxa, dxb, dxc = dx[0], dx[1], dx[2]
    for x in range(w):
        grey = img[y, x]
        xa, xb, xc = x - step * dxa, x - step * dxb, x - step * dxc
        pa, pb, pc = prev_min[0, xa + _PAD], prev_min[1, xb + _PAD], prev_min[2, xc + _PAD]
        ja = _jump(lut, pa, grey, _grey_clamped(img, yq, xa))
        jb = _jump(lut, pb, grey, _grey_clamped(img, yq, xb))
        jc = _jump(lut, pc, grey, _grey_clamped(img, yq, xc))
        xa, xb, xc = xa + _PAD, xb + _PAD, xc + _PAD
        xo = x + _PAD
        ma = np.int16(NO_VALUE)
        mb = np.int16(NO_VALUE)
        mc = np.int16(NO_VALUE)
        for d in range(cost.shape[2]):
            c = np.int16(cost[cy, x, d])
            # _path_update's recurrence, written out for each path: with it in an inlined
            # helper function, LLVM left this loop scalar (3x slower).
            a = np.int16(min(prev[0, xa, d], prev[0, xa, d + 2]) + p1)
            ra = np.int16(c + np.int16(min(a, min(prev[0, xa, d + 1], ja)) - pa))
            b = np.int16(min(prev[1, xb, d], prev[1, xb, d + 2]) + p1)
            rb = np.int16(c + np.int16(min(b, min(prev[1, xb, d + 1], jb)) - pb))
            e = np.int16(min(prev[2, xc, d], prev[2, xc, d + 2]) + p1)
            rc = np.int16(c + np.int16(min(e, min(prev[2, xc, d + 1], jc)) - pc))
            cur[0, xo, d + 1] = ra
            cur[1, xo, d + 1] = rb
            cur[2, xo, d + 1] = rc
            total[y, x, d] = np.int16(keep * total[y, x, d] + np.int16(ra + np.int16(rb + rc)))
            ma = min(ma, ra)
            mb = min(mb, rb)
            mc = min(mc, rc)
        cur_min[0, xo] = ma
        cur_min[1, xo] = mb
        cur_min[2, xo] = mc


# Paths that come from earlier rows, as (rows back, columns back) in the sweep's own
# direction: (1, 0) is straight down, (1, +-1) the diagonals, and the 16-path set adds the
# knight moves (1, +-2), (2, +-1). With the path along the row, each of the two sweeps
# carries half of the 4, 8 or 16 paths.
ROW_PATHS = {
    4: ((1, 0),),
    8: ((1, 0), (1, 1), (1, -1)),
    16: ((1, 0), (1, 1), (1, -1), (1, 2), (1, -2), (2, 1), (2, -1)),
}


def sweep_state(width: int, n_disp: int, paths: int) -> tuple[np.ndarray, ...]:
    """Fresh row buffers of the paths from earlier rows, for :func:`aggregate_sweep`.

    ``(prev1, prev2, cur, min1, min2, cur_min)``: the last two rows' and the current row's
    L (int16, (k, W + 2 * _PAD, D + 2)) and their minima over d. They hold zeros where a
    path starts (first rows, padding columns), so that the update gives ``L = C`` there
    with no branch, and sentinels at d = -1 and d = D.
    """
    nk = len(ROW_PATHS[paths])
    rows = []
    for _ in range(3):
        buf = np.full((nk, width + 2 * _PAD, n_disp + 2), NO_VALUE, dtype=np.int16)
        buf[:, :, 1 : n_disp + 1] = 0
        rows.append(buf)
    mins = [np.zeros((nk, width + 2 * _PAD), dtype=np.int16) for _ in range(3)]
    return (*rows, *mins)


@njit(cache=True, nogil=True)
def aggregate_sweep(
    census_left: np.ndarray,
    census_right: np.ndarray,
    img: np.ndarray,
    forward: bool,
    row_paths: np.ndarray,
    p2_lut: np.ndarray,
    p1: int,
    out: np.ndarray,
    i0: int,
    i1: int,
    add: bool,
    state: tuple,
    select: bool,
    uniqueness: float,
    lr_max_diff: float,
    disp: np.ndarray,
    conf: np.ndarray,
) -> tuple:  # pragma: no cover - compiled
    """Half of the paths in one raster sweep, over the sweep's rows ``i0 .. i1 - 1``.

    The forward sweep goes top to bottom (its row i is image row i) and carries the path
    along the row from the left and every path in ``row_paths``; a path ``(b, c)`` comes
    from pixel ``(y - b, x - c)``. The backward sweep (its row i is image row H - 1 - i)
    mirrors them all. ``p2_lut`` is :func:`p2_table`. The sum of the paths is written to
    ``out`` (int16, (H, W, D)), or added to what it holds with ``add``. ``state`` is
    :func:`sweep_state` or what the previous call over the rows before ``i0`` returned;
    its arrays serve as the row buffers (they are overwritten), and the state after row
    ``i1 - 1`` is returned. With ``select``, each row of ``out`` is
    final once this sweep has added to it, and its disparities are chosen there and then
    (:func:`select_disparity_rows`, into ``disp`` and ``conf``), while it is in cache.

    The matching costs are computed here from the census images, ``_ROW_GROUP`` rows at a
    time, and never stored whole. For each group of rows, first row by row the paths from
    earlier rows, whose pixels within a row are independent, then the paths along the row,
    the rows interleaved (each pixel waits on its neighbour's result; interleaving
    independent rows keeps the CPU busy meanwhile). The group's rows of ``out`` stay in
    cache between the two. The row buffers of the paths from earlier rows are separate
    arrays rotated every row (reads from the previous rows and writes to this one never
    alias).
    """
    h, w = img.shape
    n = out.shape[2]
    lut = p2_lut
    p1 = np.int16(p1)  # type: ignore[assignment]
    zero = np.int16(0)
    one = np.int16(1)
    step = 1 if forward else -1
    cost = np.empty((_ROW_GROUP, w, n), dtype=np.uint8)
    reversed_right = np.empty_like(census_right[0])
    # The path along the row: the previous pixel's values alternate between two buffers
    # (even and odd steps), so reads and writes never alias.
    even = np.full((_ROW_GROUP, 1, n + 2), NO_VALUE, dtype=np.int16)
    odd = np.full((_ROW_GROUP, 1, n + 2), NO_VALUE, dtype=np.int16)
    start = np.full((1, 1, n + 2), NO_VALUE, dtype=np.int16)
    start[0, 0, 1 : n + 1] = 0  # with pm = jump = 0 the update gives L = C
    along_min = np.zeros(_ROW_GROUP, dtype=np.int16)
    work = np.empty((4, w), dtype=np.int32)  # the selection's work rows
    sub = np.empty(w, dtype=np.float32)
    nk = row_paths.shape[0]
    two_back = False  # any knight move (2, +-1): then three row buffers rotate, else two
    for k in range(nk):
        two_back = two_back or row_paths[k, 0] == 2
    # The first three paths from the row before go through one loop (8 and 16 paths).
    three_first = nk >= 3 and row_paths[0, 0] == 1 and row_paths[1, 0] == 1 and row_paths[2, 0] == 1
    prev1, prev2, cur, min1, min2, cur_min = state
    for g0 in range(i0, i1, _ROW_GROUP):
        rows = min(_ROW_GROUP, i1 - g0)
        for r in range(rows):
            y = _in_sweep_order(g0 + r, h, forward)
            census_cost_row(census_left, census_right, y, cost, r, reversed_right)
        # The paths from earlier rows, row by row, path by path (the first one of the
        # first phase writes S, the others add to it).
        for r in range(rows):
            y = _in_sweep_order(g0 + r, h, forward)
            first = 0
            if three_first:
                keep = np.int16(1) if add else zero
                _three_paths_row(
                    cost, r, img, y, forward, row_paths[:3, 1], prev1, min1, cur, cur_min, out, keep, lut, p1
                )
                first = 3
            for k in range(first, nk):
                keep = np.int16(1) if add or k > 0 else zero
                if row_paths[k, 0] == 1:
                    _row_path_row(
                        cost, r, img, y, forward, k, 1, row_paths[k, 1], prev1, min1, cur, cur_min, out,
                        keep, lut, p1,
                    )  # fmt: skip
                else:
                    _row_path_row(
                        cost, r, img, y, forward, k, 2, row_paths[k, 1], prev2, min2, cur, cur_min, out,
                        keep, lut, p1,
                    )  # fmt: skip
            if two_back:
                prev2, prev1, cur = prev1, cur, prev2
                min2, min1, cur_min = min1, cur_min, min2
            else:
                prev1, cur = cur, prev1
                min1, cur_min = cur_min, min1
        # The group's paths along the row, last: the backward sweep visits the row from
        # right to left, and its S rows are then already in cache (written first in that
        # order, they took 40% longer).
        x0 = _in_sweep_order(0, w, forward)
        for r in range(rows):
            y = _in_sweep_order(g0 + r, h, forward)
            along_min[r] = _path_update(cost, r, y, x0, start, 0, 0, even, r, 0, out, one, zero, zero, p1)
        for j in range(1, w):
            x = _in_sweep_order(j, w, forward)
            for r in range(rows):
                y = _in_sweep_order(g0 + r, h, forward)
                m = along_min[r]
                jump = _jump(lut, m, img[y, x], img[y, x - step])
                if j % 2:
                    along_min[r] = _path_update(cost, r, y, x, even, r, 0, odd, r, 0, out, one, m, jump, p1)
                else:
                    along_min[r] = _path_update(cost, r, y, x, odd, r, 0, even, r, 0, out, one, m, jump, p1)
        if select:
            for r in range(rows):
                y = _in_sweep_order(g0 + r, h, forward)
                select_row(out, y, uniqueness, lr_max_diff, disp, conf, work, sub)
    return (prev1, prev2, cur, min1, min2, cur_min)
