"""Matching cost: the 5x5 census transform (plain or ternary) and the Hamming distance
between the two images' census codes, ``C[y, x, d]`` in census bits (0-24)."""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

MAX_CENSUS_COST = 24  # 5x5 census: 24 comparisons


@njit(cache=True, nogil=True)
def census5x5(img: np.ndarray, epsilon: int = 0) -> np.ndarray:  # pragma: no cover - compiled
    """24-bit census of each pixel: bit i set where neighbour i is darker than the centre
    by more than ``epsilon`` grey levels (0: darker at all, the plain census). Outside the
    image counts as equal to the centre."""
    h, w = img.shape
    out = np.zeros((h, w), dtype=np.uint32)
    for y in range(h):
        for x in range(w):
            c = np.int32(img[y, x]) - epsilon
            bits = np.uint32(0)
            for dy in range(-2, 3):
                for dx in range(-2, 3):
                    if dy == 0 and dx == 0:
                        continue
                    yy, xx = y + dy, x + dx
                    v = c + epsilon
                    if 0 <= yy < h and 0 <= xx < w:
                        v = np.int32(img[yy, xx])
                    bits = (bits << np.uint32(1)) | np.uint32(1 if v < c else 0)
            out[y, x] = bits
    return out


@njit(cache=True, nogil=True)
def census_ternary(img: np.ndarray, epsilon: int) -> np.ndarray:  # pragma: no cover - compiled
    """Ternary 5x5 census, (H, W) uint64: each of the 24 neighbours is darker than the
    centre by more than ``epsilon`` grey levels (its bit of the low word), brighter by
    more than ``epsilon`` (its bit of the high word, the darker bits of the inverted
    image), or neither (both 0). Outside the image counts as equal to the centre.

    On a near-uniform face the plain census bits follow sensor noise and JPEG ringing, so
    every disparity gets a random cost and the winner is arbitrary; here they are all
    "neither", the costs are flat and SGM's paths carry the disparity in from the face's
    outline instead. :func:`_hamming` counts a neighbour once when its two codes differ,
    so the cost keeps the plain census's scale (0-24). Unlike the plain census it is not
    blind to a gain between the cameras (the threshold is in grey levels), only to an
    offset.
    """
    h, w = img.shape
    inverted = np.empty((h, w), dtype=np.uint8)
    for y in range(h):
        for x in range(w):
            inverted[y, x] = 255 - img[y, x]
    dark = census5x5(img, epsilon)
    bright = census5x5(inverted, epsilon)
    out = np.empty((h, w), dtype=np.uint64)
    for y in range(h):
        for x in range(w):
            out[y, x] = np.uint64(dark[y, x]) | (np.uint64(bright[y, x]) << np.uint64(32))
    return out


@intrinsic
def _hamming(typingctx, value):  # pragma: no cover - compiled
    """Census distance of ``value = a ^ b``: the bits set in a uint32 (plain census), or,
    for the uint64 ternary census (:func:`census_ternary`), the neighbours whose
    darker or brighter bit differs: ``popcount(low | high)`` of the two 32-bit halves,
    0-24 either way. LLVM's ``ctpop``: one POPCNT (VPOPCNTD once vectorised) instead of the
    dozen shifts and masks of the portable bit trick; Numba has no popcount of its own."""
    if value not in (types.uint32, types.uint64):
        return None

    def codegen(context, builder, signature, args):
        v = args[0]
        if signature.args[0] == types.uint64:
            folded = builder.or_(v, builder.lshr(v, ir.Constant(ir.IntType(64), 32)))
            v = builder.trunc(folded, ir.IntType(32))
        fn = builder.module.declare_intrinsic("llvm.ctpop", [ir.IntType(32)])
        return builder.call(fn, [v])

    return types.uint32(value), codegen


@njit(cache=True, nogil=True, inline="always")
def census_cost_row(cl, cr, y, cost, r, reversed_right):  # pragma: no cover - compiled
    """Hamming distances of row y into ``cost[r]`` (uint8, (W, D)); no match (x - d < 0)
    costs the maximum. The right census row is read reversed (into ``reversed_right``) so
    that the inner loop over d reads memory forward and vectorises."""
    w = cl.shape[1]
    n = cost.shape[2]
    for k in range(w):
        reversed_right[k] = cr[y, w - 1 - k]
    for x in range(w):
        a = cl[y, x]
        top = min(n, x + 1)
        # A view, so that the index is d itself: with ``base + d`` Numba's negative-index
        # handling turns the contiguous reads into gathers (measured 2x slower).
        candidates = reversed_right[w - 1 - x : w - 1 - x + top]
        for d in range(top):
            cost[r, x, d] = np.uint8(_hamming(a ^ candidates[d]))  # type: ignore[call-arg]
        for d in range(top, n):
            cost[r, x, d] = MAX_CENSUS_COST


@njit(cache=True, nogil=True)
def census_cost(cl: np.ndarray, cr: np.ndarray, n_disp: int) -> np.ndarray:  # pragma: no cover - compiled
    """Hamming distances ``C[y, x, d]`` (uint8, (H, W, n_disp)) of two census images."""
    h, w = cl.shape
    cost = np.empty((h, w, n_disp), dtype=np.uint8)
    reversed_right = np.empty_like(cr[0])
    for y in range(h):
        census_cost_row(cl, cr, y, cost, y, reversed_right)
    return cost
