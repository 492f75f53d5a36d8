"""The SGM engine: the stages of :mod:`stereo_terrain.stereo.sgm` on one rectified pair."""

from __future__ import annotations

import threading

import cv2
import numpy as np

from ...errors import ConfigError, InputError
from ...rectify import RectifiedPair
from .. import DisparityMap, check_max_disparity, invalidate_sourceless
from ..smooth import smooth_planar
from .aggregate import ROW_PATHS, aggregate_sweep, p2_table, sweep_state
from .census import census5x5, census_ternary
from .config import SGMConfig
from .select import MAX_DISPARITIES
from .speckle import remove_speckles
from .threads import sweep_pool


class SGM:
    """The project's SGM engine behind the :class:`DisparityBackend` interface."""

    name = "sgm"

    def __init__(self, config: SGMConfig | None = None) -> None:
        self.config = config or SGMConfig()
        # S is kept for the next call of the same size: a fresh 39-79 MB array costs one
        # page fault per 4 KB on first touch, measured 5 ms per frame at 640x480x64.
        self._volume: np.ndarray | None = None
        self._volume_lock = threading.Lock()

    def compute(self, pair: RectifiedPair, max_disparity_px: int) -> DisparityMap:
        left, right = pair.left, pair.right
        if left.dtype != np.uint8 or left.ndim != 2 or left.shape != right.shape:
            raise InputError(
                f"SGM needs two (H, W) uint8 images of one size, got {left.shape} {left.dtype} and "
                f"{right.shape} {right.dtype}"
            )
        n = check_max_disparity(max_disparity_px, left.shape[1])
        if n > MAX_DISPARITIES:
            raise InputError(f"the SGM engine handles at most {MAX_DISPARITIES} disparities, got {n}")
        c = self.config
        lut = p2_table(c.p1, c.p2, c.p2_gradient_scale)
        # What the census sees; P2's adaptation keeps the sharp left image.
        census_left, census_right = left, right
        if c.census_blur_sigma_px > 0:
            census_left, census_right = (
                cv2.GaussianBlur(image, (0, 0), c.census_blur_sigma_px) for image in (left, right)
            )
        if self._use_cuda() and c.census_epsilon_grey == 0:
            from .cuda import disparity_cuda

            disp, conf = disparity_cuda(
                census5x5(census_left), census5x5(census_right), left, n, c.paths, lut, c.p1,
                c.uniqueness_ratio_pct / 100.0, c.lr_max_diff_px,
            )  # fmt: skip
        else:
            with self._volume_lock:  # one call at a time per engine: they share S
                disp, conf = self._compute_cpu(left, census_left, census_right, n, lut)
        if c.speckle_window_px > 0:
            remove_speckles(disp, c.speckle_window_px, c.speckle_range_px)
        invalidate_sourceless(disp, pair.rectification)
        if c.plane_smooth_radius_px > 0:
            disp = smooth_planar(disp, c.plane_smooth_radius_px)
        return DisparityMap(disp, n, pair.rectification, conf, self.name)

    def _use_cuda(self) -> bool:
        if self.config.device == "cpu":
            return False
        from .cuda import cuda_available

        if cuda_available():
            return True
        if self.config.device == "cuda":
            raise ConfigError("device='cuda' but Numba finds no CUDA device; use device='cpu' or 'auto'")
        return False

    def _compute_cpu(
        self, left: np.ndarray, census_left: np.ndarray, census_right: np.ndarray, n: int, lut: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Cost, aggregation and selection on the CPU's two cores (before speckle removal);
        ``left`` for P2's adaptation, the census of the other two for the costs."""
        c = self.config
        h, w = left.shape
        pool = sweep_pool()
        if c.census_epsilon_grey > 0:
            census = [
                pool.submit(census_ternary, image, c.census_epsilon_grey)
                for image in (census_left, census_right)
            ]
        else:
            census = [pool.submit(census5x5, image) for image in (census_left, census_right)]
        cl, cr = (job.result() for job in census)
        paths = np.array(ROW_PATHS[c.paths], dtype=np.int64)
        # One volume S and two sweeps, one per core, each with half of the paths, in two
        # phases: first the forward sweep fills the top half of S and the backward sweep
        # the bottom half; then each goes on into the other half and adds its paths. A
        # row of S is then final, and its disparities are chosen right away while the
        # row is still in cache.
        if self._volume is None or self._volume.shape != (h, w, n):
            self._volume = None  # free the old one before allocating the new one
            self._volume = np.empty((h, w, n), dtype=np.int16)
        total = self._volume
        disp = np.empty((h, w), dtype=np.float32)
        conf = np.empty((h, w), dtype=np.float32)
        top = h // 2
        states = {fwd: sweep_state(w, n, c.paths) for fwd in (True, False)}
        uniqueness = c.uniqueness_ratio_pct / 100.0

        def run(fwd: bool, i0: int, i1: int, second_phase: bool) -> tuple:
            return aggregate_sweep(
                cl, cr, left, fwd, paths, lut, c.p1, total, i0, i1, second_phase, states[fwd],
                second_phase, uniqueness, c.lr_max_diff_px, disp, conf,
            )  # fmt: skip

        for second, phase in enumerate(
            (((True, 0, top), (False, 0, h - top)), ((True, top, h), (False, h - top, h)))
        ):
            jobs = {fwd: pool.submit(run, fwd, i0, i1, bool(second)) for fwd, i0, i1 in phase}
            states = {fwd: job.result() for fwd, job in jobs.items()}
        return disp, conf
