"""The band fill: the disparity of the face between two parallel lines, by a photometric
sweep of one plane over the whole face (issue 11).

On the wooden stairs that webcams photograph, a riser is a band of horizontal grain and
plank gaps between two long horizontal edges. Along the rows it has almost nothing to
match: the matcher's values there are streaks from the neighbouring faces, and no riser
plane comes out of them (docs/benchmarks.md, "Twenty-third session": lab-like renders,
given the true disparity, are found 100%; with the matcher's, 78%). The little a riser
does show along the rows (its two ends, knots, the grain's slant) is spread over
thousands of pixels; one plane tried over the whole band at once adds it up.

A band is the image region between two line segments that are images of parallel
horizontal 3D lines (a nosing and the riser's foot, the two edges of a nosing strip, a
plank gap and either): each segment's plane through the camera contains one horizontal
direction (the cross product of its normal with up), and the two segments' directions
agree within ``parallel_deg``. Segments broken by plank joints or balusters are first
merged where collinear. The face between them is taken to be one plane of one of two
families: vertical, with its normal horizontal and across the lines (a riser, a wall),
or horizontal (a tread, the floor). Each family is swept in steps of ``coarse_step_px``
of the disparity at the band's centre (then ``step_px`` about its peak), and each plane
is scored by the zero-mean normalised correlation of the left image's horizontal
gradient over the band with the right image's at the plane's disparity (the gradient: a
matched vertical edge counts, an exposure difference or a horizontal edge does not).

A band is filled with its best plane where:

- the best correlation exceeds the best at least 1.5 px away by ``min_significance``
  standard errors (the difference times the square root of the band's pixels): a
  face with nothing to match has a flat score;
- it exceeds the other family's best by ``min_family_significance`` standard errors: a
  thin band near the cameras' height looks alike as a riser and as a tread (an empty
  corridor's plank joints made a 7.8 cm "step" without this);
- no half of the band (upper, lower, left or right) prefers another plane by more than
  ``max_part_significance`` standard errors: a band that spans two faces (a riser and the
  tread above it where the nosing's own edge was not found, two objects side by side) is
  not one plane;
- it is at least ``min_width_m`` wide at its plane's depth: a staircase is wider than a
  drawer front or a box on a shelf, which are planes as well.

The fill writes the plane's disparity over the matcher's in the band's pixels (and marks
them ``filled``). It needs up in the camera frame (a rig, or the image's vertical lines)
and the image's line segments (:func:`stereo_terrain.gravity.scene_lines`). The pipeline
sweeps once a frame where its first pass wants a second opinion, on the thread that found
the lines, and writes the planes over the second opinions' disparities
(``PipelineConfig.bands``).

Written here rather than taken from OpenCV: a plane sweep over an arbitrary image region
with a per-pixel disparity law is not among its stereo functions; each hypothesis is one
compiled pass over the band (:mod:`._band_kernels`) instead of a remap and a dozen array
passes.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError
from ..rectify import RectifiedPair
from . import DisparityMap
from ._band_kernels import zncc_sweep

#: The two plane families a band is tried with.
VERTICAL, HORIZONTAL = "vertical", "horizontal"

#: A plane this far (disparity at the band's centre, px) from the best is a rival.
_RIVAL_PX = 1.5

#: A segment's horizontal direction is unreliable when its plane through the camera is
#: within this of horizontal (the cameras' horizon).
_HORIZON_DEG = 5.0

#: Bands (or halves) with fewer pixels are not judged.
_MIN_PIXELS = 150
_MIN_PART_PIXELS = 50

#: The band stops this many pixels short of each line (the edge itself is blurred
#: across both faces).
_EDGE_MARGIN_PX = 2.0

#: Short pieces are merged before the length test (a plank joint leaves 10-30 px pieces).
_MIN_PIECE_PX = 10.0

#: Left-image gradient spread (grey levels per px) below which a band has nothing to match.
_MIN_GRADIENT_STD = 2.0


@dataclass(frozen=True)
class BandFillConfig:
    """Parameters of the band fill (:func:`fill_bands`); ``PipelineConfig.bands``.

    Attributes
    ----------
    enabled : bool
        The pipeline's second opinions use the band fill (see ``PipelineConfig.bands``).
        Default True.
    min_length_px : float
        Least length of a (merged) segment that bounds a band. Default 30.
    max_slope_deg : float
        Segments steeper than this in the image are not taken. Default 35.
    parallel_deg : float
        The two segments' horizontal directions agree within this. Default 3.
    min_gap_px, max_gap_px : int
        The band's height in the image, at the middle of the two segments' overlap.
        Defaults 6 and 120.
    lines_below : int
        Each segment bounds bands with this many of the nearest segments below it: with 2,
        a riser split by a plank gap is also tried whole (of two overlapping bands kept,
        the larger is written). Default 2.
    widen_px : int
        The band reaches this far beyond the segments' overlap along the rows: a riser's
        ends, which hold most of what it shows, are often a few pixels beyond the
        segments. Default 6.
    coarse_step_px, step_px : float
        Sweep steps of the disparity at the band's centre: the whole range in coarse steps
        (the correlation's peak spans a few pixels on the realistic renders' blurred
        images), then one coarse step either side of each family's peak in fine steps.
        Defaults 1 and 0.25.
    min_significance : float
        The best plane's lead over its rivals, in standard errors. Default 5.
    min_family_significance : float
        The best plane's lead over the other family's best, in standard errors. Default 3.
    max_part_significance : float
        The most a half of the band may prefer another plane, in standard errors.
        Default 4.
    min_width_m : float
        Least width of a band at its plane's depth: a staircase is wider than a drawer
        front or a box on a shelf. The band spans only the two segments' overlap, which
        the image's border, balusters and a yawed staircase's far end cut well short of
        the staircase's 0.8-0.9 m (building codes): on realistic renders, the bands
        refused for their width alone were within 2 px of the truth in 82% (those kept,
        93%), and at 0.4 m eight more realistic runs were counted right, none fewer, with the
        rooms no worse (docs/benchmarks.md, "Thirty-ninth session"). Default 0.4 (0.6
        before).
    merge_tol_px, merge_gap_px : float
        Segments are merged when each end of one is within ``merge_tol_px`` of the
        other's line and the gap between them is at most ``merge_gap_px``. Defaults 1.5
        and 40.
    """

    enabled: bool = True
    min_length_px: float = 30.0
    max_slope_deg: float = 35.0
    parallel_deg: float = 3.0
    min_gap_px: int = 6
    lines_below: int = 2
    max_gap_px: int = 120
    widen_px: int = 6
    coarse_step_px: float = 1.0
    step_px: float = 0.25
    min_significance: float = 5.0
    min_family_significance: float = 3.0
    max_part_significance: float = 4.0
    min_width_m: float = 0.4
    merge_tol_px: float = 1.5
    merge_gap_px: float = 40.0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 0, "widen_px", "min_significance", "min_family_significance", "max_part_significance")
        check_min(self, 0, "min_width_m")
        check_min(self, 1, "lines_below")
        check_min(self, 0, "merge_tol_px", "merge_gap_px", "min_length_px")
        if not 0 < self.step_px <= self.coarse_step_px <= 2:
            raise ConfigError(
                "BandFillConfig needs 0 < step_px <= coarse_step_px <= 2, "
                f"got {self.step_px} and {self.coarse_step_px}"
            )
        if not 0 < self.parallel_deg < 45 or not 0 < self.max_slope_deg < 90:
            raise ConfigError("BandFillConfig.parallel_deg must be in (0, 45) and max_slope_deg in (0, 90)")
        if not 1 <= self.min_gap_px <= self.max_gap_px:
            raise ConfigError(
                "BandFillConfig needs 1 <= min_gap_px <= max_gap_px, "
                f"got {self.min_gap_px} and {self.max_gap_px}"
            )


@dataclass(frozen=True)
class Band:
    """What the sweep made of one band.

    Attributes
    ----------
    family : str
        ``vertical`` or ``horizontal``: the best plane's family.
    centre_disparity_px : float
        The best plane's disparity at the band's centre.
    significance : float
        Its lead over the rivals, in standard errors.
    family_significance : float
        The best plane's lead over the other family's best, in standard errors (infinite
        where only one family could be tried).
    part_significance : float
        The most a half of the band prefers another plane (0 when not judged).
    width_m : float
        The band's width at the plane's depth.
    pixels : int
    kept : bool
        The band was filled.
    """

    family: str
    centre_disparity_px: float
    significance: float
    family_significance: float
    part_significance: float
    width_m: float
    pixels: int
    kept: bool


def merge_collinear(segments: np.ndarray, tol_px: float, max_gap_px: float) -> np.ndarray:
    """Segments ``(N, 4)`` with the collinear ones (each end of the shorter within
    ``tol_px`` of the longer's line, at most ``max_gap_px`` apart along it) joined, longest
    first, until none joins."""
    s = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    while len(s) > 1:
        s = s[np.argsort(-np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]), kind="stable")]
        used = np.zeros(len(s), dtype=bool)
        out = []
        for i in range(len(s)):
            if used[i]:
                continue
            a = s[i].copy()
            for j in range(i + 1, len(s)):
                if not used[j]:
                    joined = _joined(a, s[j], tol_px, max_gap_px)
                    if joined is not None:
                        a, used[j] = joined, True
            out.append(a)
        if len(out) == len(s):
            break
        s = np.array(out)
    return s


def _joined(a: np.ndarray, b: np.ndarray, tol_px: float, max_gap_px: float) -> np.ndarray | None:
    """``a`` extended over ``b`` when ``b`` lies on ``a``'s line within the tolerances."""
    dx, dy = a[2] - a[0], a[3] - a[1]
    length = math.hypot(dx, dy)
    if length == 0:
        return None
    ux, uy = dx / length, dy / length
    ends = b.reshape(2, 2) - a[:2]
    if np.any(np.abs(ends[:, 0] * -uy + ends[:, 1] * ux) > tol_px):
        return None
    t = np.sort(ends[:, 0] * ux + ends[:, 1] * uy)
    if max(t[0] - length, -t[1]) > max_gap_px:
        return None
    lo, hi = min(0.0, t[0]), max(length, t[1])
    return np.array([a[0] + lo * ux, a[1] + lo * uy, a[0] + hi * ux, a[1] + hi * uy])


def _rays(px: np.ndarray, pair: RectifiedPair) -> np.ndarray:
    """Directions of the rectified left camera's rays through ``px`` ``(N, 2)``."""
    rect = pair.rectification
    f = rect.focal_px
    return np.column_stack([(px[:, 0] - rect.cx) / f, (px[:, 1] - rect.cy) / f, np.ones(len(px))])


def _line_segments(
    segments: np.ndarray, pair: RectifiedPair, up: np.ndarray, config: BandFillConfig
) -> tuple[np.ndarray, np.ndarray]:
    """The segments that may bound a band, left end first, and the horizontal 3D direction
    each is an image of (unit, camera frame). Those whose plane through the camera is within
    ``_HORIZON_DEG`` of horizontal are left out: a segment near the cameras' horizon is the
    image of a horizontal line of any direction."""
    s = np.asarray(segments, dtype=np.float64).reshape(-1, 4).copy()
    s[s[:, 0] > s[:, 2]] = s[s[:, 0] > s[:, 2]][:, [2, 3, 0, 1]]
    slope = np.degrees(np.arctan2(np.abs(s[:, 3] - s[:, 1]), s[:, 2] - s[:, 0]))
    s = s[(np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) >= _MIN_PIECE_PX) & (slope <= config.max_slope_deg)]
    s = merge_collinear(s, config.merge_tol_px, config.merge_gap_px)
    if len(s) == 0:
        return np.empty((0, 4)), np.empty((0, 3))
    s[s[:, 0] > s[:, 2]] = s[s[:, 0] > s[:, 2]][:, [2, 3, 0, 1]]
    s = s[np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) >= config.min_length_px]
    n = np.cross(_rays(s[:, :2], pair), _rays(s[:, 2:], pair))
    n /= np.linalg.norm(n, axis=1)[:, None]
    v = np.cross(n, up)
    norm = np.linalg.norm(v, axis=1)
    posed = norm > math.sin(math.radians(_HORIZON_DEG))
    return s[posed], v[posed] / norm[posed, None]


def _y_at(seg: np.ndarray, x: np.ndarray | float) -> np.ndarray:
    """The row of segment ``seg``'s line at column ``x``."""
    return np.asarray(seg[1] + (seg[3] - seg[1]) * (np.asarray(x) - seg[0]) / max(seg[2] - seg[0], 1e-9))


def _band_pairs(s: np.ndarray, v: np.ndarray, config: BandFillConfig) -> list[tuple[int, int, np.ndarray]]:
    """For each segment, the nearest ``lines_below`` below it that are images of lines
    parallel to its own (directions within ``parallel_deg``) and overlap it along the
    rows: the bands' upper and lower lines, and the lines' horizontal direction (the mean
    of the two, signed alike)."""
    pairs = []
    parallel = math.cos(math.radians(config.parallel_deg))
    for i in range(len(s)):
        agree = np.abs(v @ v[i]) >= parallel
        agree[i] = False
        lo, hi = np.maximum(s[:, 0], s[i, 0]), np.minimum(s[:, 2], s[i, 2])
        shorter = np.minimum(s[:, 2] - s[:, 0], s[i, 2] - s[i, 0])
        agree &= hi - lo >= np.maximum(config.min_length_px, 0.5 * shorter)
        below = []
        for k in np.flatnonzero(agree):
            mid = 0.5 * (lo[k] + hi[k])
            gap = float(_y_at(s[k], mid) - _y_at(s[i], mid))
            if config.min_gap_px <= gap <= config.max_gap_px:
                below.append((gap, int(k)))
        for _, j in sorted(below)[: config.lines_below]:
            # v and -v are one direction: a line above the horizon and one below it have
            # opposite signs of the cross product
            direction = v[i] + np.copysign(1.0, float(v[i] @ v[j])) * v[j]
            pairs.append((i, j, direction / np.linalg.norm(direction)))
    return pairs


@dataclass(frozen=True)
class BandPlanes:
    """The planes the band fill found in one rectified pair (:func:`sweep_bands`).

    Attributes
    ----------
    disparity : (H, W) float32
        Each kept band's plane's disparity on its pixels (of two overlapping bands, the
        larger's: more of one face); NaN elsewhere.
    bands : tuple of Band
        What each band tried gave, kept or not.
    """

    disparity: np.ndarray = field(repr=False)
    bands: tuple[Band, ...] = ()

    def fill(self, disp: DisparityMap) -> DisparityMap:
        """``disp`` with the kept bands' planes written over it (and marked ``filled``);
        ``disp`` itself when there is none. Values beyond ``disp``'s search range are
        left out."""
        fill = np.isfinite(self.disparity) & (self.disparity < disp.max_disparity_px)
        if not fill.any():
            return disp
        out = disp.disparity.copy()
        out[fill] = self.disparity[fill]
        filled = np.zeros(fill.shape, dtype=bool) if disp.filled is None else disp.filled.copy()
        filled[fill] = True
        return dataclasses.replace(disp, disparity=out, filled=filled)


def sweep_bands(
    pair: RectifiedPair,
    segments: np.ndarray,
    up_camera: np.ndarray,
    max_disparity_px: int,
    config: BandFillConfig,
) -> BandPlanes:
    """The bands between parallel horizontal lines of ``pair`` and their best planes (see the
    module's docstring). ``segments`` ``(N, 4)`` are line segments of the rectified left
    image, ``up_camera`` is up in the rectified left camera; disparities are searched in
    ``(0, max_disparity_px)``."""
    h, w = pair.left.shape[:2]
    values = np.full((h, w), np.nan, dtype=np.float32)
    up = np.asarray(up_camera, dtype=np.float64)
    up = up / np.linalg.norm(up)
    s, v = _line_segments(segments, pair, up, config)
    pairs = _band_pairs(s, v, config)
    if not pairs:
        return BandPlanes(values)
    rect = pair.rectification
    left_gx = cv2.Sobel(pair.left.astype(np.float32), cv2.CV_32F, 1, 0, ksize=3)
    right_gx = cv2.Sobel(pair.right.astype(np.float32), cv2.CV_32F, 1, 0, ksize=3)
    valid = (
        np.ones((h, w), dtype=bool) if rect.valid_left is None else np.asarray(rect.valid_left, dtype=bool)
    )
    centres = np.arange(0.5, max_disparity_px, config.coarse_step_px)
    bands = []
    kept = []
    for i, j, direction in pairs:
        band = _sweep_band(s[i], s[j], direction, up, pair, left_gx, right_gx, valid, centres, config)
        if band is None:
            continue
        bands.append(band[0])
        if band[0].kept:
            kept.append(band)
    for _, uu, vv, d in sorted(kept, key=lambda b: b[0].pixels):
        values[vv, uu] = d  # the larger of two overlapping bands: more of one face
    values[~((values > 0) & (values < max_disparity_px))] = np.nan
    return BandPlanes(values, tuple(bands))


def fill_bands(
    disp: DisparityMap,
    pair: RectifiedPair,
    segments: np.ndarray,
    up_camera: np.ndarray,
    config: BandFillConfig,
) -> tuple[DisparityMap, tuple[Band, ...]]:
    """``disp`` with the bands of :func:`sweep_bands` filled (``disp`` itself when none is
    kept), and what each band tried gave."""
    planes = sweep_bands(pair, segments, up_camera, disp.max_disparity_px, config)
    return planes.fill(disp), planes.bands


def _sweep_band(
    upper: np.ndarray,
    lower: np.ndarray,
    direction: np.ndarray,
    up: np.ndarray,
    pair: RectifiedPair,
    left_gx: np.ndarray,
    right_gx: np.ndarray,
    valid: np.ndarray,
    centres: np.ndarray,
    config: BandFillConfig,
) -> tuple[Band, np.ndarray, np.ndarray, np.ndarray] | None:
    """The band between ``upper`` and ``lower`` swept with both families: its
    :class:`Band`, its pixels and their disparity under the best plane; None when it is
    too small, flat, or no family can be seen across it."""
    h, w = valid.shape
    lo = max(upper[0], lower[0]) - config.widen_px
    hi = min(upper[2], lower[2]) + config.widen_px
    poly = np.array(
        [
            [lo, _y_at(upper, lo) + _EDGE_MARGIN_PX],
            [hi, _y_at(upper, hi) + _EDGE_MARGIN_PX],
            [hi, _y_at(lower, hi) - _EDGE_MARGIN_PX],
            [lo, _y_at(lower, lo) - _EDGE_MARGIN_PX],
        ]
    )
    corners = np.round(poly).astype(np.int32)
    x0, y0 = np.maximum(corners.min(axis=0), 0)
    x1, y1 = np.minimum(corners.max(axis=0) + 1, (w, h))
    if x1 <= x0 or y1 <= y0:
        return None
    mask = np.zeros((y1 - y0, x1 - x0), dtype=np.uint8)  # the band's box, not the image
    cv2.fillConvexPoly(mask, corners - np.array([x0, y0], dtype=np.int32), 1)
    vv, uu = np.nonzero(mask.astype(bool) & valid[y0:y1, x0:x1])
    vv, uu = vv + y0, uu + x0
    if len(uu) < _MIN_PIXELS:
        return None
    left_values = left_gx[vv, uu].astype(np.float64)
    if left_values.std() < _MIN_GRADIENT_STD:
        return None
    px = np.column_stack([uu, vv]).astype(np.float64)
    rays = _rays(px, pair)
    centre_ray = _rays(px.mean(axis=0)[None], pair)[0]
    direction = direction / np.linalg.norm(direction)
    normals = {VERTICAL: np.cross(up, direction), HORIZONTAL: up}
    ratios, scores = {}, {}
    us, vs = uu.astype(np.float64), vv.astype(np.float64)
    doffs = pair.rectification.doffs_px
    for family, normal in normals.items():
        at, at_centre = rays @ normal, centre_ray @ normal
        # the plane must be seen from one side across the band (not edge-on)
        if not (np.all(at * at_centre > 0) and np.min(np.abs(at)) > 1e-3 * np.max(np.abs(at))):
            continue
        ratios[family] = at / at_centre
        scores[family] = zncc_sweep(us, vs, ratios[family], left_values, right_gx, centres, doffs)
    refined = {
        f: _refined_peak(z, us, vs, ratios[f], left_values, right_gx, centres, doffs, config)
        for f, z in scores.items()
        if np.isfinite(z).any()
    }
    if not refined:
        return None
    family = max(refined, key=lambda f: refined[f][1])
    dc, best = refined[family]
    root_n = math.sqrt(len(uu))
    rivals = np.where(np.abs(centres - dc) > _RIVAL_PX, scores[family], -1.0)
    significance = (best - float(np.nanmax(rivals))) * root_n
    others = [b for f, (_, b) in refined.items() if f != family]
    family_significance = (best - others[0]) * root_n if others else math.inf
    width = float((uu.max() - uu.min()) * pair.rectification.baseline_m / (dc + doffs))
    part = 0.0
    kept = (
        significance >= config.min_significance
        and family_significance >= config.min_family_significance
        and width >= config.min_width_m
    )
    if kept:
        part = _part_significance(
            upper, lower, us, vs, ratios, left_values, right_gx, centres, doffs, family, dc
        )
        kept = part <= config.max_part_significance
    d = ((dc + doffs) * ratios[family] - doffs).astype(np.float32)
    band = Band(family, dc, significance, family_significance, part, width, len(uu), kept)
    return band, uu, vv, d


def _refined_peak(
    z: np.ndarray,
    us: np.ndarray,
    vs: np.ndarray,
    ratio: np.ndarray,
    left_values: np.ndarray,
    right_gx: np.ndarray,
    centres: np.ndarray,
    doffs: float,
    config: BandFillConfig,
) -> tuple[float, float]:
    """The peak of a family's coarse correlation curve ``z`` (over ``centres``) swept again in
    steps of ``step_px`` within one coarse step of it, with a parabola through the finer
    curve's best and its neighbours: the peak's centre disparity and correlation."""
    k = int(np.nanargmax(z))
    fine = centres[k] + np.arange(-config.coarse_step_px, config.coarse_step_px + 1e-9, config.step_px)
    fine = fine[fine >= centres[0]]
    zf = zncc_sweep(us, vs, ratio, left_values, right_gx, fine, doffs)
    if not np.isfinite(zf).any():
        return float(centres[k]), float(z[k])
    j = int(np.nanargmax(zf))
    dc, best = float(fine[j]), float(zf[j])
    if 0 < j < len(zf) - 1 and np.isfinite(zf[j - 1]) and np.isfinite(zf[j + 1]):
        curvature = zf[j - 1] - 2.0 * zf[j] + zf[j + 1]
        if curvature < 0:
            dc += config.step_px * 0.5 * (zf[j - 1] - zf[j + 1]) / curvature
    return dc, best


def _part_significance(
    upper: np.ndarray,
    lower: np.ndarray,
    us: np.ndarray,
    vs: np.ndarray,
    ratios: dict[str, np.ndarray],
    left_values: np.ndarray,
    right_gx: np.ndarray,
    centres: np.ndarray,
    doffs: float,
    family: str,
    dc: float,
) -> float:
    """The most any half of the band (upper, lower, left, right) prefers its own best plane
    (either family, on the coarse grid ``centres``) to the band's (``family``, centre
    disparity ``dc``), in standard errors."""
    ya, yb = _y_at(upper, us), _y_at(lower, us)
    across = (vs - ya) / np.maximum(yb - ya, 1e-9)
    middle = 0.5 * (us.min() + us.max())
    worst = 0.0
    for part in (across < 0.5, across >= 0.5, us < middle, us >= middle):
        if part.sum() < _MIN_PART_PIXELS:
            continue
        own = {
            f: zncc_sweep(us[part], vs[part], r[part], left_values[part], right_gx, centres, doffs)
            for f, r in ratios.items()
        }
        finite = [float(np.nanmax(z)) for z in own.values() if np.isfinite(z).any()]
        if not finite:
            continue
        at = zncc_sweep(
            us[part], vs[part], ratios[family][part], left_values[part], right_gx, np.array([dc]), doffs
        )[0]
        at = -1.0 if not np.isfinite(at) else float(at)
        worst = max(worst, (max(finite) - at) * math.sqrt(part.sum()))
    return worst


def warm_up() -> None:
    """Load (or compile) the sweep's compiled kernel now, not in the first frame that runs
    the band opinion, for the array types :func:`fill_bands` passes."""
    one = np.ones(2)
    zncc_sweep(one, np.zeros(2), one, one, np.ones((2, 4), dtype=np.float32), np.zeros(1), 0.0)
