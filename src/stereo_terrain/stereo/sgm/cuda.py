"""The SGM engine's CUDA path (Numba-CUDA): the same algorithm as the CPU engine of
:mod:`stereo_terrain.stereo.sgm`, on a GPU.

Used by :class:`stereo_terrain.stereo.sgm.SGM` when its config says ``device="cuda"`` (or
``"auto"`` and a CUDA device is present). It gives the same disparities and confidences
as the CPU kernels, bit for bit: every cost and path value is an integer, and the
sub-pixel and confidence formulas are the same float64 expressions. The test suite checks
that on Numba's CUDA simulator, so it runs on machines without a GPU; tests marked
``gpu`` run it on a real device.

Layout of the work on the device:

- **cost**: one thread per (pixel, disparity), from the two census images (computed on
  the CPU, ~1 ms, and uploaded).
- **aggregation**: one kernel launch per direction; one block per path line (a row, a
  column or a diagonal, from the image border), one thread per disparity. The block walks
  its line pixel by pixel; ``min_k L(q, k)`` is a shared-memory reduction. Each launch
  adds its path into one int16 sum (each pixel lies on exactly one line per direction,
  so the additions never race).
- **selection**: one thread per pixel for winner, uniqueness, sub-pixel and confidence;
  each accepted winner is offered to the right image's pixel with an atomic minimum of
  ``cost << 16 | d`` (lowest cost, then lowest d: the CPU's first-wins rule); a second
  kernel applies the left-right check.

The kernels compile on first use; importing this module needs no GPU. Speckle removal
runs on the host (OpenCV), as on the CPU path. 16 paths are not
implemented on the GPU (the knight moves need lines that skip rows); at most 256
disparities (one block of threads per line).
"""

from __future__ import annotations

import math

import numpy as np
from numba import cuda, int16, int32

from ...errors import ConfigError
from ..subpixel import parabola_peak
from .aggregate import NO_VALUE
from .census import MAX_CENSUS_COST

MAX_DISPARITIES = 256
_SHARED = MAX_DISPARITIES  # shared-memory row of one aggregation block

# The 8 directions (dy, dx); the 4-path set is the first four.
DIRECTIONS = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))


def cuda_available() -> bool:
    """True when Numba sees a usable CUDA device (or its simulator is switched on)."""
    try:
        return bool(cuda.is_available())
    except Exception:  # pragma: no cover - a broken driver counts as no device
        return False


@cuda.jit
def cost_kernel(cl, cr, cost):  # pragma: no cover - runs on the device
    x, y = cuda.grid(2)
    h, w = cl.shape
    if y >= h or x >= w:
        return
    a = cl[y, x]
    for d in range(cost.shape[2]):
        if x - d >= 0:
            cost[y, x, d] = cuda.popc(a ^ cr[y, x - d])
        else:
            cost[y, x, d] = MAX_CENSUS_COST


@cuda.jit
def path_kernel(cost, img, starts_y, starts_x, dy, dx, lut, p1, total):  # pragma: no cover
    line = cuda.blockIdx.x
    t = cuda.threadIdx.x
    h, w, n = cost.shape
    block = cuda.blockDim.x  # a power of two >= n
    prev = cuda.shared.array(_SHARED + 2, int32)
    red = cuda.shared.array(_SHARED, int32)
    if t == 0:
        prev[0] = NO_VALUE
        prev[n + 1] = NO_VALUE
    y = starts_y[line]
    x = starts_x[line]
    pm = 0
    first = True
    while 0 <= y < h and 0 <= x < w:
        value = NO_VALUE
        if t < n:
            c = int32(cost[y, x, t])
            if first:
                value = c
            else:
                g = abs(int32(img[y, x]) - int32(img[y - dy, x - dx]))
                jump = pm + int32(lut[g])
                v = min(min(prev[t + 1], jump), min(prev[t], prev[t + 2]) + p1)
                value = c + v - pm
            total[y, x, t] = int16(total[y, x, t] + value)
        cuda.syncthreads()  # every thread has read prev
        if t < n:
            prev[t + 1] = value
        red[t] = value
        cuda.syncthreads()
        s = block // 2
        while s > 0:
            if t < s:
                red[t] = min(red[t], red[t + s])
            cuda.syncthreads()
            s //= 2
        pm = red[0]
        cuda.syncthreads()  # red[0] read by all before the next step writes red
        first = False
        y += dy
        x += dx


@cuda.jit
def select_kernel(total, uniqueness, disp, conf, best, right):  # pragma: no cover
    x, y = cuda.grid(2)
    h, w, n = total.shape
    if y >= h or x >= w:
        return
    disp[y, x] = math.nan
    conf[y, x] = 0.0
    best[y, x] = -1
    if x < max(4, n // 4):
        return
    m = 32000
    arg = n
    for d in range(n):
        v = int32(total[y, x, d])
        if v < m:
            m = v
            arg = d
    second = 32000
    for d in range(n):
        if d < arg - 1 or d > arg + 1:
            second = min(second, int32(total[y, x, d]))
    if arg > x or second >= 32000:
        return
    conf[y, x] = float(second - m) / max(float(second), 1.0)
    if m * (1.0 + uniqueness) > second:
        return
    cuda.atomic.min(right, (y, x - arg), (m << 16) | arg)
    best[y, x] = arg
    disp[y, x] = arg
    if 0 < arg < n - 1 and arg + 1 <= x:  # both neighbours exist
        disp[y, x] = parabola_peak(arg, total[y, x, arg - 1], total[y, x, arg], total[y, x, arg + 1])


@cuda.jit
def lr_check_kernel(best, right, lr_max_diff, disp):  # pragma: no cover
    x, y = cuda.grid(2)
    h, w = best.shape
    if y >= h or x >= w:
        return
    arg = best[y, x]
    if arg >= 0 and abs((right[y, x - arg] & 0xFFFF) - arg) > lr_max_diff:
        disp[y, x] = math.nan


def line_starts(h: int, w: int, dy: int, dx: int) -> tuple[np.ndarray, np.ndarray]:
    """First pixel of every path line in direction (dy, dx): the pixels whose previous
    pixel ``(y - dy, x - dx)`` lies outside the image. Returns (ys, xs), int32."""
    ys, xs = np.mgrid[0:h, 0:w]
    py, px = ys - dy, xs - dx
    outside = (py < 0) | (py >= h) | (px < 0) | (px >= w)
    return ys[outside].astype(np.int32), xs[outside].astype(np.int32)


def disparity_cuda(
    census_left: np.ndarray,
    census_right: np.ndarray,
    left: np.ndarray,
    n: int,
    paths: int,
    p2_lut: np.ndarray,
    p1: int,
    uniqueness: float,
    lr_max_diff: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Cost, aggregation and selection on the GPU; returns (disparity, confidence) float32
    (H, W) on the host, before speckle removal (NaN where rejected)."""
    if paths not in (4, 8):
        raise ConfigError(f"the CUDA path aggregates 4 or 8 paths, got paths={paths}; use device='cpu'")
    if n > MAX_DISPARITIES:
        raise ConfigError(f"the CUDA path handles at most {MAX_DISPARITIES} disparities, got {n}")
    h, w = left.shape
    tiles = (math.ceil(w / 16), math.ceil(h / 16))
    d_cl, d_cr, d_img = cuda.to_device(census_left), cuda.to_device(census_right), cuda.to_device(left)
    d_cost = cuda.device_array((h, w, n), dtype=np.uint8)
    cost_kernel[tiles, (16, 16)](d_cl, d_cr, d_cost)
    d_total = cuda.to_device(np.zeros((h, w, n), dtype=np.int16))
    d_lut = cuda.to_device(p2_lut)
    block = 1 << (n - 1).bit_length()  # threads per line: a power of two >= n
    for dy, dx in DIRECTIONS[:paths]:
        sy, sx = (cuda.to_device(a) for a in line_starts(h, w, dy, dx))
        path_kernel[sy.shape[0], block](d_cost, d_img, sy, sx, dy, dx, d_lut, p1, d_total)
    d_disp = cuda.device_array((h, w), dtype=np.float32)
    d_conf = cuda.device_array((h, w), dtype=np.float32)
    d_best = cuda.device_array((h, w), dtype=np.int32)
    d_right = cuda.to_device(np.full((h, w), np.iinfo(np.int32).max, dtype=np.int32))
    select_kernel[tiles, (16, 16)](d_total, uniqueness, d_disp, d_conf, d_best, d_right)
    lr_check_kernel[tiles, (16, 16)](d_best, d_right, lr_max_diff, d_disp)
    return d_disp.copy_to_host(), d_conf.copy_to_host()
