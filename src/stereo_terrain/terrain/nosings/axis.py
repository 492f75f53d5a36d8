"""The stair axis as the image's nosings show it (issue 11).

A staircase's axis comes from its riser planes' normals. On painted or carpeted stairs
most of a riser's samples are a fill's plane, whose normal the fill took from a few edges:
on four realistic sets with a rig, 18 of the 55 staircases counted short had an axis more
than 3 deg off (up to 75), against 11 of the 125 counted right (docs/benchmarks.md,
"Fortieth session"). A wrong axis skews every line the nosing tests predict, and the
next nosing's image misses its segments.

The nosings themselves are long straight segments in the image, placed to a fraction of a
pixel. Each segment's plane through the camera holds one horizontal direction (its
normal crossed with up); the segments that are images of the chain's nosings and of its
risers' feet (their rays meet the step's height near its position along the axis, within
its width) hold the lateral direction ``v``. The direction their lengths pile up on, within
``_WINDOW_DEG`` of the risers' ``v``, is the staircase's. Taken where that pile is
``_MIN_PILE`` of the image's width long at least (short segments are no witness: a plank
joint across a tread; three pieces 28-53 px long on a shelf's edge in Middlebury
`Playroom` turned a lone riser 5 deg and made it a two-step staircase at 0.15 of the
width) and it turns the axis by ``_MIN_TURN_DEG`` or more.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..model import Step, stair_axes
from .view import ImageLines, horizontal_directions

#: The lateral directions searched: this far (deg) either side of the risers'.
_WINDOW_DEG = 12.0

#: Histogram bin (deg); each bin is summed with its neighbours (weights 1, 2, 1).
_BIN_DEG = 0.5

#: Segments within this (deg) of the histogram's peak are averaged for the direction.
_PEAK_DEG = 1.0

#: The peak's segments must be at least this long together, as a share of the image's width.
_MIN_PILE = 0.25

#: A segment counts for a step where its middle's ray meets the step's height this near
#: (metres along the axis) the step's position, within its width widened by as much again.
_NEAR_STEP_M = 0.15
_LATERAL_MARGIN_M = 0.3

#: Turns smaller than this (deg) are left alone.
_MIN_TURN_DEG = 0.5


def axis_from_nosings(
    lines: ImageLines, yaw: float, steps: Sequence[Step], lateral: tuple[float, float]
) -> float | None:
    """The stair axis's yaw (radians, terrain frame) that the image's segments on the
    chain's nosings and risers' feet show, near ``yaw`` (the risers'); None where they
    show none clearly or it is within ``_MIN_TURN_DEG`` of ``yaw`` (module docstring).

    Parameters
    ----------
    lines : ImageLines
    yaw : the axis from the risers' normals
    steps : the chain's steps, nearest first (``axis_position_m``, ``top_z_m``, ``rise_m``)
    lateral : the chain's lateral extent along ``v`` at ``yaw``, metres
    """
    seg = np.asarray(lines.segments, dtype=np.float64).reshape(-1, 4)
    if not len(seg) or not steps:
        return None
    mid, bearing, length, ok = horizontal_directions(lines, seg)
    ok &= _on_steps(lines, mid, yaw, steps, lateral)
    # Each segment's horizontal direction against the risers' lateral direction, in
    # (-90, 90] deg (a line has no sign).
    off = (bearing - yaw) % math.pi - math.pi / 2
    window = math.radians(_WINDOW_DEG)
    ok &= np.abs(off) < window
    if not ok.any():
        return None
    edges = np.arange(-_WINDOW_DEG, _WINDOW_DEG + 1e-9, _BIN_DEG)
    hist = np.histogram(np.degrees(off[ok]), bins=edges, weights=length[ok])[0]
    pile = np.convolve(hist, [1.0, 2.0, 1.0], "same")
    k = int(np.argmax(pile))
    peak = 0.5 * (edges[k] + edges[k + 1])
    near = ok & (np.abs(np.degrees(off) - peak) < _PEAK_DEG)
    if float(np.sum(length[near])) < _MIN_PILE * lines.image_size[0]:
        return None
    turn = float(np.sum(length[near] * off[near]) / np.sum(length[near]))
    if abs(math.degrees(turn)) < _MIN_TURN_DEG:
        return None
    return yaw + turn


def _on_steps(
    lines: ImageLines,
    mid: np.ndarray,
    yaw: float,
    steps: Sequence[Step],
    lateral: tuple[float, float],
) -> np.ndarray:
    """Which rays ``mid`` (a segment's middle) meet a step's nosing height, or its riser's
    foot height, near the step's position along the axis and within the chain's width."""
    u, v = stair_axes(yaw)
    c = lines.centre
    lo, hi = lateral[0] - _LATERAL_MARGIN_M, lateral[1] + _LATERAL_MARGIN_M
    on = np.zeros(len(mid), dtype=bool)
    for step in steps:
        for z in (step.top_z_m, step.top_z_m - step.rise_m):
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (z - c[2]) / mid[:, 2]
            p = c + t[:, None] * mid
            along, across = p @ u, p @ v
            on |= (
                (t > 0)
                & (np.abs(along - step.axis_position_m) < _NEAR_STEP_M)
                & (across > lo)
                & (across < hi)
            )
    return on
