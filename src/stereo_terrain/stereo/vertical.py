"""Per-frame correction of a residual vertical misalignment between rectified images.

Cheap webcams leave 0.5-3 px of vertical disparity after rectification (a mount that
creeps, rolling shutters, a calibration of a few views). A horizontal matcher then
compares rows that show different things: the census windows of strongly row-structured
content (step edges, plank gaps, wood grain) disagree and the disparities break up or go
wrong. Turning the rig back by the online drift correction (:mod:`stereo_terrain.drift`)
needs features and many frames; this stage instead measures the offset of *this* frame
and shifts the right image by it before matching.

How (about 3 ms at 640x480):

1. The images are cut into a grid of ``tiles_y x tiles_x`` tiles. The left tile is
   phase-correlated (``cv2.phaseCorrelate``, Hanning window) with the right tile at the
   same rows, ``tile_disparity_px`` to the left (a typical disparity, so that most of the
   content is shared). Phase correlation finds the dominant 2-D translation of the tile:
   its x part is a disparity (blurred where the disparity varies over the tile), its y
   part the vertical offset, to about 0.1 px.
2. A line ``dy(x) = offset + slope * (x - cx)`` (a vertical shift plus a small roll) is
   fitted to the tiles whose correlation peak is at least ``min_response``, the worst
   tile dropped while any is further than ``max_spread_px`` from the line.
3. The right image is resampled at ``y + dy(x)`` (one affine warp) only when the fit is
   trusted (at least ``min_tiles`` tiles agree) and the correction moves some pixel by at
   least ``min_correction_px``: a well-rectified pair, or one without the texture to
   measure, is left exactly as it was.

Row profiles of vertical strips (the mean grey level of each row) were tried first: on
rendered staircases they failed to measure half the pairs and were 0.3-0.5 px off on
the rest, since averaged noise texture carries little of the offset.

The rectified right camera (``P2``, ``Q``) is not changed: the shift is taken to be an
error of the image, not of the geometry, and depth is that of the calibration.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..rectify import RectifiedPair


@dataclass(frozen=True)
class VerticalAlignConfig:
    """Parameters of the per-frame vertical alignment.

    Attributes
    ----------
    enabled : bool
        Measure and correct every frame (default True).
    tiles_x, tiles_y : int
        Grid of tiles that are phase-correlated.
    tile_width_px, tile_height_px : int
        Tile size, pixels (clipped to the image).
    tile_disparity_px : int
        The right tile is taken this far to the left of the left tile.
    min_response : float
        Phase-correlation peak (``cv2.phaseCorrelate``'s response) a tile must reach.
    max_offset_px : float
        Tiles that measure a larger vertical offset are outliers (cheap webcams leave up
        to about 3 px; a larger error needs the drift correction or a recalibration).
    min_tiles : int
        Tiles that must agree for a correction.
    max_spread_px : float
        Largest disagreement of a tile with the fitted line, pixels.
    min_correction_px : float
        Corrections that move no pixel by this much are not applied (a bilinear shift
        smooths the image a little, which costs more than a tiny misalignment).
    """

    enabled: bool = True
    tiles_x: int = 4
    tiles_y: int = 3
    tile_width_px: int = 160
    tile_height_px: int = 96
    tile_disparity_px: int = 24
    min_response: float = 0.1
    max_offset_px: float = 4.0
    min_tiles: int = 4
    max_spread_px: float = 0.5
    min_correction_px: float = 0.3

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "tiles_x", "tiles_y", "min_tiles")
        check_min(self, 16, "tile_width_px", "tile_height_px")
        check_min(self, 0, "tile_disparity_px")
        if self.min_tiles > self.tiles_x * self.tiles_y:
            raise ConfigError(
                f"VerticalAlignConfig.min_tiles ({self.min_tiles}) must not exceed the "
                f"{self.tiles_x * self.tiles_y} tiles"
            )
        if not 0.0 <= self.min_response < 1.0:
            raise ConfigError(f"VerticalAlignConfig.min_response must be in [0, 1), got {self.min_response}")
        for name in ("max_offset_px", "max_spread_px", "min_correction_px"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"VerticalAlignConfig.{name} must be > 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class VerticalOffset:
    """The measured vertical offset of the right image: right row ``y + dy(x)`` shows what
    left row ``y`` shows, ``dy(x) = offset_px + slope * (x - centre_px)``.

    Attributes
    ----------
    offset_px : float
    slope : float
        Pixels of offset per pixel of x (a roll of about ``slope`` radians).
    centre_px : float
    tiles_used : int
        Tiles that entered the fit (0: nothing was measured).
    applied : bool
        Whether the right image was shifted.
    reason : str
    """

    offset_px: float = 0.0
    slope: float = 0.0
    centre_px: float = 0.0
    tiles_used: int = 0
    applied: bool = False
    reason: str = ""

    def largest_px(self, width: int) -> float:
        """Largest ``|dy(x)|`` over the image's columns, pixels."""
        half = max(self.centre_px, width - 1 - self.centre_px)
        return abs(self.offset_px) + abs(self.slope) * half


_MIN_TILE_STD = 1.0  # grey levels; below it a tile has no texture to measure

_WINDOWS: dict[tuple[int, int], np.ndarray] = {}


def _window(tw: int, th: int) -> np.ndarray:
    key = (tw, th)
    if key not in _WINDOWS:
        _WINDOWS[key] = cv2.createHanningWindow((tw, th), cv2.CV_32F)
    return _WINDOWS[key]


def measure_tiles(
    left: np.ndarray, right: np.ndarray, config: VerticalAlignConfig | None = None
) -> np.ndarray:
    """Phase correlation of the tile grid.

    Returns
    -------
    (N, 3) float64: tile centre x (pixels), vertical offset ``dy`` (pixels, right row
    ``y + dy`` shows left row ``y``) and the correlation response, one row per tile.
    """
    cfg = config or VerticalAlignConfig()
    h, w = left.shape
    off = min(cfg.tile_disparity_px, w // 4)
    tw = min(cfg.tile_width_px, (w - off) // max(cfg.tiles_x, 1))
    th = min(cfg.tile_height_px, h // max(cfg.tiles_y, 1))
    if tw < 16 or th < 16:
        return np.zeros((0, 3))
    win = _window(tw, th)
    xs = np.linspace(off, w - tw, cfg.tiles_x).astype(int)
    ys = np.linspace(0, h - th, cfg.tiles_y).astype(int)
    out = []
    for y0 in ys:
        lrow = left[y0 : y0 + th].astype(np.float32)
        rrow = right[y0 : y0 + th].astype(np.float32)
        for x0 in xs:
            a = lrow[:, x0 : x0 + tw]
            b = rrow[:, x0 - off : x0 - off + tw]
            (_dx, dy), response = cv2.phaseCorrelate(a, b, win)
            # A flat tile correlates with anything (at zero shift). OpenCV's standard
            # deviation of the uint8 tile: a tenth of NumPy's float one's time (issue 13).
            if (
                cv2.meanStdDev(left[y0 : y0 + th, x0 : x0 + tw])[1][0, 0] < _MIN_TILE_STD
                or cv2.meanStdDev(right[y0 : y0 + th, x0 - off : x0 - off + tw])[1][0, 0] < _MIN_TILE_STD
            ):
                response = 0.0
            out.append((x0 + (tw - 1) / 2.0, dy, response))
    return np.asarray(out, dtype=np.float64)


def estimate_vertical_offset(
    left: np.ndarray, right: np.ndarray, config: VerticalAlignConfig | None = None
) -> VerticalOffset:
    """Measure the vertical offset of ``right`` against ``left`` (module docstring).

    Parameters
    ----------
    left, right : (H, W) uint8, rectified grey images

    Returns
    -------
    VerticalOffset with ``applied`` False; ``tiles_used`` 0 (and zero offset) when the
    pair gives no trusted measurement, with ``reason`` saying why.
    """
    cfg = config or VerticalAlignConfig()
    w = left.shape[1]
    centre = (w - 1) / 2.0
    tiles = measure_tiles(left, right, cfg)
    if len(tiles) == 0:
        return VerticalOffset(centre_px=centre, reason="image too small for the tiles")
    use = (tiles[:, 2] >= cfg.min_response) & (np.abs(tiles[:, 1]) <= cfg.max_offset_px)
    while use.sum() >= cfg.min_tiles:
        xu, su, wu = tiles[use, 0] - centre, tiles[use, 1], tiles[use, 2]
        A = np.column_stack([np.ones_like(xu), xu])
        if np.ptp(xu) < 0.25 * w:  # one column of tiles: a shift only
            A = A[:, :1]
        sw = np.sqrt(wu)
        coef = np.linalg.lstsq(A * sw[:, None], su * sw, rcond=None)[0]
        resid = np.abs(su - A @ coef)
        if resid.max() <= cfg.max_spread_px:
            slope = float(coef[1]) if len(coef) > 1 else 0.0
            return VerticalOffset(float(coef[0]), slope, centre, int(use.sum()), False, "measured")
        use[np.flatnonzero(use)[int(np.argmax(resid))]] = False
    return VerticalOffset(centre_px=centre, reason="too few tiles with texture agree")


def align_vertical(
    pair: RectifiedPair, config: VerticalAlignConfig | None = None
) -> tuple[RectifiedPair, VerticalOffset]:
    """Shift the right image of ``pair`` by its measured vertical offset when trusted.

    Returns the pair (the same object when nothing was applied) and the measurement. The
    shifted right image samples ``right(x, y + dy(x))`` bilinearly; rows that leave the
    image are black and, with ``valid_right`` shifted alike, without a source.
    """
    cfg = config or VerticalAlignConfig()
    if not cfg.enabled:
        return pair, VerticalOffset(reason="disabled")
    est = estimate_vertical_offset(pair.left, pair.right, cfg)
    h, w = pair.right.shape
    if est.tiles_used == 0:
        return pair, est
    if est.largest_px(w) < cfg.min_correction_px:
        return pair, dataclasses.replace(est, reason="below min_correction_px: left as it was")
    # dst(x, y) = src(x, y + offset + slope * (x - c)).
    M = np.array([[1.0, 0.0, 0.0], [est.slope, 1.0, est.offset_px - est.slope * est.centre_px]])
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    right = cv2.warpAffine(pair.right, M, (w, h), flags=flags, borderMode=cv2.BORDER_CONSTANT)
    rect = pair.rectification
    valid = np.ones((h, w), np.uint8) if rect.valid_right is None else rect.valid_right.astype(np.uint8)
    shifted = cv2.warpAffine(valid, M, (w, h), flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP) > 0
    # One more pixel off the rows that left the image (bilinear mixes them with black).
    shifted = (
        cv2.erode(shifted.astype(np.uint8), np.ones((3, 1), np.uint8), borderType=cv2.BORDER_REPLICATE) > 0
    )
    rect = dataclasses.replace(rect, valid_right=None if shifted.all() else shifted)
    return RectifiedPair(pair.left, right, rect), dataclasses.replace(est, applied=True, reason="applied")
