"""The two cameras' focus: which image of a rectified pair is blurrier, by how much, and
the sharper one blurred to match (issue 11).

Two $20 webcams are focused by hand, or not at all, and one often sees the scene with a
pixel more of optical blur than the other. Block matching then compares a sharp patch with
a soft one: the x derivatives that OpenCV's cost is made of differ in size everywhere, and
on wood grain and near-uniform paint the wrong match can win. Blurring the sharper image
by the difference (Gaussians add in quadrature: ``sqrt(s_soft**2 - s_sharp**2)``) makes
the two alike again; it loses no detail that the other image had.

The difference is found from the images alone. Both show mostly the same scene, so the
energy of their smoothed gradients (each divided by its image's contrast at a coarse
scale, which takes out the exposure gain and hardly sees the blur) differs only by the
blur, the noise and what only one camera sees.
The smoothing (``SCALE_PX``) keeps the sensor noise, which is strongest at the finest
scale, from passing for sharpness. The sharper image is blurred more and more (a
bisection) until its energy falls to the softer one's.

On the realistic renders (blur drawn per camera, 0.5-1.5 px) the estimate is within
0.11 px of the true difference at the median and 0.35 px at p90, and picks the right image
wherever the difference exceeds 0.5 px (docs/benchmarks.md, "Fifteenth session").
"""

from __future__ import annotations

import math

import cv2
import numpy as np

#: Gaussian sigma (pixels) that both images are smoothed by before their gradient energy
#: is taken: above it the sensor noise's energy is small beside the texture's.
SCALE_PX = 1.0
#: Gaussian sigma (pixels) of the smoothing under which the images' contrast is compared
#: (the exposure gain): coarse enough that a blur difference barely changes it.
CONTRAST_SCALE_PX = 4.0
#: The largest blur difference looked for (pixels); a larger gap is not a focus
#: difference that a Gaussian explains, and nothing is blurred.
MAX_BLUR_PX = 2.0
#: Differences below this (pixels) are left alone: about the estimate's p90 error.
MIN_BLUR_PX = 0.25
#: Bisection stops when the interval is this narrow (pixels).
_TOLERANCE_PX = 0.05


def relative_blur_px(
    left: np.ndarray,
    right: np.ndarray,
    valid_left: np.ndarray | None = None,
    valid_right: np.ndarray | None = None,
    *,
    at_least_px: float = 0.0,
) -> float:
    """How much blurrier the right image is than the left: the Gaussian sigma (pixels)
    that blurs the left image into the right one's sharpness; negative when the left image
    is the blurrier (then ``-sigma`` blurs the right). 0.0 for flat images, for no common
    pixels, or when the gap is more than :data:`MAX_BLUR_PX` (module docstring).

    Parameters
    ----------
    left, right : (H, W) uint8
        Rectified images.
    valid_left, valid_right : (H, W) bool or None
        Pixels with a raw source; only pixels valid in both, away from the borders of
        that region, are counted.
    at_least_px : float
        Differences below it are reported as 0.0, found with one smoothing of the sharper
        image instead of the bisection's half dozen (a pair focused alike costs about a
        third as much).
    """
    mask = _common_mask(valid_left, valid_right, left.shape)
    if mask is not None and not mask.any():
        return 0.0
    grey_left, grey_right = left.astype(np.float32), right.astype(np.float32)
    c_left, c_right = _contrast(grey_left, mask), _contrast(grey_right, mask)
    if not (c_left > 1.0 and c_right > 1.0):
        return 0.0  # flat
    e_left = _energy(grey_left, SCALE_PX, mask) / c_left
    e_right = _energy(grey_right, SCALE_PX, mask) / c_right
    sharp, c_sharp, target, sign = (
        (grey_left, c_left, e_right, 1.0) if e_left > e_right else (grey_right, c_right, e_left, -1.0)
    )

    def sharper_after(blur_px: float) -> bool:
        """Whether the sharper image blurred by ``blur_px`` is still the sharper."""
        return _energy(sharp, math.hypot(SCALE_PX, blur_px), mask) / c_sharp > target

    if at_least_px > 0.0 and not sharper_after(at_least_px):
        return 0.0  # less than at_least_px apart
    if sharper_after(MAX_BLUR_PX):
        return 0.0
    lo, hi = at_least_px, MAX_BLUR_PX
    while hi - lo > _TOLERANCE_PX:
        mid = 0.5 * (lo + hi)
        if sharper_after(mid):
            lo = mid
        else:
            hi = mid
    return sign * 0.5 * (lo + hi)


def match_blur(
    left: np.ndarray,
    right: np.ndarray,
    valid_left: np.ndarray | None = None,
    valid_right: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """The pair with the sharper image blurred to the other's sharpness, and the blur
    difference found (:func:`relative_blur_px`; positive: the left image was blurred).

    Differences below :data:`MIN_BLUR_PX` are left alone (the images are returned as they
    are); a blurred image is a new array.
    """
    sigma = relative_blur_px(left, right, valid_left, valid_right, at_least_px=MIN_BLUR_PX)
    if sigma >= MIN_BLUR_PX:
        left = cv2.GaussianBlur(left, (0, 0), sigma)
    elif sigma <= -MIN_BLUR_PX:
        right = cv2.GaussianBlur(right, (0, 0), -sigma)
    return left, right, sigma


def _common_mask(
    valid_left: np.ndarray | None, valid_right: np.ndarray | None, shape: tuple[int, ...]
) -> np.ndarray | None:
    """Pixels valid in both images, eroded by the widest smoothing kernel's reach (the
    black outside a valid region is no texture); None when neither mask fits."""
    masks = [m for m in (valid_left, valid_right) if m is not None and m.shape == shape]
    if not masks:
        return None
    both = masks[0] if len(masks) == 1 else masks[0] & masks[1]
    reach = 2 * math.ceil(3.0 * math.hypot(SCALE_PX, MAX_BLUR_PX)) + 3
    eroded: np.ndarray = cv2.erode(both.view(np.uint8), np.ones((reach, reach), np.uint8))
    return eroded


def _energy(image: np.ndarray, sigma_px: float, mask: np.ndarray | None) -> float:
    """Mean squared gradient of ``image`` (float32) smoothed by ``sigma_px``, over ``mask``."""
    smooth = cv2.GaussianBlur(image, (0, 0), sigma_px)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1)
    return float(cv2.mean(gx * gx + gy * gy, mask=mask)[0])


def _contrast(image: np.ndarray, mask: np.ndarray | None) -> float:
    """Grey-level variance of ``image`` (float32) smoothed by :data:`CONTRAST_SCALE_PX`,
    over ``mask``: the exposure gain squared, times the scene's, and nearly blind to a
    blur a few times smaller."""
    _, std = cv2.meanStdDev(cv2.GaussianBlur(image, (0, 0), CONTRAST_SCALE_PX), mask=mask)
    return float(std[0, 0]) ** 2
