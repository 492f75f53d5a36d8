"""Compiled inner loop of the grid sample (Numba, :func:`stereo_terrain.cloud.sample_disparity`).

Per grid cell: the validity test of the centre and of its four neighbours' boxes, the
four neighbours' mean disparities reprojected, the normal from their cross product, and
the centre point. In NumPy that was a dozen fancy-indexed temporaries per frame (issue
13: two thirds of the cloud stage); here it is one pass over the cells. The arithmetic is
NumPy's, operation for operation and in the same precisions (float32 where NumPy computed
in float32), so the sample is the same bit for bit. Compiled on first use and cached on
disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)  # no fastmath: NumPy's roundings, in NumPy's order
def grid_cells_normals(
    valid: np.ndarray,
    density: np.ndarray,
    acc: np.ndarray,
    dd: np.ndarray,
    rr: np.ndarray,
    cc: np.ndarray,
    ru: np.ndarray,
    rd: np.ndarray,
    cl: np.ndarray,
    cr: np.ndarray,
    fb: float,
    cx: float,
    cy: float,
    f: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """The grid cells kept and their normals and points (see ``sample_disparity``).

    Parameters
    ----------
    valid : (H, W) bool, disparity in the depth range
    density : (H, W) float32, box mean of ``valid``
    acc : (H, W) float32, box mean of the valid disparities (0 elsewhere)
    dd : (H, W) float32, disparity plus the rectification's ``doffs``
    rr, cc, ru, rd, cl, cr : (N,) int64, the grid layout (centre row and column, the
        rows above and below, the columns left and right)
    fb, cx, cy, f : float, focal length times baseline (px m), principal point and focal
        length (px)

    Returns
    -------
    cells : (M,) int64, indices into the layout of the cells kept
    normals : (M, 3) float64, unit (not signed)
    points : (M, 3) float64, metres, rectified camera frame
    """
    n = rr.shape[0]
    cells = np.empty(n, np.int64)
    normals = np.empty((n, 3))
    points = np.empty((n, 3))
    thr = np.float32(0.6)
    fb32 = np.float32(fb)  # NumPy divides a Python float by a float32 array in float32
    m = 0
    for i in range(n):
        r, c, u, dn, le, ri = rr[i], cc[i], ru[i], rd[i], cl[i], cr[i]
        if not (
            valid[r, c]
            and density[r, le] > thr
            and density[r, ri] > thr
            and density[u, c] > thr
            and density[dn, c] > thr
        ):
            continue
        # Mean disparity of each neighbour's box (float32), its depth (float32), then the
        # point's x, y in float64, as NumPy's mixed-precision expressions compute them.
        z_r = np.float32(fb32 / np.float32(acc[r, ri] / density[r, ri]))
        z_l = np.float32(fb32 / np.float32(acc[r, le] / density[r, le]))
        z_d = np.float32(fb32 / np.float32(acc[dn, c] / density[dn, c]))
        z_u = np.float32(fb32 / np.float32(acc[u, c] / density[u, c]))
        ax = (ri - cx) * np.float64(z_r) / f - (le - cx) * np.float64(z_l) / f
        ay = (r - cy) * np.float64(z_r) / f - (r - cy) * np.float64(z_l) / f
        az = np.float64(z_r) - np.float64(z_l)
        bx = (c - cx) * np.float64(z_d) / f - (c - cx) * np.float64(z_u) / f
        by = (dn - cy) * np.float64(z_d) / f - (u - cy) * np.float64(z_u) / f
        bz = np.float64(z_d) - np.float64(z_u)
        nx = ay * bz - az * by
        ny = az * bx - ax * bz
        nz = ax * by - ay * bx
        norm = np.sqrt(nx * nx + ny * ny + nz * nz)
        if not (norm > 0.0 and np.isfinite(norm)):
            continue
        cells[m] = i
        normals[m, 0], normals[m, 1], normals[m, 2] = nx / norm, ny / norm, nz / norm
        z = fb / np.float64(dd[r, c])
        points[m, 0] = (c - cx) * z / f
        points[m, 1] = (r - cy) * z / f
        points[m, 2] = z
        m += 1
    return cells[:m], normals[:m], points[:m]
