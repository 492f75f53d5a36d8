"""A rectified pair with the sensor's noise taken out, for a second opinion (issue 11).

A cheap webcam's noise is a few grey levels per pixel, and after its own smoothing and
JPEG it is blotchy rather than pixel-fine: spots a few pixels across that differ between
the two cameras. On a painted riser or a plain wall whose own texture is a few grey levels
too, those spots are most of what the matcher sees, and it matches them to anything.
Non-local means (Buades, Coll & Morel 2005; OpenCV's ``fastNlMeansDenoising``) averages
each patch with the patches of its neighbourhood that look like it: it keeps edges, the
nosings' dark strips and a face's shading, and removes the noise that no other patch
repeats. A Gaussian blur of the same strength removes the edges with the noise (a 0.8 px
pre-blur measured mixed, docs/benchmarks.md, "Twenty-ninth session"), and a bilateral
filter keeps the blotches, which are edges at its scale.

Non-local means also takes away texture as weak as the noise, and makes a surface's
fine detail flatter, which costs the rises of staircases that the plain pair measures
well; so it is a later opinion's input, not the first matcher's (docs/benchmarks.md,
"Thirtieth session").
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from ..rectify import RectifiedPair

#: Side (pixels) of the patches compared, and of the window searched for alike patches:
#: OpenCV's recommended 7 and 21 cost 2-3x the time of these for the same matches here.
TEMPLATE_PX = 5
SEARCH_PX = 15


def denoise_image(image: np.ndarray, strength_grey: float) -> np.ndarray:
    """``image`` (H, W) uint8 with non-local means of filter strength ``strength_grey``
    (OpenCV's ``h``, grey levels: about the noise's standard deviation)."""
    if image.dtype != np.uint8 or image.ndim != 2:
        raise ValueError(f"denoise_image takes an (H, W) uint8 image, got {image.dtype} {image.shape}")
    return cv2.fastNlMeansDenoising(image, None, float(strength_grey), TEMPLATE_PX, SEARCH_PX)


def denoise_pair(pair: RectifiedPair, strength_grey: float) -> RectifiedPair:
    """``pair`` with both images denoised alike (:func:`denoise_image`)."""
    return dataclasses.replace(
        pair, left=denoise_image(pair.left, strength_grey), right=denoise_image(pair.right, strength_grey)
    )
