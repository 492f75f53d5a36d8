"""The project's own Semi-Global Matching engine (Hirschmüller 2005), compiled with Numba.

Stages:

1. **Census cost.** A 5x5 census transform (24 bits) of both images. The matching cost is
   the Hamming distance between the two bit strings (uint8 volume ``C[y, x, d]``). It
   depends only on the order of intensities, so a gain or offset between cheap webcams
   leaves it unchanged. Optionally (``census_epsilon_grey``) a ternary census, blind to
   differences within a few grey levels, for near-uniform faces under noise and JPEG.
2. **Aggregation along 4, 8 or 16 directions r**, the paper's recurrence:
   ``L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d±1) + P1, min_k L_r(p-r, k) + P2')
   - min_k L_r(p-r, k)``.
   P1 penalises 1-px disparity steps. ``P2' = max(P1 + 1, P2 / (1 + |I(p) - I(p-r)| /
   p2_gradient_scale))`` penalises larger jumps, less so across intensity edges.
   ``S(p, d) = sum_r L_r(p, d)``.
3. **Disparity selection.** Winner-take-all with a uniqueness ratio, parabola sub-pixel
   refinement, a left-right consistency check, and speckle removal. Invalid pixels become
   NaN.
4. **Confidence** of each pixel from its cost curve:
   ``(S_second - S_best) / S_second``, with the second best taken outside ``d_best ± 1``.

How it is made fast on two cores (numbers in ``docs/benchmarks.md``):

- Every path update is one loop over d in int16 that LLVM vectorises (32 disparities per
  AVX-512 instruction); see :func:`_path_update` for what keeps it vectorisable, and
  :func:`_allow_noalias_option` for what keeps it free of per-pixel overlap checks.
- Two raster sweeps, one per core: the forward sweep carries the path from the left and
  the paths from the rows above, the backward sweep the mirror images. Each computes the
  matching costs of four rows at a time and, for those rows, first the paths from
  earlier rows (no dependence between the pixels of a row, visited left to right), then
  the paths along the row (the four rows interleaved, so that one pixel's wait on its
  neighbour overlaps with other rows' work). The cost volume is never stored whole.
- One volume S for both sweeps, filled in two phases: the forward sweep writes the top
  half while the backward sweep writes the bottom half; then each goes on into the
  other half, adds its paths, and chooses the disparities of each row it finishes while
  the row is still in cache.

Memory: S (int16), ``2 * H * W * D`` bytes: 79 MB at 640x480x128 and 39 MB at 64
disparities, plus row buffers (under 2 MB). An engine keeps S between calls (the next
frame of the same size reuses it).
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cpu as numba_cpu
from numba.extending import intrinsic

from ..checks import check_fields, check_min
from ..errors import ConfigError, InputError
from ..rectify import RectifiedPair
from . import DisparityMap, check_max_disparity, invalidate_sourceless
from .smooth import smooth_planar
from .subpixel import parabola_peak


def _allow_noalias_option() -> bool:
    """Let ``@njit`` take ``noalias=True``.

    Numba has this compiler flag (its parallel back end sets it on the kernels it writes)
    but its decorator does not expose it. With it, LLVM knows that no two array arguments
    of the function overlap. Without it, every inner loop over d that writes one array and
    reads others first compares their address ranges at run time before it may use the
    vector code, for each pixel and path; those comparisons (over a hundred instructions
    for three paths) cost more than the 64-disparity loop itself: measured 3x slower.

    Returns False, and the engine compiles without the flag (same result, slower), if a
    Numba version lays out its options differently.
    """
    from numba.core.compiler import Flags

    options = getattr(numba_cpu, "CPUTargetOptions", None)
    if options is None or not callable(getattr(options, "Mapping", None)) or not hasattr(Flags, "noalias"):
        return False
    existing = getattr(options, "noalias", None)
    if existing is None:
        options.noalias = options.Mapping("noalias")
    elif not isinstance(existing, options.Mapping):
        return False
    return True


NOALIAS = _allow_noalias_option()
# ``@njit`` with the flag; for functions whose array arguments never overlap.
_njit_no_overlap: Any = njit(cache=True, nogil=True, **({"noalias": True} if NOALIAS else {}))  # type: ignore[call-overload]

_MAX_COST = 24  # 5x5 census: 24 comparisons
MAX_DISPARITIES = 4096  # the selection packs a disparity index into 12 bits
_BIG = 16000  # "no value" in the int16 path buffers; + P2 (<= 255) still fits in int16
_ROW_GROUP = 4  # rows whose paths along the row advance together
_PAD = 2  # padding columns of the row buffers: row paths step at most 2 columns


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
    census_blur_sigma_px : float
        Gaussian blur (sigma, pixels) of both images before the census transform; 0 for
        none (the default). On weakly textured faces the census bits of a 5x5 window
        follow sensor noise; a blur of about 1 px makes them follow the faint shading
        instead. It costs detail: see Notes. P2's adaptation always uses the sharp image.
    census_epsilon_grey : int
        0 (the default): the plain census. Above 0: the ternary census
        (:func:`census_ternary`), in which a neighbour within this many grey levels of
        the centre counts as equal to it, so that sensor noise and JPEG ringing on a
        near-uniform face give flat costs and the disparity comes from the face's outline
        through SGM's paths. CPU only.
    plane_smooth_radius_px : int
        0 (the default) for none; above 0, the disparities are replaced by the value of
        the least-squares plane through the valid disparities of the ``(2 r + 1)``-square
        window around each pixel, and pixels more than 1 px off it are dropped
        (:func:`~stereo_terrain.stereo.smooth.smooth_planar`). This undoes the whole-pixel
        terraces SGM leaves on faces where the costs are flat.
    device : str
        ``cpu`` (Numba, the default), ``cuda`` (Numba-CUDA, :mod:`.sgm_cuda`; 4 or 8 paths,
        at most 256 disparities; same result as the CPU) or ``auto`` (CUDA when a device is
        present, else CPU).

    Notes
    -----
    P1 and P2 were chosen by ``benchmarks/tune_sgm.py`` on the eight Middlebury 2014
    quarter-size scenes (the lowest mean bad-2.0 on a small grid; those scenes are also
    the evaluation set, as ``docs/benchmarks.md`` says beside them). A uniqueness ratio of
    2% scores better there (bad-2.0 counts holes as errors) but finds fewer rendered
    staircases than 5% (``docs/benchmarks.md``), so the default keeps 5%.

    ``census_blur_sigma_px: 1.0`` (``docs/benchmarks.md``, "Census on a blurred image")
    lifts the pipeline's detection in weakly textured scenes from 69% to 83% (OpenCV: 83%),
    and raises the mean Middlebury bad-2.0 from 13.0% to 16.2% (still below OpenCV's best
    mode on every scene). It lowers detection at 320x240, so it is not the default.
    """

    paths: int = 8
    p1: int = 14
    p2: int = 80
    p2_gradient_scale: float = 16.0
    uniqueness_ratio_pct: int = 5
    lr_max_diff_px: float = 1.0
    speckle_window_px: int = 100
    speckle_range_px: int = 2
    census_blur_sigma_px: float = 0.0
    census_epsilon_grey: int = 0
    plane_smooth_radius_px: int = 0
    device: str = "cpu"

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 0, "lr_max_diff_px", "speckle_window_px", "speckle_range_px")
        if self.speckle_window_px > 1_000_000 or self.speckle_range_px > 1_000:
            raise ConfigError(
                "speckle_window_px must be at most 1000000 and speckle_range_px at most 1000, got "
                f"{self.speckle_window_px} and {self.speckle_range_px}"
            )
        if self.paths not in (4, 8, 16):
            raise ConfigError(f"paths must be 4, 8 or 16, got {self.paths}")
        if not 0 < self.p1 < self.p2 <= 255:
            raise ConfigError(f"need 0 < p1 < p2 <= 255, got p1={self.p1}, p2={self.p2}")
        if self.p2_gradient_scale <= 0:
            raise ConfigError("p2_gradient_scale must be > 0")
        if not 0.0 <= self.census_blur_sigma_px <= 10.0:
            raise ConfigError(
                "census_blur_sigma_px must be between 0 (no blur) and 10 pixels, "
                f"got {self.census_blur_sigma_px}"
            )
        if not 0 <= self.census_epsilon_grey <= 64:
            raise ConfigError(
                f"census_epsilon_grey must be between 0 (plain census) and 64, got {self.census_epsilon_grey}"
            )
        if self.census_epsilon_grey > 0 and self.device == "cuda":
            raise ConfigError(
                "census_epsilon_grey > 0 (the ternary census) runs on the CPU only; "
                "use device='cpu' or 'auto'"
            )
        if not 0 <= self.plane_smooth_radius_px <= 50:
            raise ConfigError(
                f"plane_smooth_radius_px must be between 0 (off) and 50, got {self.plane_smooth_radius_px}"
            )
        if not 0 <= self.uniqueness_ratio_pct < 100:
            raise ConfigError("uniqueness_ratio_pct must be in [0, 100)")
        if self.device not in ("cpu", "cuda", "auto"):
            raise ConfigError(f"device must be cpu, cuda or auto, got '{self.device}'")


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
def _census_cost_row(cl, cr, y, cost, r, reversed_right):  # pragma: no cover - compiled
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
            cost[r, x, d] = _MAX_COST


@njit(cache=True, nogil=True)
def census_cost(cl: np.ndarray, cr: np.ndarray, n_disp: int) -> np.ndarray:  # pragma: no cover - compiled
    """Hamming distances ``C[y, x, d]`` (uint8, (H, W, n_disp)) of two census images."""
    h, w = cl.shape
    cost = np.empty((h, w, n_disp), dtype=np.uint8)
    reversed_right = np.empty_like(cr[0])
    for y in range(h):
        _census_cost_row(cl, cr, y, cost, y, reversed_right)
    return cost


def p2_table(p1: int, p2: int, p2_scale: float) -> np.ndarray:
    """Hirschmüller's P2 lowered across intensity edges, for every grey-level step 0-255.

    ``P2' = max(P1 + 1, P2 / (1 + |I(p) - I(p - r)| / p2_scale))``, as int16: one table
    look-up per pixel and path instead of a division.
    """
    g = np.arange(256, dtype=np.float64)
    return np.maximum(p1 + 1, (p2 / (1.0 + g / p2_scale)).astype(np.int32)).astype(np.int16)


@_njit_no_overlap
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
    m = np.int16(_BIG)
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


@_njit_no_overlap
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


@_njit_no_overlap
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
        ma = np.int16(_BIG)
        mb = np.int16(_BIG)
        mc = np.int16(_BIG)
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
        buf = np.full((nk, width + 2 * _PAD, n_disp + 2), _BIG, dtype=np.int16)
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
    even = np.full((_ROW_GROUP, 1, n + 2), _BIG, dtype=np.int16)
    odd = np.full((_ROW_GROUP, 1, n + 2), _BIG, dtype=np.int16)
    start = np.full((1, 1, n + 2), _BIG, dtype=np.int16)
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
            _census_cost_row(census_left, census_right, y, cost, r, reversed_right)
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
                _select_row(out, y, uniqueness, lr_max_diff, disp, conf, work, sub)
    return (prev1, prev2, cur, min1, min2, cur_min)


@njit(cache=True, nogil=True, inline="always")
def _select_row(total, y, uniqueness, lr_max_diff, disp, conf, work, sub):  # pragma: no cover
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
        _select_row(total, y, uniqueness, lr_max_diff, disp, conf, work, sub)


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


_POOL: ThreadPoolExecutor | None = None


def cpu_halves() -> list[set[int]]:
    """The CPUs this process may use, split in two halves (one per sweep thread); an empty
    list where that cannot be done (one CPU, or no affinity on this system)."""
    if not hasattr(os, "sched_getaffinity"):
        return []
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) < 2:
        return []
    half = len(cpus) // 2
    return [set(cpus[:half]), set(cpus[half:])]


def _keep_to_own_cpus(halves: list[set[int]], which: Iterator[int]) -> None:
    """Pool initializer: the calling thread runs only on its half of the CPUs."""
    try:
        os.sched_setaffinity(0, halves[next(which) % len(halves)])  # 0: the calling thread
    except OSError:  # a CPU set changed under us, or not allowed: run anywhere
        pass


def _sweep_pool() -> ThreadPoolExecutor:
    """One two-thread pool for the forward and backward sweeps, shared by all engines.

    Each thread keeps to its own half of the CPUs. Left free, the scheduler often woke
    both on the same core after an idle spell, and one sweep waited for the other: a call
    0.2 s after the previous one took 31-33 ms at 640x480x128 (median; quartiles 26-37 ms)
    instead of 26 ms (26-27 ms).
    """
    global _POOL
    if _POOL is None:
        halves = cpu_halves()
        if halves:
            _POOL = ThreadPoolExecutor(
                max_workers=2, thread_name_prefix="sgm", initializer=_keep_to_own_cpus,
                initargs=(halves, itertools.count()),
            )  # fmt: skip
        else:
            _POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="sgm")
    return _POOL


class SGM:
    """The project's SGM engine behind the :class:`DisparityBackend` interface."""

    name = "sgm"

    def __init__(self, config: SGMConfig | None = None) -> None:
        self.config = config or SGMConfig()
        # S is kept for the next call of the same size: a fresh 39-79 MB array costs one
        # page fault per 4 KB on first touch, measured 5 ms per frame at 640x480x64.
        self._volume: np.ndarray | None = None
        self._volume_lock = threading.Lock()

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
        left, right = pair.left, pair.right
        if left.dtype != np.uint8 or left.ndim != 2 or left.shape != right.shape:
            raise InputError(
                f"SGM needs two (H, W) uint8 images of one size, got {left.shape} {left.dtype} and "
                f"{right.shape} {right.dtype}"
            )
        n = check_max_disparity(max_disparity_px, left.shape[1])
        if n > MAX_DISPARITIES:
            raise InputError(f"the SGM engine handles at most {MAX_DISPARITIES} disparities, got {n}")
        c = self.config
        lut = p2_table(c.p1, c.p2, c.p2_gradient_scale)
        # What the census sees; P2's adaptation keeps the sharp left image.
        census_left, census_right = left, right
        if c.census_blur_sigma_px > 0:
            census_left, census_right = (
                cv2.GaussianBlur(image, (0, 0), c.census_blur_sigma_px) for image in (left, right)
            )
        if self._use_cuda() and c.census_epsilon_grey == 0:
            from .sgm_cuda import disparity_cuda

            disp, conf = disparity_cuda(
                census5x5(census_left), census5x5(census_right), left, n, c.paths, lut, c.p1,
                c.uniqueness_ratio_pct / 100.0, c.lr_max_diff_px,
            )  # fmt: skip
        else:
            with self._volume_lock:  # one call at a time per engine: they share S
                disp, conf = self._compute_cpu(left, census_left, census_right, n, lut)
        if c.speckle_window_px > 0:
            fixed = _to_fixed_point(disp)
            cv2.filterSpeckles(fixed, _INVALID_FIXED, c.speckle_window_px, c.speckle_range_px * 16)
            _invalidate_where(disp, fixed)
        invalidate_sourceless(disp, pair.rectification)
        if c.plane_smooth_radius_px > 0:
            disp = smooth_planar(disp, c.plane_smooth_radius_px)
        return DisparityMap(disp, n, pair.rectification, conf, self.name)

    def _use_cuda(self) -> bool:
        if self.config.device == "cpu":
            return False
        from .sgm_cuda import cuda_available

        if cuda_available():
            return True
        if self.config.device == "cuda":
            raise ConfigError("device='cuda' but Numba finds no CUDA device; use device='cpu' or 'auto'")
        return False

    def _compute_cpu(
        self, left: np.ndarray, census_left: np.ndarray, census_right: np.ndarray, n: int, lut: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Cost, aggregation and selection on the CPU's two cores (before speckle removal);
        ``left`` for P2's adaptation, the census of the other two for the costs."""
        c = self.config
        h, w = left.shape
        pool = _sweep_pool()
        if c.census_epsilon_grey > 0:
            census = [
                pool.submit(census_ternary, image, c.census_epsilon_grey)
                for image in (census_left, census_right)
            ]
        else:
            census = [pool.submit(census5x5, image) for image in (census_left, census_right)]
        cl, cr = (job.result() for job in census)
        paths = np.array(ROW_PATHS[c.paths], dtype=np.int64)
        # One volume S and two sweeps, one per core, each with half of the paths, in two
        # phases: first the forward sweep fills the top half of S and the backward sweep
        # the bottom half; then each goes on into the other half and adds its paths. A
        # row of S is then final, and its disparities are chosen right away while the
        # row is still in cache.
        if self._volume is None or self._volume.shape != (h, w, n):
            self._volume = None  # free the old one before allocating the new one
            self._volume = np.empty((h, w, n), dtype=np.int16)
        total = self._volume
        disp = np.empty((h, w), dtype=np.float32)
        conf = np.empty((h, w), dtype=np.float32)
        top = h // 2
        states = {fwd: sweep_state(w, n, c.paths) for fwd in (True, False)}
        uniqueness = c.uniqueness_ratio_pct / 100.0

        def run(fwd: bool, i0: int, i1: int, second_phase: bool) -> tuple:
            return aggregate_sweep(
                cl, cr, left, fwd, paths, lut, c.p1, total, i0, i1, second_phase, states[fwd],
                second_phase, uniqueness, c.lr_max_diff_px, disp, conf,
            )  # fmt: skip

        for second, phase in enumerate(
            (((True, 0, top), (False, 0, h - top)), ((True, top, h), (False, h - top, h)))
        ):
            jobs = {fwd: pool.submit(run, fwd, i0, i1, bool(second)) for fwd, i0, i1 in phase}
            states = {fwd: job.result() for fwd, job in jobs.items()}
        return disp, conf
