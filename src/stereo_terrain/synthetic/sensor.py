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
    jpeg_quality: int | None = None,
    blur_sigma_px: float | None = None,
) -> np.ndarray:
    """Optics and sensor: blur, vignetting, gain/offset, noise, 8-bit, JPEG.

    The noise is Gaussian with variance ``sigma**2 + spec.shot_noise * grey`` (grey: the
    noise-free level, clipped at 0); ``blur_sigma_px`` (None: the spec's) blurs the optics;
    ``jpeg_quality`` (1..100) encodes and decodes the
    8-bit image as a webcam's MJPEG stream would (OpenCV's baseline JPEG).
    """
    h, w = img.shape
    out: np.ndarray = img.astype(np.float32)
    blur = spec.blur_sigma_px if blur_sigma_px is None else blur_sigma_px
    if blur > 0:
        out = cv2.GaussianBlur(out, (0, 0), blur, borderType=cv2.BORDER_REFLECT)
    if spec.vignetting > 0:
        vv, uu = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((uu - cam.cx) ** 2 + (vv - cam.cy) ** 2) / (cam.cx**2 + cam.cy**2)
        out *= 1.0 - spec.vignetting * r2
    out = gain * out + offset
    if spec.shot_noise > 0:
        std = np.sqrt(sigma * sigma + spec.shot_noise * np.maximum(out, 0.0)).astype(np.float32)
        out += std * rng.standard_normal(out.shape).astype(np.float32)
    elif sigma > 0:
        out += rng.normal(0.0, sigma, out.shape).astype(np.float32)
    img8 = np.clip(np.rint(out), 0, 255).astype(np.uint8)
    if jpeg_quality is not None:
        ok, buf = cv2.imencode(".jpg", img8, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
        if not ok:  # pragma: no cover - OpenCV encodes any 8-bit grey image
            raise RuntimeError("JPEG encoding failed")
        img8 = np.asarray(cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE), dtype=np.uint8)
    return img8
