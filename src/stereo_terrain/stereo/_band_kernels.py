"""The band fill's sweep in one compiled loop (see :mod:`.bands`).

A band holds thousands of pixels and is tried at a few hundred disparities for each of
two plane families: the correlation of each hypothesis is one pass over the band, which
NumPy would make a dozen array passes (and a remap) per hypothesis.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def zncc_sweep(
    us: np.ndarray,
    vs: np.ndarray,
    ratio: np.ndarray,
    left_values: np.ndarray,
    right_image: np.ndarray,
    centre_disparities: np.ndarray,
    doffs: float,
) -> np.ndarray:  # pragma: no cover - compiled
    """Zero-mean normalised correlation of ``left_values`` (the band's pixels ``us, vs`` in
    the left image) with ``right_image`` sampled (linearly along the row) at ``u - d``,
    for each plane of a family: the plane whose disparity at the band's centre is
    ``centre_disparities[k]`` gives pixel ``i`` the disparity ``(dc + doffs) * ratio[i] -
    doffs``. NaN where under 80% of the band falls inside the right image or either side
    is flat."""
    n = us.shape[0]
    w = right_image.shape[1]
    out = np.full(centre_disparities.shape[0], np.nan)
    for k in range(centre_disparities.shape[0]):
        dc = centre_disparities[k] + doffs
        sa = 0.0
        sb = 0.0
        sab = 0.0
        saa = 0.0
        sbb = 0.0
        m = 0
        for i in range(n):
            x = us[i] - (dc * ratio[i] - doffs)
            if x < 0.0 or x > w - 2:
                continue
            x0 = int(x)
            fx = x - x0
            y = int(vs[i])
            b = right_image[y, x0] * (1.0 - fx) + right_image[y, x0 + 1] * fx
            a = left_values[i]
            sa += a
            sb += b
            sab += a * b
            saa += a * a
            sbb += b * b
            m += 1
        if m < 0.8 * n or m == 0:
            continue
        ma = sa / m
        mb = sb / m
        va = saa / m - ma * ma
        vb = sbb / m - mb * mb
        if va <= 0.0 or vb <= 0.0:
            continue
        out[k] = (sab / m - ma * mb) / math.sqrt(va * vb)
    return out
