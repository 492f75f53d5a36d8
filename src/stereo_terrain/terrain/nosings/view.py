"""The image's line segments and the camera that saw them (:class:`ImageLines`), and one
staircase as they see it (:class:`StairView`): which segments are images of its nosings,
where a line of the staircase is in view, and how much of its width segments cover."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..photometric import StereoView, edge_disparities
from .plumb import plumb_segments

#: A segment is parallel to the nosings when its plane through the camera is within this
#: of containing ``v``, plus the angle one pixel of end error makes over its length.
_PARALLEL_DEG = 2.0


#: Segments reaching the image's border whose plane through the camera is within this of
#: horizontal are not taken for nosings (:func:`parallel_segments`).
HORIZON_DEG = 1.0


#: The lateral step (metres) at which the visible part of a nosing is measured.
_LATERAL_STEP_M = 0.02


#: The least part of a nosing that must be in view (metres) to judge it.
_MIN_VISIBLE_M = 0.15


#: The cameras must be this much above a tread to see the foot of the riser behind it.
FOOT_VISIBLE_M = 0.03


#: A tread under this many pixels tall in the image is seen edge-on (at the cameras'
#: height): the lines of its nosing and of the foot of the riser above it are one
#: (:func:`tread_height_px`; :func:`~.steps.nosing_steps` steps over such a nosing).
EDGE_ON_PX = 4.0


@dataclass(frozen=True)
class ImageLines:
    """The rectified left image's line segments and the camera that saw them, for the
    terrain stage.

    Attributes
    ----------
    segments : (N, 4) float64
        ``x1, y1, x2, y2`` in pixels of the rectified left image.
    focal_px, cx, cy : float
        The rectified left camera.
    image_size : (width, height)
    T_frame_camera : (4, 4) float64
        Rectified left camera to the terrain's (gravity-aligned) frame.
    at_border : (M, 4) float64
        Segments that reach the border of the image's valid region, clipped there (a
        staircase wider than the view has all its nosings so); ``segments`` are whole.
    image : (H, W) array or None
        The rectified left image itself, where a nosing no segment shows is looked for
        as a step edge in its grey levels (``TerrainConfig.nosing_edge_contrast``).
    stereo : StereoView or None
        The rectified pair, where the risers found are moved to where both images put them
        (``TerrainConfig.photometric_risers``, :mod:`..photometric`). None: not done.
    short : (K, 4) float64
        Segments shorter than ``segments`` and ``at_border`` (the lines' job's
        ``VerticalLinesConfig.terrain_min_length_px``), for the vertical edges alone
        (:func:`vertical_edges`): the end of a riser at the top of a staircase 3 m away
        is 20-25 px tall.
    plumb_edges : bool
        Whether :func:`vertical_edges` also takes the near-vertical edges the grey levels
        show where no segment does (:func:`~.plumb.plumb_segments`; the pipeline sets it
        from ``TerrainConfig.plumb_edges``).
    """

    segments: np.ndarray = field(repr=False)
    focal_px: float
    cx: float
    cy: float
    image_size: tuple[int, int]
    T_frame_camera: np.ndarray = field(repr=False)
    at_border: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 4)))
    image: np.ndarray | None = field(repr=False, default=None)
    stereo: StereoView | None = field(repr=False, default=None)
    short: np.ndarray = field(repr=False, default_factory=lambda: np.empty((0, 4)))
    plumb_edges: bool = False

    @property
    def every_segment(self) -> np.ndarray:
        """``segments`` then ``at_border``, ``(N + M, 4)`` float64."""
        return np.concatenate(
            [
                np.asarray(self.segments, dtype=np.float64).reshape(-1, 4),
                np.asarray(self.at_border, dtype=np.float64).reshape(-1, 4),
            ]
        )

    @cached_property
    def vertical_edges(self) -> VerticalEdges:
        """The image's vertical 3D lines placed by both images (:func:`vertical_edges`),
        found once per frame."""
        return vertical_edges(self)

    @property
    def centre(self) -> np.ndarray:
        """The camera centre in the terrain's frame."""
        return np.asarray(self.T_frame_camera[:3, 3], dtype=np.float64)

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Directions (not unit) of the rays through ``pixels`` ``(N, 2)``, terrain frame."""
        d = np.column_stack(
            [
                (pixels[:, 0] - self.cx) / self.focal_px,
                (pixels[:, 1] - self.cy) / self.focal_px,
                np.ones(len(pixels)),
            ]
        )
        out: np.ndarray = d @ self.T_frame_camera[:3, :3].T
        return out

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels ``(N, 2)`` and depths ``(N,)`` of terrain-frame ``points``."""
        R = self.T_frame_camera[:3, :3]
        X = (points - self.centre) @ R  # R^T (p - c), row-wise
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.column_stack(
                [self.focal_px * X[:, 0] / X[:, 2] + self.cx, self.focal_px * X[:, 1] / X[:, 2] + self.cy]
            )
        return uv, X[:, 2]


@dataclass(frozen=True)
class VerticalEdges:
    """Vertical lines of the scene that the image's segments show and both images place
    (:func:`vertical_edges`): each one's foot and top (the segment's ends), terrain frame."""

    foot: np.ndarray = field(repr=False)
    top: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class Segments:
    """The segments parallel to the nosings, with their end rays and planes."""

    d0: np.ndarray
    d1: np.ndarray
    normal: np.ndarray


@dataclass(frozen=True)
class StairView:
    """One staircase as the image's lines see it: the camera (``lines``), the segments
    parallel to its nosings, its axis ``u`` and lateral direction ``v``, and the part of
    its width looked at (``lat``, metres along ``v``)."""

    lines: ImageLines
    segs: Segments
    u: np.ndarray
    v: np.ndarray
    lat: tuple[float, float]


def inner_lateral(lateral: tuple[float, float]) -> tuple[float, float]:
    """The part of a staircase's lateral extent whose nosings are looked at: not its side
    edges (stringers, walls)."""
    margin = 0.1 * (lateral[1] - lateral[0])
    return (lateral[0] + margin, lateral[1] - margin)


def segment_planes(
    lines: ImageLines, segments: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each segment's end rays ``d0``, ``d1`` (terrain frame), the unit normal of its plane
    through the camera, its length (pixels) and whether it spans a plane at all (not
    degenerate); ``segments`` ``(N, 4)`` as :attr:`ImageLines.segments`."""
    d0, d1 = lines.rays(segments[:, :2]), lines.rays(segments[:, 2:])
    n = np.cross(d0, d1)
    norm = np.linalg.norm(n, axis=1)
    length = np.hypot(segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1])
    ok = (norm > 1e-12) & (length > 0)
    n[ok] /= norm[ok, None]
    return d0, d1, n, length, ok


#: A segment whose plane through the camera is within this (deg) of vertical holds a
#: vertical line (a baluster, a wall's corner): its horizontal direction is only its
#: bearing (:func:`horizontal_directions`).
MIN_TILT_DEG = 15.0

#: Shorter segments (pixels) do not vote for a direction: theirs is a few degrees uncertain.
MIN_DIRECTION_LENGTH_PX = 20.0


def horizontal_directions(
    lines: ImageLines, segments: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each segment's middle ray (terrain frame), the bearing (radians, terrain frame) of
    the one horizontal direction its plane through the camera holds, its length (pixels)
    and whether it votes for a direction: its plane neither within ``MIN_TILT_DEG`` of
    vertical nor within ``HORIZON_DEG`` of horizontal (which holds every horizontal
    direction), and it is ``MIN_DIRECTION_LENGTH_PX`` long at least."""
    d0, d1, n, length, ok = segment_planes(lines, segments)
    h = np.cross(n, np.array([0.0, 0.0, 1.0]))
    tilt = np.abs(n[:, 2])
    ok &= (tilt > math.sin(math.radians(MIN_TILT_DEG))) & (tilt < math.cos(math.radians(HORIZON_DEG)))
    ok &= length >= MIN_DIRECTION_LENGTH_PX
    return 0.5 * (d0 + d1), np.arctan2(h[:, 1], h[:, 0]), length, ok


def parallel_segments(lines: ImageLines, v: np.ndarray) -> Segments | None:
    """The segments that are images of lines along ``v``; None when there are none.

    Of those that reach the image's border, not the ones whose plane through the camera is
    within ``HORIZON_DEG`` of horizontal: a line across the view at the cameras' height is
    as likely the horizon or a far wall's foot as a nosing (one made a step beyond a
    landing on a default-profile render). A whole one there is kept: the nosings of a
    staircase whose top is at the cameras' height are such segments."""
    whole = len(np.asarray(lines.segments).reshape(-1, 4))
    d0, d1, n, length, ok = segment_planes(lines, lines.every_segment)
    tol = np.sin(np.radians(_PARALLEL_DEG) + 2.0 / np.maximum(length, 1.0))
    ok &= np.abs(n @ v) < tol
    ok[whole:] &= np.abs(n[whole:, 2]) < math.cos(math.radians(HORIZON_DEG))
    if not ok.any():
        return None
    return Segments(d0[ok], d1[ok], n[ok])


def on_height(lines: ImageLines, d: np.ndarray, z: np.ndarray | float) -> np.ndarray:
    """Where the rays ``d`` meet the horizontal plane at height ``z`` (NaN behind or along)."""
    c = lines.centre
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z - c[2]) / d[:, 2]
    p: np.ndarray = c + t[:, None] * d
    p[~(t > 0)] = np.nan
    return p


def visible_span(view: StairView, s: float, z: float) -> tuple[float, float] | None:
    """The part of ``lat`` in view (in the image, in front of the camera) of the line at
    position ``s`` along ``u`` and height ``z``; None when less than ``_MIN_VISIBLE_M``."""
    lines, u, v, lat = view.lines, view.u, view.v, view.lat
    t = np.arange(lat[0], lat[1] + 1e-9, _LATERAL_STEP_M)
    if len(t) < 2:
        return None
    uv, depth = lines.project(s * u + t[:, None] * v + np.array([0.0, 0.0, z]))
    w, h = lines.image_size
    with np.errstate(invalid="ignore"):
        ok = (depth > 0.2) & (uv[:, 0] > 3) & (uv[:, 0] < w - 4) & (uv[:, 1] > 3) & (uv[:, 1] < h - 4)
    if not ok.any():
        return None
    lo, hi = float(t[ok][0]), float(t[ok][-1])
    return (lo, hi) if hi - lo >= _MIN_VISIBLE_M else None


def covered_share(lo: np.ndarray, hi: np.ndarray, span: tuple[float, float]) -> float:
    """The share of ``span`` that the union of the intervals ``[lo, hi]`` covers."""
    a, b = np.maximum(lo, span[0]), np.minimum(hi, span[1])
    keep = b > a
    total, reach = 0.0, -math.inf
    for x, y in sorted(zip(a[keep], b[keep], strict=True)):
        if y > reach:
            total += y - max(x, reach)
            reach = y
    return total / (span[1] - span[0])


def on_riser_plane(
    lines: ImageLines, segs: Segments, u: np.ndarray, v: np.ndarray, a: float, middle: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where each segment's plane through the camera meets the riser plane ``u . x = a``:
    the height of that line at ``middle`` along ``v``, the lateral extent ``(lo, hi)`` of
    the segment's end rays on the plane, and whether both rays meet it in front of the
    camera (NaN where a ray or plane runs along it)."""
    c = lines.centre
    base = a * u + middle * v
    with np.errstate(divide="ignore", invalid="ignore"):
        z = -(segs.normal @ (base - c)) / segs.normal[:, 2]
        t0 = (a - c @ u) / (segs.d0 @ u)
        t1 = (a - c @ u) / (segs.d1 @ u)
        e0 = (c + t0[:, None] * segs.d0) @ v
        e1 = (c + t1[:, None] * segs.d1) @ v
    return z, np.minimum(e0, e1), np.maximum(e0, e1), (t0 > 0) & (t1 > 0)


def lateral_on_height(view: StairView, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's lateral extent ``(lo, hi)`` where its end rays meet height ``z`` (one
    per segment; NaN where a ray misses)."""
    lines, segs, v = view.lines, view.segs, view.v
    a = on_height(lines, segs.d0, z) @ v
    b = on_height(lines, segs.d1, z) @ v
    return np.minimum(a, b), np.maximum(a, b)


def tread_height_px(view: StairView, front: float, back: float, z: float) -> float:
    """How tall in the image (pixels, at the staircase's lateral middle) a tread at height
    ``z`` is from its nosing at ``front`` to the foot of the riser behind it at ``back``
    (along ``u``): the foot's distance from the nosing's image line; NaN where either is
    behind the camera."""
    mid = 0.5 * (view.lat[0] + view.lat[1]) * view.v + np.array([0.0, 0.0, z])
    nosing = mid + front * view.u
    uv, depth = view.lines.project(np.array([nosing, nosing + 0.1 * view.v, mid + back * view.u]))
    if not (depth > 0).all():
        return math.nan
    along = uv[1] - uv[0]
    across = abs(float(along[0] * (uv[2, 1] - uv[0, 1]) - along[1] * (uv[2, 0] - uv[0, 0])))
    return across / float(np.hypot(*along))


#: A segment is the image of a vertical line where its plane through the camera is within
#: this of vertical, plus the angle 1.5 px of end error makes over its length.
_VERTICAL_DEG = 1.5

#: Shorter segments (pixels) are not matched: too few rows.
_MIN_VERTICAL_PX = 12.0

#: Nearest and farthest a vertical line is looked for (metres from the cameras).
_EDGE_DEPTHS_M = (0.3, 6.0)

#: Least correlation of the two images' gradients across a vertical line for it to be
#: placed (:func:`~..photometric.edge_disparities`).
MIN_EDGE_SCORE = 0.7


def vertical_edges(lines: ImageLines) -> VerticalEdges:
    """The segments that are images of vertical lines (their plane through the camera
    holds up within ``_VERTICAL_DEG``), each placed in depth by its disparity between the
    two images (:func:`~..photometric.edge_disparities`), where the images agree on it
    (``MIN_EDGE_SCORE``): the foot and top of each, terrain frame. Empty without the
    rectified pair (``lines.stereo``).

    A horizontal baseline places a vertical edge best of all: its two images differ by a
    shift along the rows that the edge's whole length measures. A painted staircase's
    faces give the matcher nothing, but each riser's end is such an edge, against the wall
    beside it or the room behind (issue 11)."""
    empty = VerticalEdges(np.empty((0, 3)), np.empty((0, 3)))
    stereo = lines.stereo
    if stereo is None:
        return empty
    seg = np.concatenate([lines.every_segment, np.asarray(lines.short, dtype=np.float64).reshape(-1, 4)])
    if lines.plumb_edges:
        plumb = plumb_segments(stereo.left, stereo.valid_left, grad_x=stereo.gradients[0])
        seg = np.concatenate([seg, plumb])
    if not len(seg):
        return empty
    _, _, n, length, ok = segment_planes(lines, seg)
    tol = np.sin(np.radians(_VERTICAL_DEG) + 1.5 / np.maximum(length, 1.0))
    ok &= (np.abs(n[:, 2]) < tol) & (length >= _MIN_VERTICAL_PX)
    seg = seg[ok]
    if not len(seg):
        return empty
    fb = stereo.focal_px * stereo.baseline_m
    span = (fb / _EDGE_DEPTHS_M[1] - stereo.doffs_px, fb / _EDGE_DEPTHS_M[0] - stereo.doffs_px)
    d, score = edge_disparities(stereo, seg, span)
    with np.errstate(invalid="ignore"):
        keep = np.isfinite(d) & (score >= MIN_EDGE_SCORE) & (d + stereo.doffs_px > 0)
    if not keep.any():
        return empty
    seg, depth = seg[keep], fb / (d[keep] + stereo.doffs_px)
    lower_first = seg[:, 1] > seg[:, 3]  # image rows grow downwards: the foot is the lower end
    foot = np.where(lower_first[:, None], seg[:, :2], seg[:, 2:])
    top = np.where(lower_first[:, None], seg[:, 2:], seg[:, :2])
    # the rays are scaled to unit camera depth: a point at depth z is z rays out
    c = lines.centre
    return VerticalEdges(c + depth[:, None] * lines.rays(foot), c + depth[:, None] * lines.rays(top))
