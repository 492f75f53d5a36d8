"""Near-vertical edges that the grey levels show and no line segment does (issue 11).

LSD grows a segment from neighbouring pixels whose gradient directions agree. A painted
staircase's risers end against a wall or a room of nearly their own grey: across such an
end the grey level steps by 10-20 levels over four or five pixels, under webcam noise of
2-3 levels a pixel, and the gradient's direction at each pixel scatters too far for LSD to
grow a line. On realistic 57 scene 44 it found the ends of two of the five risers; the
chain stopped at two steps.

Along a vertical edge the step is the same from row to row, so :func:`plumb_segments`
averages the horizontal gradient over ``_ROWS`` rows (the noise falls threefold) and keeps
the pixels where it peaks across the row and stands ``_NOISE_K`` times above the noise
around it: the larger of the image's own (the median of the averaged gradient's size,
most of an image being flat) and the local one (:func:`_local_noise`: the vertical
gradient's, which a vertical edge has none of and a speckled face plenty; with the
image's noise alone the default profile's speckled risers gave lines enough for a false
pitch, docs/benchmarks.md, "Forty-sixth session"). The peaks of one sign on
neighbouring rows, a pixel or two apart, form a line; those at least ``min_length_px``
tall, straight and within ``_MAX_TILT_DEG`` of the image's vertical are kept, each as the
segment fitted through its peaks. Whether one is the image of a vertical line of the
scene is for :func:`~.view.vertical_edges` to say, with the rest.

Written here rather than taken from OpenCV: its detectors (LSD, Canny with a Hough
transform) use each pixel's own gradient, which is what the noise spoils; knowing the lines
sought are near vertical lets the rows be averaged first.
"""

from __future__ import annotations

import cv2
import numpy as np

from ...rectify import valid_interior
from ..photometric import smoothed

#: Rows the horizontal gradient is averaged over (pixels).
_ROWS = 9

#: A peak stands this many times the noise (an averaged gradient's robust sigma) above
#: zero.
_NOISE_K = 4.0

#: The image's noise is measured in blocks this big (pixels) as well as over the whole
#: of it; a peak stands ``_NOISE_K`` times above the larger.
_BLOCK_PX = 16

#: Most angle (deg) between a line and the image's vertical.
_MAX_TILT_DEG = 12.0

#: A line's pixels cover at least this share of its rows (one peak a row).
_MIN_FILL = 0.8

#: Peaks this many columns apart or fewer on neighbouring rows join one line; a line's
#: peaks lie within this RMS (pixels) of the straight line fitted through them.
_JOIN_PX = 2
_MAX_RMS_PX = 1.0

#: A line ends where its averaged gradient falls below this share of its mean.
_END_SHARE = 0.5


def plumb_segments(
    image: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    grad_x: np.ndarray | None = None,
    min_length_px: float = 14.0,
) -> np.ndarray:
    """The near-vertical edges of an image (the module docstring).

    Parameters
    ----------
    image : (H, W) grey image
    valid : (H, W) bool, optional
        Pixels with a source pixel (a rectified image's); the lines stay inside, away
        from its outline.
    grad_x : (H, W) float32, optional
        The image's horizontal gradient where already taken (:attr:`~..photometric.
        StereoView.gradients`, which the edges' stereo match takes too); else taken here
        the same way.
    min_length_px : float
        Shortest line kept (rows).

    Returns
    -------
    (N, 4) float64: ``x1, y1, x2, y2`` (pixel centres), the top end first.
    """
    smooth = smoothed(image)
    if grad_x is None:
        grad_x = cv2.Sobel(smooth, cv2.CV_32F, 1, 0)
    grad_y = cv2.Sobel(smooth, cv2.CV_32F, 0, 1)
    g = cv2.blur(np.asarray(grad_x, dtype=np.float32), (1, _ROWS))
    h, w = g.shape
    inside = valid_interior(valid, (h, w))  # off the valid region's outline, as the segments
    a = np.abs(g)
    if not inside.any():
        return np.empty((0, 4))
    # (every third row and column: the median of a fraction of the pixels, at a ninth of
    # the cost, is as good a scale)
    sample = a[::3, ::3][inside[::3, ::3]]
    if not len(sample):
        sample = a[inside]
    noise = float(np.median(sample)) / 0.6745
    if noise <= 0.0:
        noise = float(np.mean(sample)) or 1.0
    floor = np.maximum(noise, _local_noise(np.abs(cv2.blur(grad_y, (_ROWS, 1)))))
    peak = np.zeros((h, w), dtype=bool)
    peak[:, 1:-1] = (a[:, 1:-1] >= a[:, :-2]) & (a[:, 1:-1] > a[:, 2:])
    peak &= (a >= _NOISE_K * floor) & inside
    found = [_lines(peak & (g > 0), a, min_length_px), _lines(peak & (g < 0), a, min_length_px)]
    return np.concatenate(found)


def _local_noise(a: np.ndarray) -> np.ndarray:
    """The local noise around each pixel: the median of ``a`` (the vertical gradient
    averaged along the rows, as the horizontal one is along the columns: the same noise,
    but a vertical edge has none of it) over each ``_BLOCK_PX`` block (every other row and
    column of it), the least of it and its eight neighbours' (a horizontal edge raises a
    block's own), spread smoothly. A textured face (speckled paint, carpet) is noise to
    this search: its grains line up in near-vertical streaks a rise tall often enough that
    the ends' profile fitted a pitch to them (the default profile's scene 4, the demo's
    staircase), where a painted riser's end stands between flat greys."""
    h, w = a.shape
    sub = a[::2, ::2]
    b = _BLOCK_PX // 2
    rows, cols = sub.shape[0] // b, sub.shape[1] // b
    if rows < 1 or cols < 1:
        return np.zeros_like(a)
    tiles = sub[: rows * b, : cols * b].reshape(rows, b, cols, b).transpose(0, 2, 1, 3)
    blocks = tiles.reshape(rows, cols, -1)
    med = (np.median(blocks, axis=2) / 0.6745).astype(np.float32)
    # the quietest of each block's neighbours: a nosing's or a floor's horizontal edge in
    # a block raises its median, and a riser's end meets one at each of its corners
    med = cv2.erode(med, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    out: np.ndarray = cv2.resize(med, (w, h), interpolation=cv2.INTER_LINEAR)
    return out


def _lines(mask: np.ndarray, strength: np.ndarray, min_length_px: float) -> np.ndarray:
    """The straight, near-vertical lines among ``mask``'s peaks (:func:`plumb_segments`):
    peaks within ``_JOIN_PX`` columns of one another on neighbouring rows are one line
    (under noise a faint edge's peak wanders a pixel or two between rows). Averaging over
    ``_ROWS`` rows carries an edge's response up to half of them beyond its ends, falling
    away: a line ends at its last peaks at least ``_END_SHARE`` of its mean ``strength``
    (the averaged gradient's size), where the true end's is. Lines are kept where at
    least ``min_length_px`` rows tall, ``_MIN_FILL`` of them holding a peak, straight
    (``_MAX_RMS_PX`` about the fitted line) and within ``_MAX_TILT_DEG`` of vertical."""
    joined = cv2.dilate(mask.astype(np.uint8), np.ones((1, 2 * _JOIN_PX - 1), np.uint8))
    n, label = cv2.connectedComponents(joined, connectivity=8)
    if n <= 1:
        return np.empty((0, 4))
    ys, xs = np.nonzero(mask)
    lab = label[ys, xs]
    y, x = ys.astype(np.float64), xs.astype(np.float64)
    count = np.bincount(lab, minlength=n).astype(np.float64)
    count[count == 0] = np.inf
    my = np.bincount(lab, y, n) / count
    mx = np.bincount(lab, x, n) / count
    var_y = np.bincount(lab, y * y, n) / count - my * my
    var_x = np.bincount(lab, x * x, n) / count - mx * mx
    cov = np.bincount(lab, x * y, n) / count - mx * my
    size = strength[ys, xs]
    mean = np.bincount(lab, size, n) / count
    strong = size >= _END_SHARE * mean[lab]
    top = np.full(n, np.inf)
    bottom = np.full(n, -np.inf)
    np.minimum.at(top, lab[strong], y[strong])
    np.maximum.at(bottom, lab[strong], y[strong])
    tall = bottom - top + 1.0
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = cov / var_y  # x = mx + slope (y - my)
        rms = np.sqrt(np.maximum(var_x - cov * slope, 0.0))
    keep = (tall >= min_length_px) & np.isfinite(slope) & (rms <= _MAX_RMS_PX)
    keep &= np.abs(slope) <= np.tan(np.radians(_MAX_TILT_DEG))
    keep &= count >= _MIN_FILL * tall
    keep[0] = False  # the background
    i = np.flatnonzero(keep)
    y0, y1 = top[i], bottom[i]
    x0 = mx[i] + slope[i] * (y0 - my[i])
    x1 = mx[i] + slope[i] * (y1 - my[i])
    return np.column_stack([x0, y0, x1, y1])
