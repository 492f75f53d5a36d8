"""The test of one nosing: where on the staircase's pitch line the next nosing after a
step lies, as the segments (or the grey levels) show it with its riser's foot."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...msac import Plane
from ..model import Step, TerrainConfig
from ..risers import riser_distance
from .edges import foot_in_grey_levels
from .view import FOOT_VISIBLE_M, Segments, StairView, covered_share, lateral_on_height, visible_span

#: Segments whose pitch-line positions are within this (in steps) are one nosing.
LAM_GROUP = 0.08


def inferred_step(u: np.ndarray, a: float, top: float, rise: float, run: float | None) -> Step:
    """A step whose riser formed no plane, at ``a`` along the stair axis ``u`` (inferred rise)."""
    plane = Plane(-u, a)  # vertical, facing the robot, u . x = a
    distance = riser_distance(plane, a, u)
    return Step(rise, run, distance, None, top, a, plane, None, rise_inferred=True, position_inferred=True)


def next_nosing(
    view: StairView,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    config: TerrainConfig,
    smoothed: Callable[[], np.ndarray] | None = None,
) -> float | None:
    """The pitch-line position ``lam`` of the next nosing after the step at ``(a_k, top_k)``,
    or None when the segments show none (the package docstring). ``smoothed`` gives the smoothed
    image (:func:`~.edges.smoothed_image`) where a foot the segments do not show may be looked for
    in it."""
    lines, segs, u, v, lat = view.lines, view.segs, view.u, view.v, view.lat
    c = lines.centre
    span = visible_span(view, a_k + run, top_k + rise)
    if span is None:
        return None
    anchor = a_k * u + 0.5 * (lat[0] + lat[1]) * v + np.array([0.0, 0.0, top_k])
    pitch = run * u + np.array([0.0, 0.0, rise])
    den = segs.normal @ pitch
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -(segs.normal @ (anchor - c)) / den
    tol = config.nosing_run_tolerance
    near = np.isfinite(lam) & (np.abs(den) > 1e-9) & (lam > 1.0 - tol) & (lam < 1.0 + tol)
    if not near.any():
        return None
    lo, hi = lateral_on_height(view, top_k + lam * rise)
    near &= np.isfinite(lo) & np.isfinite(hi)
    # The group of segments that covers most of the staircase's width; of groups that
    # cover as much (lines across the whole staircase cover all of it), the nearest to
    # the expected position: with a run measured a few centimetres long, the next nosing
    # and a line beyond it (the tread's far edge, the nosing after) both fall within the
    # tolerance.
    found: dict[float, float] = {}
    for x in lam[near]:
        group = near & (np.abs(lam - x) < LAM_GROUP)
        at = float(np.median(lam[group]))
        if at not in found:
            found[at] = covered_share(lo[group], hi[group], span)
    widest = max(found.values(), default=0.0)
    if widest < config.nosing_min_cover:
        return None
    first = min((at for at, cover in found.items() if cover == widest), key=lambda at: abs(at - 1.0))
    # Where the widest group's riser foot does not show, it is no nosing (a tread's far
    # edge, a rail beyond it): the groups nearer the expected position are tried in turn.
    nearer = [
        at
        for at, cover in found.items()
        if cover >= config.nosing_min_cover and abs(at - 1.0) < abs(first - 1.0)
    ]
    ranked = [first, *sorted(nearer, key=lambda at: abs(at - 1.0))]
    for best in ranked:
        if _foot_shows(view, segs, anchor, pitch, den, a_k, top_k, rise, run, best, config):
            return best
        # No segments at the foot: with the image, its grey levels may still show it.
        if smoothed is not None and foot_in_grey_levels(view, smoothed, a_k, top_k, rise, run, best, config):
            return best
    return None


def _foot_shows(
    view: StairView,
    segs: Segments,
    anchor: np.ndarray,
    pitch: np.ndarray,
    den: np.ndarray,
    a_k: float,
    top_k: float,
    rise: float,
    run: float,
    best: float,
    config: TerrainConfig,
) -> bool:
    """Whether the foot of the riser below a nosing found at pitch position ``best`` is
    in the image where it must be (:func:`next_nosing`)."""
    c = view.lines.centre
    if not c[2] > top_k + FOOT_VISIBLE_M:
        return True
    # The last tread is seen from above, so the next riser's foot is in view: it must
    # show too (a landing's tile joint or far edge has the floor beyond it instead).
    # The feet lie on the pitch line a rise lower: the same well-posed intersection.
    # Where the tread is seen so flat that the foot's line and the last nosing's are
    # one (their pitch positions within twice a group), the foot says nothing.
    foot_anchor = anchor - np.array([0.0, 0.0, rise])
    last_nosing = np.cross(anchor - c, view.v)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam_last = -(last_nosing @ (foot_anchor - c)) / (last_nosing @ pitch)
    foot_span = visible_span(view, a_k + best * run, top_k + (best - 1.0) * rise)
    if foot_span is None or abs(lam_last - best) < 2 * LAM_GROUP:
        return True
    with np.errstate(divide="ignore", invalid="ignore"):
        lam_f = -(segs.normal @ (foot_anchor - c)) / den
    at = np.isfinite(lam_f) & (np.abs(den) > 1e-9) & (np.abs(lam_f - best) < LAM_GROUP)
    flo, fhi = lateral_on_height(view, top_k + (lam_f - 1.0) * rise)
    at &= np.isfinite(flo) & np.isfinite(fhi)
    return covered_share(flo[at], fhi[at], foot_span) >= config.nosing_min_foot_cover
