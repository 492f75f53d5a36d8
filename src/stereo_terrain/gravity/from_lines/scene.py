"""What the image's segments say, from one LSD pass beside the matcher
(:func:`scene_lines`, :class:`SceneLines`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...rectify import Rectification
from ..config import GravityEstimate
from .config import VerticalLinesConfig
from .horizontal import horizontal_direction
from .segments import _in_raw_px, _segments
from .vanishing import up_from_vertical_lines


@dataclass(frozen=True)
class SceneLines:
    """What the image's line segments say, found beside the matcher (:func:`scene_lines`).

    Attributes
    ----------
    up : GravityEstimate or None
        :func:`up_from_vertical_lines` (None when up was known and not asked for).
    horizontal : (3,) float64 or None
        :func:`horizontal_direction` in the rectified left camera (None when asked for and
        not found, or not asked for).
    segments : (N, 4) float64
        The LSD segments behind them (for :func:`horizontal_direction` with another up):
        whole ones, away from the border of the valid region.
    at_border : (M, 4) float64
        The same pass's segments that reach that border, clipped there (for the terrain's
        nosings, :mod:`stereo_terrain.terrain.nosings`: a staircase wider than the view has
        all its nosings so), and for gravity's Manhattan frame of the lines
        (``frame_at_border``). The estimates above keep to whole segments: with these too,
        the Manhattan fill and the rematches moved and lost as many staircases as the
        nosings gained (docs/benchmarks.md, "Sixteenth session").
    short : (K, 4) float64
        The same pass's segments shorter than ``min_length_px`` and at least
        ``terrain_min_length_px`` long, the whole ones then those at the border: for the
        terrain's vertical edges alone (``VerticalLinesConfig.terrain_min_length_px``).
    scale : float or None
        The scale the LSD pass ran at (``detect_scale`` or ``horizontal_scale``); None
        where no pass ran.
    """

    up: GravityEstimate | None
    horizontal: np.ndarray | None
    segments: np.ndarray
    at_border: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))
    short: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))
    scale: float | None = None

    @property
    def every_segment(self) -> np.ndarray:
        """``(N + M, 4)``: the whole segments, then those at the border (the band fill's,
        and with ``frame_at_border`` the Manhattan frame's)."""
        return np.concatenate([self.segments, self.at_border])


def scene_lines(
    image: np.ndarray,
    rectification: Rectification,
    config: VerticalLinesConfig,
    *,
    known_up: np.ndarray | None = None,
    want_up: bool = True,
    want_horizontal: bool = True,
    prior_cone_deg: float = 45.0,
) -> SceneLines:
    """Up from the vertical lines (unless ``known_up``, e.g. a rig's, is given or
    ``want_up`` is False) and the dominant horizontal direction (``want_horizontal``; with
    the given up, else with the lines' when they fix it), from one LSD pass."""
    up_est = None
    scale = None  # the pass's, where one ran
    length = _in_raw_px(rectification, config.min_length_px)
    shortest = _in_raw_px(rectification, config.terrain_min_length_px)
    found, whole = np.empty((0, 4)), np.zeros(0, dtype=bool)
    if known_up is None and want_up:
        scale = config.detect_scale
        found, whole, long = _long_and_short(image, rectification, shortest, length, scale)
        segments = found[whole & long]
        up_est = up_from_vertical_lines(
            image, rectification, config, prior_cone_deg=prior_cone_deg, segments=segments
        )
        up = up_est.up if up_est.ok else None
    else:
        up = known_up
        long = np.zeros(0, dtype=bool)
        if want_horizontal and up is not None:
            scale = config.horizontal_scale
            found, whole, long = _long_and_short(image, rectification, shortest, length, scale)
        segments = found[whole & long]
    horizontal = None
    if want_horizontal and up is not None:
        horizontal = horizontal_direction(segments, rectification, up, config)
    return _sorted(found, whole, long, scale, up_est, horizontal)


def scene_segments(
    image: np.ndarray, rectification: Rectification, config: VerticalLinesConfig, scale: float
) -> SceneLines:
    """One LSD pass at ``scale`` sorted as :func:`scene_lines` sorts its segments (whole,
    at the border, short), with neither up nor a horizontal direction: the terrain's lines
    at another scale than the frame's (``finer_scale``)."""
    length = _in_raw_px(rectification, config.min_length_px)
    shortest = _in_raw_px(rectification, config.terrain_min_length_px)
    return _sorted(*_long_and_short(image, rectification, shortest, length, scale), scale)


def _sorted(
    found: np.ndarray,
    whole: np.ndarray,
    long: np.ndarray,
    scale: float | None,
    up: GravityEstimate | None = None,
    horizontal: np.ndarray | None = None,
) -> SceneLines:
    """One pass's segments (:func:`_long_and_short`) as :class:`SceneLines` holds them."""
    short = np.concatenate([found[whole & ~long], found[~whole & ~long]])
    return SceneLines(up, horizontal, found[whole & long], found[~whole & long], short, scale)


def _long_and_short(
    image: np.ndarray, rectification: Rectification, shortest: float, length: float, scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One LSD pass's segments at least ``shortest`` long (:func:`_segments`), which of
    them are whole, and which are ``length`` long or more: the same segments that pass
    would give at ``length`` (a clipped segment's length is its clipped part's)."""
    found, whole = _segments(image, rectification.valid_left, shortest, scale)
    long = np.hypot(found[:, 2] - found[:, 0], found[:, 3] - found[:, 1]) >= length
    return found, whole, long
