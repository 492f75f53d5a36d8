"""Kernel warm-up: the pipeline run once on a tiny pair so that the first real frame costs
about what a steady one does (:func:`warm_up_kernels`)."""

from __future__ import annotations

import dataclasses
import logging
from typing import Any

import cv2
import numpy as np

from ..calibration import StereoCalibration
from ..frames import R_BODY_OPTICAL, Rig, Transform
from ..gravity import load_gravity_kernels
from ..stereo import DisparityBackend
from ..stereo._regions import warm_up as warm_up_fill_kernels
from ..stereo.bands import warm_up as warm_up_bands
from ..stereo.manhattan import warm_up as warm_up_manhattan
from .config import PipelineConfig

#: Configurations already warmed up in this process (see :func:`warm_up_kernels`).
_WARMED: set[tuple[Any, ...]] = set()
#: Size of the warm-up pair (pixels) and its rig: a level camera 0.5 m above the floor.
_WARM_SIZE, _WARM_FOCAL_PX, _WARM_BASELINE_M, _WARM_HEIGHT_M = (160, 120), 100.0, 0.1, 0.5


def _warm_up_scene() -> tuple[StereoCalibration, Rig, np.ndarray, np.ndarray]:
    """A tiny ideal rig looking at two steps, and its pair: a textured image warped by the
    scene's disparity, with an untextured face for the planar fill. Only its shape
    matters (every stage must find something to work on), not its accuracy."""
    w, h = _WARM_SIZE
    f, B, cam_h = _WARM_FOCAL_PX, _WARM_BASELINE_M, _WARM_HEIGHT_M
    K = np.array([[f, 0.0, w / 2], [0.0, f, h / 2], [0.0, 0.0, 1.0]])
    calib = StereoCalibration(
        K, np.zeros(5), K.copy(), np.zeros(5), np.eye(3), np.array([-B, 0.0, 0.0]), (w, h)
    )
    T_body_camera = Transform.from_rt(R_BODY_OPTICAL, [0.0, 0.0, cam_h], "body", "camera")
    # Depth of each pixel: floor, two 0.2 m steps (risers at 1.0 and 1.3 m), a wall at 1.6 m.
    ray_down = (np.arange(h, dtype=np.float64)[:, None] - h / 2 + 0.5) / f  # y / Z along each row
    depth = np.full((h, 1), 1.6)
    for riser_m, top_m in ((1.3, 2 * 0.2), (1.0, 0.2), (np.inf, 0.0)):  # far to near
        with np.errstate(divide="ignore"):
            on_top = np.where(ray_down > 0, (cam_h - top_m) / ray_down, np.inf)  # this level's floor
        hits_riser = (ray_down * riser_m <= cam_h - top_m + 0.2) if np.isfinite(riser_m) else True
        level = np.where(on_top < riser_m, on_top, riser_m)
        depth = np.where((on_top < depth) | (hits_riser & (level < depth)), np.minimum(level, depth), depth)
    disparity = np.broadcast_to(f * B / depth, (h, w)).astype(np.float32)
    rng = np.random.default_rng(0)
    left = cv2.GaussianBlur(rng.integers(0, 256, (h, w)).astype(np.uint8), (3, 3), 0.8)
    left[h // 2 + 22 : h // 2 + 36, w // 4 : 3 * w // 4] = 128  # an untextured riser face
    xs = np.arange(w, dtype=np.float32)[None, :] + disparity  # right(x) = left(x + d)
    ys = np.broadcast_to(np.arange(h, dtype=np.float32)[:, None], (h, w))
    right = cv2.remap(left, np.ascontiguousarray(xs), np.ascontiguousarray(ys), cv2.INTER_LINEAR)
    return calib, Rig(T_body_camera), left, right


def warm_up_kernels(
    config: PipelineConfig, *, with_rig: bool = True, backend: DisparityBackend | None = None
) -> None:
    """Run the pipeline of ``config`` once on a tiny rendered-by-warping pair, so that every
    compiled (Numba) kernel its stages use is loaded from the cache (or compiled) now rather
    than in the first real frame. Once per process and configuration of the compiled
    stages (backend and its device, plane method, fill, with or without a rig); a few
    milliseconds when already cached on disk."""
    key = (
        config.backend,
        getattr(config.sgm, "device", None) if config.backend == "sgm" else None,
        config.method,
        config.fill.enabled,
        config.fill.texture,
        config.fill.manhattan,
        config.bands.enabled,
        with_rig,
        None if backend is None else type(backend).__name__,
    )
    if key in _WARMED:
        return
    calib, rig, left, right = _warm_up_scene()
    warm_config = dataclasses.replace(
        config,
        max_disparity_px=None,
        drift=dataclasses.replace(config.drift, online=False),
        rectify_fov="valid",
    )
    from .core import Pipeline  # not at the top: core imports this module (Pipeline(...) warms up)

    try:
        pipeline = Pipeline(calib, rig if with_rig else None, warm_config, backend=backend, warm_up=False)
        pipeline.run(left, right)
        load_gravity_kernels()  # the rig check's, which a rig that agrees with the pair skips
        if config.fill.enabled:
            warm_up_fill_kernels()  # the planar fill's, for frames that have a region
            if config.fill.manhattan:
                warm_up_manhattan()
        if config.bands.enabled:
            warm_up_bands()  # the band fill's, for frames whose warm-up pair has no band
    except Exception:  # an optimisation only: a config the tiny pair does not suit runs cold
        logging.getLogger(__name__).debug("kernel warm-up skipped", exc_info=True)
    _WARMED.add(key)
