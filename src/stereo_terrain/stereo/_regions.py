"""Connected regions of a binary image with OpenCV's statistics, faster (issue 13).

``cv2.connectedComponentsWithStats`` spends four fifths of its time on the statistics
(1.6 of 2.0 ms at 640x480, on the fill's worker thread while the matcher runs); the
labels alone take 0.4 ms and one compiled pass over them gives the same statistics.
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _label_stats(labels: np.ndarray, count: int) -> np.ndarray:  # pragma: no cover - compiled
    """``(count, 5)`` int32: left, top, width, height and area of each label."""
    h, w = labels.shape
    x0 = np.full(count, w, np.int64)
    y0 = np.full(count, h, np.int64)
    x1 = np.full(count, -1, np.int64)
    y1 = np.full(count, -1, np.int64)
    area = np.zeros(count, np.int64)
    for y in range(h):
        x = 0
        while x < w:  # one run of a label at a time: a compare per pixel
            k = labels[y, x]
            start = x
            while x < w and labels[y, x] == k:
                x += 1
            area[k] += x - start
            if start < x0[k]:
                x0[k] = start
            if x - 1 > x1[k]:
                x1[k] = x - 1
            if y < y0[k]:
                y0[k] = y
            y1[k] = y  # rows come in order
    out = np.empty((count, 5), np.int32)
    for k in range(count):
        out[k, 0], out[k, 1] = x0[k], y0[k]
        out[k, 2], out[k, 3] = x1[k] - x0[k] + 1, y1[k] - y0[k] + 1
        out[k, 4] = area[k]
    return out


def connected_regions(binary: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """``cv2.connectedComponentsWithStats(binary, connectivity=4)`` without the centroids.

    Parameters
    ----------
    binary : (H, W) uint8, non-zero = foreground

    Returns
    -------
    count : int, labels including the background 0
    labels : (H, W) int32
    stats : (count, 5) int32, OpenCV's ``x, y, width, height, area`` (the same values)
    """
    count, labels = cv2.connectedComponents(binary, connectivity=4, ltype=cv2.CV_32S)
    stats = _label_stats(labels, count)
    if stats[0, 4] == 0:  # no background pixel: OpenCV's own (odd) values for an empty label
        count, labels, stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=4)
    return count, labels, stats
