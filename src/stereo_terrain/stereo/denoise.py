"""A rectified pair with the sensor's noise taken out, for a second opinion (issue 11).

A cheap webcam's noise is a few grey levels per pixel, and after its own smoothing and
JPEG it is blotchy rather than pixel-fine: spots a few pixels across that differ between
the two cameras. On a painted riser or a plain wall whose own texture is a few grey levels
too, those spots are most of what the matcher sees, and it matches them to anything.
Non-local means (Buades, Coll & Morel 2005; OpenCV's ``fastNlMeansDenoising``) averages
each patch with the patches of its neighbourhood that look like it: it keeps edges, the
nosings' dark strips and a face's shading, and removes the noise that no other patch
repeats. A Gaussian blur of the same strength removes the edges with the noise (a 0.8 px
pre-blur measured mixed, docs/benchmarks.md, "Twenty-ninth session"); a bilateral filter,
which keeps whatever looks like an edge at its scale, found less ("Thirtieth session").

Non-local means also takes away texture as weak as the noise, and makes a surface's
fine detail flatter, which costs the rises of staircases that the plain pair measures
well; so it is a later opinion's input, not the first matcher's (docs/benchmarks.md,
"Thirtieth session").
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from ..errors import InputError
from ..rectify import RectifiedPair

#: Side (pixels) of the patches compared, and of the window searched for alike patches.
#: OpenCV's recommended 7 and 21 take about 1.35x the time here; a 9 px search takes about
#: 0.4x and finds a little less (docs/benchmarks.md, "Thirtieth session").
TEMPLATE_PX = 5
SEARCH_PX = 15
#: The strongest filter taken (grey levels; ``PipelineConfig.rematch_denoised``): a
#: webcam's noise is a few, and 50 flattens any texture.
MAX_STRENGTH_GREY = 50.0


def denoise_image(image: np.ndarray, strength_grey: float) -> np.ndarray:
    """One grey image with non-local means (OpenCV's ``fastNlMeansDenoising``).

    Parameters
    ----------
    image : (H, W) uint8
    strength_grey : float
        The filter strength (OpenCV's ``h``, grey levels): about the noise's standard
        deviation; larger removes more texture with the noise.

    Returns
    -------
    (H, W) uint8
        The image denoised; edges and texture stronger than the noise stay.
    """
    if image.dtype != np.uint8 or image.ndim != 2:
        raise InputError(f"denoise_image takes an (H, W) uint8 image, got {image.dtype} {image.shape}")
    return cv2.fastNlMeansDenoising(image, None, float(strength_grey), TEMPLATE_PX, SEARCH_PX)


def denoise_pair(pair: RectifiedPair, strength_grey: float) -> RectifiedPair:
    """``pair`` with both images denoised alike (:func:`denoise_image`); the same
    rectification."""
    return dataclasses.replace(
        pair, left=denoise_image(pair.left, strength_grey), right=denoise_image(pair.right, strength_grey)
    )
