"""The staircase's pitch from its nosings' lines, anchored at its first riser's foot
(:func:`pitch_from_nosings`): a chain that stands on one riser plane is rebuilt on it, one
of several carried on by it (:func:`~.steps.pitched_steps`).

A chain of one riser plane has one measured rise, its riser's top edge, where the
matcher's noise is worst; every step after it is placed at that rise and at a run that
one more measurement gave (the samples' continuation, two nosings beyond a lone step).
On the realistic renders such chains are the commonest wrong count: a painted riser 5 cm
too tall, and the steps beyond it land between the nosings (docs/benchmarks.md,
"Twenty-fourth session"). The image holds more: every nosing is a line, and the nosings
of a staircase whose first riser stands at ``a0`` on the ground at ``z0`` lie at
``(a0 + (k - 1) run, z0 + k rise)``, ``k = 1, 2, ...``. Each rise and run of the ordinary
range (``min_rise_m`` to ``max_rise_m``, ``continue_min_run_m`` to
``continue_max_run_m``) puts those lines somewhere in the image; the pair that puts the
most of them, from the first on, where segments cover ``nosing_min_cover`` of the
staircase's width in view (as :func:`~.next_nosing.next_nosing` asks of one), is the
staircase's pitch. A segment is nosing ``k`` where its plane through the camera meets the
pitch line within ``LAM_GROUP`` steps of ``k``.

Where the cameras see a tread from above (and taller than ``EDGE_ON_PX``), the next
riser's foot must show too, a run beyond the nosing at its height: plank joints and grain
lines on wooden risers fit a pitch of half a stair's rise, but have no feet behind them.
The rise and run are then placed by least squares on the lines they explain (each line's
plane through the camera holds it: linear in both). No pitch is given where another rise,
more than a group apart, shows nearly as many nosings (one fewer): cameras at or below the
treads see a line by its elevation alone, and the two edges of a nosing strip are two
lines, so short staircases there fit more than one pitch (docs/benchmarks.md,
"Twenty-fourth session": a wooden staircase seen from 0.34 m read 17.8 cm for 21.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import TerrainConfig
from .next_nosing import LAM_GROUP
from .view import (
    EDGE_ON_PX,
    FOOT_VISIBLE_M,
    StairView,
    covered_share,
    lateral_on_height,
    tread_height_px,
    visible_span,
)

#: The rises and runs tried (metres apart): within a group of the sixth nosing of an
#: ordinary staircase; the least-squares fit then places them (:func:`_refined`).
_RISE_STEP_M = 0.003
_RUN_STEP_M = 0.006

#: The most nosings looked for (the chain's own and those beyond; :func:`~.steps.nosing_steps`
#: looks for the ones after).
MAX_NOSINGS = 6

#: Distinct explanations of the lines verified with the exact cover test, best first by
#: the quick count.
_VERIFIED = 12


@dataclass(frozen=True)
class Pitch:
    """A staircase's rise and run from its nosings' lines, and how many of them show from
    the first on."""

    rise_m: float
    run_m: float
    nosings: int


def pitch_from_nosings(
    view: StairView,
    a0: float,
    z0: float,
    config: TerrainConfig,
    *,
    min_nosings: int = 3,
    near: tuple[float, float] | None = None,
) -> Pitch | None:
    """The rise and run that put the most nosings, from the first on and at least
    ``min_nosings``, where the image's segments show them (the module docstring), for a
    staircase whose first riser stands at ``a0`` along ``view.u`` on the ground at height
    ``z0``; None where no pair puts that many. ``near``: a rise and run known already (a
    chain of several riser planes); only those within a third of each are tried (of the
    ordinary range), and a fit at the edge of that is none."""
    segs = view.segs
    if len(segs.normal) < min_nosings:
        return None
    rise_lo, rise_hi = config.min_rise_m, config.max_rise_m
    run_lo, run_hi = config.continue_min_run_m, config.continue_max_run_m
    if near is not None:
        rise_lo, rise_hi = max(rise_lo, near[0] * 2.0 / 3.0), min(rise_hi, near[0] * 4.0 / 3.0)
        run_lo, run_hi = max(run_lo, near[1] * 2.0 / 3.0), min(run_hi, near[1] * 4.0 / 3.0)
    rises = np.arange(rise_lo, rise_hi + 1e-9, _RISE_STEP_M)
    runs = np.arange(run_lo, run_hi + 1e-9, _RUN_STEP_M)
    if len(rises) < 3 or len(runs) < 3:
        return None
    R, L = (g.ravel() for g in np.meshgrid(rises, runs, indexing="ij"))
    # Nosing k is N0 + k p: N0 = (a0 - run) u + z0 z (the foot's line a run before the
    # first riser), p = run u + rise z. Each segment's plane meets that line at one lam.
    terms = _foot_terms(view, a0, z0)
    base, nu, nz = terms  # (S,) each
    Lf, Rf = L.astype(np.float32)[:, None], R.astype(np.float32)[:, None]
    den = Lf * nu.astype(np.float32)[None, :] + Rf * nz.astype(np.float32)[None, :]  # (C, S)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -(base.astype(np.float32)[None, :] - Lf * nu.astype(np.float32)[None, :]) / den
    lam[~(np.abs(den) > 1e-9)] = np.nan
    # The quick count: consecutive nosings from the first with a segment within a group,
    # and the mean distance (in steps) of the nearest segment to each of them.
    has = np.zeros((len(R), MAX_NOSINGS + 1), dtype=bool)
    off = np.full((len(R), MAX_NOSINGS), np.inf, dtype=np.float32)
    for j in range(MAX_NOSINGS):
        d = np.abs(lam - np.float32(j + 1))
        off[:, j] = np.where(d < LAM_GROUP, d, np.inf).min(axis=1)
        has[:, j] = np.isfinite(off[:, j])
    quick = np.argmin(has, axis=1)  # the first nosing missing (the last column never shows)
    if quick.max() < min_nosings:
        return None
    counted = np.arange(MAX_NOSINGS)[None, :] < quick[:, None]
    spread = np.where(counted, np.where(np.isfinite(off), off, 0.0), 0.0).sum(axis=1) / np.maximum(quick, 1)
    order = np.lexsort((spread, -quick))
    # Distinct explanations of the lines, best first by the quick count, each verified: a
    # pitch whose nosings take, each, one of the segments that a pitch verified before
    # takes there, at a rise within a group of its (a neighbour of it: the same lines),
    # is not looked at again.
    verified: list[tuple[int, float, int]] = []  # (nosings shown, spread, index)
    taken: list[np.ndarray] = []  # each verified pitch's segments per nosing, (K, S) bool
    ks = np.arange(1, MAX_NOSINGS + 1, dtype=np.float32)[:, None]
    for i in order:
        if quick[i] < min_nosings or len(verified) == _VERIFIED:
            break
        mine = np.abs(lam[i][None, :] - ks[: int(quick[i])]) < LAM_GROUP
        if any(
            abs(R[i] - R[j]) <= LAM_GROUP * R[j]
            and bool((mine[: len(other)] & other[: len(mine)]).any(axis=1).all())
            for (_, _, j), other in zip(verified, taken, strict=True)
        ):
            continue
        shown = _nosings_shown(
            view, terms, lam[i].astype(np.float64), a0, z0, float(R[i]), float(L[i]), int(quick[i]), config
        )
        verified.append((shown, float(spread[i]), int(i)))
        taken.append(mine)
    ranked = sorted(verified, key=lambda x: (-x[0], x[1]))
    if not ranked or ranked[0][0] < min_nosings:
        return None
    best = ranked[0]
    rise_best = float(R[best[2]])
    for shown, _, j in ranked[1:]:
        if _at_edge(R[j], L[j], rises, runs):
            continue  # its best fit lies outside the ordinary range: no staircase's
        if shown >= max(min_nosings, best[0] - 1) and abs(float(R[j]) - rise_best) > LAM_GROUP * rise_best:
            # another rise shows (nearly) as many nosings: the lines do not pin it (cameras
            # at or below the treads see a line by its elevation alone, and the edges of
            # nosing strips and plank joints are lines too)
            return None
    shown, _, i = best
    if _at_edge(R[i], L[i], rises, runs):
        return None  # at the edge of the ordinary range: the lines' best fit lies outside it
    rise, run = _refined(terms, lam[i].astype(np.float64), float(R[i]), float(L[i]), shown, config)
    if (rise, run) != (float(R[i]), float(L[i])):
        lam_refined = _on_pitch(terms, rise, run)
        if _nosings_shown(view, terms, lam_refined, a0, z0, rise, run, shown, config) == shown:
            return Pitch(rise, run, shown)
    return Pitch(float(R[i]), float(L[i]), shown)


def _foot_terms(view: StairView, a0: float, z0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each segment's plane (through the camera) against the staircase's first riser's
    foot line, at its lateral middle: ``n . (F0 - c)``, ``n . u`` and ``n . z`` (for
    :func:`_on_pitch`)."""
    n = view.segs.normal
    foot = 0.5 * (view.lat[0] + view.lat[1]) * view.v + a0 * view.u + np.array([0.0, 0.0, z0])
    return n @ (foot - view.lines.centre), n @ view.u, n[:, 2]


def _on_pitch(
    terms: tuple[np.ndarray, np.ndarray, np.ndarray], rise: float, run: float, *, feet: bool = False
) -> np.ndarray:
    """Where each segment's plane meets the pitch line of ``rise`` and ``run`` (``terms``:
    :func:`_foot_terms`), in steps: nosing ``k`` at ``k`` (``(k - 1) run`` along and ``k
    rise`` up from the first riser's foot), or with ``feet`` the foot of riser ``j + 1`` at
    ``j`` (``j`` runs along, ``j`` rises up); NaN where a plane holds the line's direction."""
    base, nu, nz = terms
    with np.errstate(divide="ignore", invalid="ignore"):
        return -(base - (0.0 if feet else run) * nu) / (run * nu + rise * nz)


def lines_beyond(view: StairView, a0: float, z0: float, rise: float, run: float, steps: int) -> bool:
    """Whether any segment's plane through the camera meets the pitch line of a staircase
    of ``rise`` and ``run`` (first riser at ``a0`` on the ground at ``z0``) beyond its
    ``steps``-th nosing (a quarter of a step on, up to ``MAX_NOSINGS``): else no pitch
    found near it can carry a chain of ``steps`` on (:func:`~.steps.pitched_steps`)."""
    lam = _on_pitch(_foot_terms(view, a0, z0), rise, run)
    return bool(np.any((lam > steps + 0.25) & (lam < MAX_NOSINGS + 0.5)))


def _at_edge(rise: float, run: float, rises: np.ndarray, runs: np.ndarray) -> bool:
    """Whether a pitch of the grid lies at the edge of the ordinary range searched."""
    return bool(rise in (rises[0], rises[-1]) or run in (runs[0], runs[-1]))


def _refined(
    terms: tuple[np.ndarray, np.ndarray, np.ndarray],
    lam: np.ndarray,
    rise: float,
    run: float,
    shown: int,
    config: TerrainConfig,
) -> tuple[float, float]:
    """The rise and run that put the ``shown`` nosings' segments (those within a group of
    nosing ``k`` at pitch positions ``lam``) and the risers' feet between them on their
    lines, by least squares (each segment's plane through the camera must hold its line:
    linear in the rise and the run); ``(rise, run)`` where they do not fix both or leave the
    ordinary range."""
    # Nosing k lies in segment s's plane where base_s + (k - 1) run nu_s + k rise nz_s = 0;
    # the foot of riser k + 1 (a run beyond nosing k, at its height) where
    # base_s + k run nu_s + k rise nz_s = 0.
    base, nu, nz = terms
    lam_foot = _on_pitch(terms, rise, run, feet=True)
    rows, rhs = [], []
    for k in range(1, shown + 1):
        for s in np.flatnonzero(np.abs(lam - k) < LAM_GROUP):
            rows.append(((k - 1) * nu[s], k * nz[s]))
            rhs.append(-base[s])
        if k < shown:
            for s in np.flatnonzero(np.abs(lam_foot - k) < LAM_GROUP):
                rows.append((k * nu[s], k * nz[s]))
                rhs.append(-base[s])
    A = np.asarray(rows, dtype=np.float64).reshape(-1, 2)
    if len(A) < 2 or np.linalg.matrix_rank(A) < 2:
        return rise, run
    (fit_run, fit_rise), *_ = np.linalg.lstsq(A, np.asarray(rhs), rcond=None)
    ordinary = config.min_rise_m <= fit_rise <= config.max_rise_m
    if not (ordinary and config.continue_min_run_m <= fit_run <= config.continue_max_run_m):
        return rise, run
    return float(fit_rise), float(fit_run)


def _nosings_shown(
    view: StairView,
    terms: tuple[np.ndarray, np.ndarray, np.ndarray],
    lam: np.ndarray,
    a0: float,
    z0: float,
    rise: float,
    run: float,
    most: int,
    config: TerrainConfig,
) -> int:
    """How many nosings, from the first on (at most ``most``), the segments at pitch
    positions ``lam`` show over ``nosing_min_cover`` of the staircase's width in view
    (``terms``: :func:`_foot_terms`, for the risers' feet)."""
    with np.errstate(invalid="ignore"):  # rays along the height's plane: NaN
        lo, hi = lateral_on_height(view, z0 + lam * rise)
    ok = np.isfinite(lam) & np.isfinite(lo) & np.isfinite(hi)
    # The risers' feet: foot j (of riser j + 1) lies a run beyond nosing j, at its height.
    lam_foot = _on_pitch(terms, rise, run, feet=True)
    with np.errstate(invalid="ignore"):
        flo, fhi = lateral_on_height(view, z0 + lam_foot * rise)
    foot_ok = np.isfinite(lam_foot) & np.isfinite(flo) & np.isfinite(fhi)
    for k in range(1, most + 1):
        span = visible_span(view, a0 + (k - 1) * run, z0 + k * rise)
        group = ok & (np.abs(lam - k) < LAM_GROUP)
        if (
            span is None
            or not group.any()
            or covered_share(lo[group], hi[group], span) < config.nosing_min_cover
        ):
            return k - 1
        if k > 1 and not _foot_shows(view, foot_ok, lam_foot, flo, fhi, a0, z0, rise, run, k - 1, config):
            return k - 1
    return most


def _foot_shows(
    view: StairView,
    ok: np.ndarray,
    lam_foot: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    a0: float,
    z0: float,
    rise: float,
    run: float,
    j: int,
    config: TerrainConfig,
) -> bool:
    """Whether riser ``j + 1``'s foot shows where it must: where the cameras are above tread
    ``j`` (``FOOT_VISIBLE_M``) and see it taller than ``EDGE_ON_PX`` (else its nosing's line
    and the foot's are one), segments at the foot's pitch position ``j`` cover
    ``nosing_min_foot_cover`` of the width in view. Plank joints and grain lines on wooden
    risers fit a pitch of half a stair's rise as nosings, but have no feet behind them."""
    z = z0 + j * rise
    if not view.lines.centre[2] > z + FOOT_VISIBLE_M:
        return True
    front, back = a0 + (j - 1) * run, a0 + j * run
    if not tread_height_px(view, front, back, z) >= EDGE_ON_PX:
        return True
    span = visible_span(view, back, z)
    if span is None:
        return True
    at = ok & (np.abs(lam_foot - j) < LAM_GROUP)
    return bool(at.any()) and covered_share(lo[at], hi[at], span) >= config.nosing_min_foot_cover
