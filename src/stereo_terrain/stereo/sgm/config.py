"""The SGM engine's parameters."""

from __future__ import annotations

from dataclasses import dataclass

from ...checks import check_fields, check_min
from ...errors import ConfigError


@dataclass(frozen=True)
class SGMConfig:
    """Parameters of the SGM engine (costs are in census bits, 0-24).

    Attributes
    ----------
    paths : int
        Aggregation directions: 4 (rows and columns), 8 (and diagonals) or 16 (and the
        knight moves (+-1, +-2), (+-2, +-1)).
    p1 : int
        Penalty for disparity changes of 1 px.
    p2 : int
        Penalty for larger changes (before adaptation to the image gradient).
    p2_gradient_scale : float
        Grey levels of intensity change that halve P2.
    uniqueness_ratio_pct : int
        The best cost must beat the second best (outside +-1 px) by this margin.
    lr_max_diff_px : float
        Left-right consistency tolerance.
    speckle_window_px, speckle_range_px : int
        Speckle filter (OpenCV's filterSpeckles on the result).
    census_blur_sigma_px : float
        Gaussian blur (sigma, pixels) of both images before the census transform; 0 for
        none (the default). On weakly textured faces the census bits of a 5x5 window
        follow sensor noise; a blur of about 1 px makes them follow the faint shading
        instead. It costs detail: see Notes. P2's adaptation always uses the sharp image.
    census_epsilon_grey : int
        0 (the default): the plain census. Above 0: the ternary census
        (:func:`census_ternary`), in which a neighbour within this many grey levels of
        the centre counts as equal to it, so that sensor noise and JPEG ringing on a
        near-uniform face give flat costs and the disparity comes from the face's outline
        through SGM's paths. CPU only.
    plane_smooth_radius_px : int
        0 (the default) for none; above 0, the disparities are replaced by the value of
        the least-squares plane through the valid disparities of the ``(2 r + 1)``-square
        window around each pixel, and pixels more than 1 px off it are dropped
        (:func:`~stereo_terrain.stereo.smooth.smooth_planar`). This undoes the whole-pixel
        terraces SGM leaves on faces where the costs are flat.
    device : str
        ``cpu`` (Numba, the default), ``cuda`` (Numba-CUDA, :mod:`.cuda`; 4 or 8 paths,
        at most 256 disparities; same result as the CPU) or ``auto`` (CUDA when a device is
        present, else CPU).

    Notes
    -----
    P1 and P2 were chosen by ``benchmarks/tune_sgm.py`` on the eight Middlebury 2014
    quarter-size scenes (the lowest mean bad-2.0 on a small grid; those scenes are also
    the evaluation set, as ``docs/benchmarks.md`` says beside them). A uniqueness ratio of
    2% scores better there (bad-2.0 counts holes as errors) but finds fewer rendered
    staircases than 5% (``docs/benchmarks.md``), so the default keeps 5%.

    ``census_blur_sigma_px: 1.0`` (``docs/benchmarks.md``, "Census on a blurred image")
    lifts the pipeline's detection in weakly textured scenes from 69% to 83% (OpenCV: 83%),
    and raises the mean Middlebury bad-2.0 from 13.0% to 16.2% (still below OpenCV's best
    mode on every scene). It lowers detection at 320x240, so it is not the default.
    """

    paths: int = 8
    p1: int = 14
    p2: int = 80
    p2_gradient_scale: float = 16.0
    uniqueness_ratio_pct: int = 5
    lr_max_diff_px: float = 1.0
    speckle_window_px: int = 100
    speckle_range_px: int = 2
    census_blur_sigma_px: float = 0.0
    census_epsilon_grey: int = 0
    plane_smooth_radius_px: int = 0
    device: str = "cpu"

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 0, "lr_max_diff_px", "speckle_window_px", "speckle_range_px")
        if self.speckle_window_px > 1_000_000 or self.speckle_range_px > 1_000:
            raise ConfigError(
                "speckle_window_px must be at most 1000000 and speckle_range_px at most 1000, got "
                f"{self.speckle_window_px} and {self.speckle_range_px}"
            )
        if self.paths not in (4, 8, 16):
            raise ConfigError(f"paths must be 4, 8 or 16, got {self.paths}")
        if not 0 < self.p1 < self.p2 <= 255:
            raise ConfigError(f"need 0 < p1 < p2 <= 255, got p1={self.p1}, p2={self.p2}")
        if self.p2_gradient_scale <= 0:
            raise ConfigError("p2_gradient_scale must be > 0")
        if not 0.0 <= self.census_blur_sigma_px <= 10.0:
            raise ConfigError(
                "census_blur_sigma_px must be between 0 (no blur) and 10 pixels, "
                f"got {self.census_blur_sigma_px}"
            )
        if not 0 <= self.census_epsilon_grey <= 64:
            raise ConfigError(
                f"census_epsilon_grey must be between 0 (plain census) and 64, got {self.census_epsilon_grey}"
            )
        if self.census_epsilon_grey > 0 and self.device == "cuda":
            raise ConfigError(
                "census_epsilon_grey > 0 (the ternary census) runs on the CPU only; "
                "use device='cpu' or 'auto'"
            )
        if not 0 <= self.plane_smooth_radius_px <= 50:
            raise ConfigError(
                f"plane_smooth_radius_px must be between 0 (off) and 50, got {self.plane_smooth_radius_px}"
            )
        if not 0 <= self.uniqueness_ratio_pct < 100:
            raise ConfigError("uniqueness_ratio_pct must be in [0, 100)")
        if self.device not in ("cpu", "cuda", "auto"):
            raise ConfigError(f"device must be cpu, cuda or auto, got '{self.device}'")
