"""A staircase none of whose risers formed a plane: its first riser as the image's lines
show it, its foot on the floor and its nosing above (issue 11).

On painted stairs the matcher holds nothing on the faces: the fills give bands and
fronto-parallel patches, and on 20 of the 111 painted staircases of four realistic sets
(with a rig) no vertical plane looked like a riser at all. The image still shows the
staircase plainly: every nosing is a long straight edge (a strip, or the shading change
between a lit tread and its riser), and so is the first riser's foot on the floor.

With the floor known (a rig, or a floor plane found), a segment on the floor is placed by
its plane through the camera alone: it meets the floor in one line. A long such line is a
candidate for the first riser's foot (the terrain stage asks for the floor the matcher
holds in front of it); a line a stair's rise above it on the riser's plane, covering as
much of the width, for its nosing. The staircase is then what the terrain stage makes of
a one-riser chain (:func:`~stereo_terrain.terrain.from_lines.staircase_from_lines`): the
pitch the nosings show from that foot on (:func:`~.pitch.pitch_from_nosings`, with its
tests of the risers' feet and of a second pitch that fits as well), the nosings beyond,
the rise they show. A candidate is kept only where that shows three steps or more: a lone
edge pair is any box or shelf.

Whether the floor goes on beyond a foot's line (a tile joint, a board's edge) the samples
do not tell here: on a painted riser they lie anywhere along their rays, and the share of
them on the floor's height beyond its foot was 0.2-0.8 for the true first risers of the
realistic renders against 0.3-1.0 for lines on the floor (docs/benchmarks.md,
"Forty-first session"). The three steps do: no line on a floor of the realistic renders
made three.

The stair axis comes from the segments too: the horizontal direction of each segment's
plane through the camera, weighted by its length, within ``_MAX_YAW_DEG`` of the camera's
lateral axis (stairs are met yawed up to +-60 deg); the peaks are tried in turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import TerrainConfig
from .view import ImageLines, Segments, covered_share, horizontal_directions, on_height, on_riser_plane

#: Stair axes tried: this many peaks of the segments' horizontal directions (each foot
#: and nosing tried costs a one-riser chain's finishing, 10-50 ms).
MAX_AXES = 2

#: The directions searched, either side of the camera's lateral axis (deg).
_MAX_YAW_DEG = 60.0

#: Histogram bin (deg) of the segments' directions; peaks are taken this many bins apart.
_BIN_DEG = 0.5
_PEAK_APART_BINS = 6

#: A peak's segments must be this long together, as a share of the image's width.
_MIN_PILE = 0.25

#: Segments whose lines on the floor lie within this of each other (metres along the
#: axis, and this share of their distance) are one line.
_GROUP_M = 0.02
_GROUP_SHARE = 0.01

#: A foot's line must be this wide (metres) and its segments cover this share of it.
MIN_WIDTH_M = 0.5
_MIN_FOOT_COVER = 0.5

#: The floor lines looked at: this near and far (metres, horizontally from the cameras).
_NEAREST_M = 0.4
_FARTHEST_M = 4.0

#: Candidate feet tried, nearest first, and nosings over each, best covered first (a
#: plank or tiled floor's joints come before the first riser's foot).
MAX_FEET = 8
MAX_NOSINGS = 2

#: Nosing heights on a foot's riser plane within this (metres) of each other are one line.
_NOSING_GROUP_M = 0.01


@dataclass(frozen=True)
class FirstRiser:
    """A first riser the lines show: its foot at ``axis_position_m`` along the stair axis
    on the floor, its nosing ``top_z_m`` high, across ``lateral`` (metres along the
    lateral direction)."""

    axis_position_m: float
    top_z_m: float
    lateral: tuple[float, float]


def line_axes(lines: ImageLines) -> list[float]:
    """The yaws (radians, terrain frame) of the stair axes the segments' horizontal
    directions pile up on (module docstring), strongest first."""
    seg = lines.every_segment
    if not len(seg):
        return []
    _, bearing, length, ok = horizontal_directions(lines, seg)
    cam_x, cam_z = lines.T_frame_camera[:3, 0], lines.T_frame_camera[:3, 2]
    side = math.atan2(float(cam_x[1]), float(cam_x[0]))
    ahead = math.atan2(float(cam_z[1]), float(cam_z[0]))
    off = (bearing - side + math.pi / 2) % math.pi - math.pi / 2
    ok &= np.abs(off) <= math.radians(_MAX_YAW_DEG)
    if not ok.any():
        return []
    edges = np.arange(-_MAX_YAW_DEG, _MAX_YAW_DEG + 1e-9, _BIN_DEG)
    hist = np.histogram(np.degrees(off[ok]), bins=edges, weights=length[ok])[0]
    pile = np.convolve(hist, [1.0, 2.0, 1.0], "same") / 2.0
    yaws = []
    for _ in range(MAX_AXES):
        k = int(np.argmax(pile))
        if pile[k] < _MIN_PILE * lines.image_size[0]:
            break
        peak = 0.5 * (edges[k] + edges[k + 1])
        near = ok & (np.abs(np.degrees(off) - peak) < _BIN_DEG * 2)
        lateral = side + float(np.sum(length[near] * off[near]) / np.sum(length[near]))
        yaw = lateral - math.pi / 2
        if math.cos(yaw - ahead) < 0:  # the axis points away from the cameras
            yaw += math.pi
        yaws.append(math.atan2(math.sin(yaw), math.cos(yaw)))
        pile[max(0, k - _PEAK_APART_BINS) : k + _PEAK_APART_BINS + 1] = 0.0
    return yaws


def first_risers(
    lines: ImageLines, segs: Segments, u: np.ndarray, v: np.ndarray, ground_z: float, config: TerrainConfig
) -> list[FirstRiser]:
    """The first risers the segments ``segs`` (parallel to ``v``) show on the floor at
    ``ground_z``: each long line on the floor (nearest first, at most ``MAX_FEET``) with
    each nosing line over it (a stair's rise up on its riser plane, covering
    ``nosing_min_cover`` of its width), best covered first."""
    c = lines.centre
    p0, p1 = on_height(lines, segs.d0, ground_z), on_height(lines, segs.d1, ground_z)
    a = 0.5 * (p0 + p1) @ u
    lo, hi = np.minimum(p0 @ v, p1 @ v), np.maximum(p0 @ v, p1 @ v)
    reach = a - float(c @ u)
    ok = np.isfinite(a) & np.isfinite(lo) & np.isfinite(hi) & (reach > _NEAREST_M) & (reach < _FARTHEST_M)
    order = np.flatnonzero(ok)[np.argsort(a[ok])]
    out: list[FirstRiser] = []
    feet = 0
    i = 0
    while i < len(order) and feet < MAX_FEET:
        tol = max(_GROUP_M, _GROUP_SHARE * float(reach[order[i]]))
        j = i
        while j + 1 < len(order) and a[order[j + 1]] - a[order[i]] < tol:
            j += 1
        group = order[i : j + 1]
        i = j + 1
        span = (float(lo[group].min()), float(hi[group].max()))
        if span[1] - span[0] < MIN_WIDTH_M or covered_share(lo[group], hi[group], span) < _MIN_FOOT_COVER:
            continue
        feet += 1
        a0 = float(np.median(a[group]))
        for top in nosings_over(lines, segs, u, v, a0, span, ground_z, config):
            out.append(FirstRiser(a0, top, span))
    return out


def nosings_over(
    lines: ImageLines,
    segs: Segments,
    u: np.ndarray,
    v: np.ndarray,
    a0: float,
    span: tuple[float, float],
    ground_z: float,
    config: TerrainConfig,
) -> list[float]:
    """The heights of the lines on the riser plane ``u . x = a0`` a stair's rise above the
    floor whose segments cover ``nosing_min_cover`` of ``span``, best covered first (at
    most ``MAX_NOSINGS``)."""
    z, lo, hi, ahead = on_riser_plane(lines, segs, u, v, a0, 0.5 * (span[0] + span[1]))
    rise = z - ground_z
    ok = np.isfinite(z) & np.isfinite(lo) & np.isfinite(hi) & ahead
    ok &= (rise >= max(config.min_rise_m, 0.08)) & (rise <= config.max_rise_m)
    found: list[tuple[float, float]] = []
    for k in np.flatnonzero(ok)[np.argsort(z[ok])]:
        if any(abs(z[k] - f) < _NOSING_GROUP_M for _, f in found):
            continue
        group = ok & (np.abs(z - z[k]) < _NOSING_GROUP_M)
        share = covered_share(lo[group], hi[group], span)
        if share >= config.nosing_min_cover:
            found.append((share, float(np.median(z[group]))))
    return [top for _, top in sorted(found, key=lambda f: -f[0])][:MAX_NOSINGS]
