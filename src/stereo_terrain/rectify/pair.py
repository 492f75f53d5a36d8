"""A raw pair rectified (:func:`rectify`, :class:`RectifiedPair`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from .images import check_pair, to_grey
from .rectification import Rectification


@dataclass(frozen=True)
class RectifiedPair:
    """A rectified grey stereo pair.

    Attributes
    ----------
    left, right : (H, W) uint8
        Rectified grey images; epipolar lines are image rows.
    rectification : Rectification
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)
    rectification: Rectification


def rectify(left: np.ndarray, right: np.ndarray, rectification: Rectification) -> RectifiedPair:
    """Rectify a raw pair.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) uint8
        Raw images from the calibrated cameras (BGR is converted to grey).

    Returns
    -------
    RectifiedPair with uint8 images of :attr:`Rectification.image_size` (the raw size
    except for ``fov="keep"``, whose images are larger).
    """
    left = to_grey(left, "left image")
    right = to_grey(right, "right image")
    check_pair(left, right, rectification.calibration)
    if rectification.maps is None:
        return RectifiedPair(left, right, rectification)
    m1x, m1y, m2x, m2y = rectification.maps
    lr = cv2.remap(left, m1x, m1y, cv2.INTER_LINEAR)
    rr = cv2.remap(right, m2x, m2y, cv2.INTER_LINEAR)
    return RectifiedPair(lr, rr, rectification)
