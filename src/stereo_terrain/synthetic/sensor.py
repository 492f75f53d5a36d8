"""Optics and sensor: blur, vignetting, gain and offset, noise, 8-bit quantisation."""

from __future__ import annotations

import cv2
import numpy as np

from .spec import CameraIntrinsics, SceneSpec


def _sensor(
    img: np.ndarray,
    spec: SceneSpec,
    cam: CameraIntrinsics,
    gain: float,
    offset: float,
    sigma: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Optics and sensor: blur, vignetting, gain/offset, Gaussian noise, 8-bit."""
    h, w = img.shape
    out: np.ndarray = img.astype(np.float32)
    if spec.blur_sigma_px > 0:
        out = cv2.GaussianBlur(out, (0, 0), spec.blur_sigma_px, borderType=cv2.BORDER_REFLECT)
    if spec.vignetting > 0:
        vv, uu = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((uu - cam.cx) ** 2 + (vv - cam.cy) ** 2) / (cam.cx**2 + cam.cy**2)
        out *= 1.0 - spec.vignetting * r2
    out = gain * out + offset
    if sigma > 0:
        out += rng.normal(0.0, sigma, out.shape).astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)
