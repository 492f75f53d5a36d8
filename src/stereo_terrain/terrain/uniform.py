"""A staircase's common rise and run: the steps whose measured rises (runs) agree report
one rise (run), their median (issue 11).

The steps of one staircase are equal: building codes allow about a centimetre between the
tallest and the lowest rise, and as much between the runs, and the data's real staircases
keep to that. The measured ones are not: a rise is the difference of two heights, a run
the difference of two riser positions, each a few centimetres of disparity noise, worst
on the far steps. So where a staircase has ``common_min_steps`` or more measured rises
within ``common_rise_tolerance_m`` of their median, that median is its rise, and each of
those steps reports it instead of its own (kept in ``Step.measured_rise_m``); the
same for the runs (``common_run_tolerance_m``, ``Step.measured_run_m``; the tolerance is
wider, since a riser's position is less sure than a height, and ``common_min_runs``, two,
are enough: the mean of two runs is half the span from the first riser to the third,
which leaves out the middle riser's error; two runs must lie within the tolerance of each
other). A step further off keeps its
own: it is either a different step (a first step on a thicker floor, a landing) or a
measurement gone wrong, and averaging would hide either from the swing plan. One wrong
measurement is told apart (:func:`misplaced_top`): two neighbours on either side of the
common rise, each further than the tolerance and their mean within half of it, beside
``common_min_steps - 1`` or more others that agree. The top between them is one height,
the first's tread and the second's foot; measured too high or too low, it makes one rise
longer by as much as the next is shorter, and both report the common rise. Steps whose
rise was inferred (:mod:`.continuation`, a first step whose foot is out of view) take the
common rise too. The tread heights follow the rises (each tread stands its rise above the
one before it, the first above the ground), so that the model's heights agree with its
rises (a step without a tread plane takes its polytope top from that height); the riser
positions and distances and the planes stay as measured. Pooled values may differ by up
to twice the tolerance between them (the two across a misplaced top by more), so the
swing plan clears the larger of a step's common and measured rise
(:func:`stereo_terrain.swing.plan_swing`).

Measured on the plane sets of 280 rendered staircases per profile (docs/benchmarks.md,
"Eighth session"): rise and run errors fall on both profiles (the default profile's rise
p90 to about a third), and the step count and detection do not change, since only rises
and runs do.

Where the image's line segments show two or more of the staircase's nosings
(:func:`~.nosings.nosing_heights`, ``TerrainConfig.nosing_rise``), the common rise is the
one that puts them at their heights instead (:func:`rise_from_nosings`): a nosing's
segments fix its elevation from the cameras to a fraction of a pixel, a few millimetres
at stair distances, where a top from the samples carries the disparity's centimetres. On
realistic webcam-like renders (wood whose faces the matcher barely holds) the rise error's
median fell by a quarter to a third (docs/benchmarks.md, "Nineteenth session"). The steps
whose measured rise lies within ``common_rise_tolerance_m`` of it report it; the rest keep
their own, as above.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection

import numpy as np

from .._numeric import median
from .model import Step, TerrainConfig


def _agreeing(values: dict[int, float], tol: float, min_count: int) -> tuple[list[int], float]:
    """The keys of ``values`` within ``tol`` of their median, and that median; no keys
    when fewer than ``min_count`` (or ``tol`` is 0: off). (The median of only those that
    agree was measured too: no better on the default profile, 0.4 cm worse in the
    realistic seed-11 rise median without a rig.)"""
    if tol <= 0 or len(values) < min_count:
        return [], 0.0
    centre = float(median(np.array(list(values.values()))))
    agree = [i for i, x in values.items() if abs(x - centre) <= tol]
    if len(agree) < min_count:
        return [], 0.0  # no majority that agrees: nothing to call the staircase's
    return agree, centre


def _agreeing_runs(values: dict[int, float], config: TerrainConfig) -> tuple[list[int], float]:
    """:func:`_agreeing` for the runs (``common_run_tolerance_m``, ``common_min_runs``),
    except that two runs agree only where they differ by no more than the tolerance: each
    is within that of their median (their mean) wherever they differ by up to twice it,
    which would pool a 28 and a 46 cm tread."""
    tol = config.common_run_tolerance_m
    if len(values) == 2 and max(values.values()) - min(values.values()) > tol:
        return [], 0.0
    return _agreeing(values, tol, config.common_min_runs)


#: Nosings whose heights the staircase's rise is fitted to: at least this many (one more
#: where the ground's height is not known, so that the fit is still checked).
_MIN_NOSINGS = 2


def rise_from_nosings(
    heights: list[float | None], ground_z: float | None, config: TerrainConfig, *, lone: bool = False
) -> tuple[float, list[int]] | None:
    """The rise that puts the staircase's nosings at their heights: the least-squares ``R``
    of ``heights[i] = ground_z + (i + 1) R`` over the steps whose nosing shows (not None),
    ``_MIN_NOSINGS`` or more. With ``ground_z`` None (the first step's foot out of view, its
    rise inferred), ``heights[i] = b + (i + 1) R`` over one more. None where fewer show,
    where one lies further than ``common_rise_tolerance_m`` from the fit (a nosing not a
    step from the next, a double step, a line that is no nosing), or where ``R`` is no
    stair rise (``min_rise_m``, ``max_rise_m``). Else ``R`` and the indices of the steps
    whose nosings it fits.

    ``lone``: the staircase is a single step whose top no tread plane measured (its top is
    its riser's top edge from the samples, the weakest height the samples give: found low
    by the edge bias, :func:`~.risers.edge_bias`). With the ground known, its own nosing is
    enough: its height above the ground is the rise. Nothing else checks it, but the window
    it was looked for in (:func:`~.nosings.nosing_heights`) and the rise's bounds. On 14
    such steps of realistic renders the rise error's median fell from 3.9 to 2.3 cm (8
    nearer the truth, 6 further; docs/benchmarks.md, "Twentieth session").

    Parameters
    ----------
    heights : each step's nosing height (frame z, metres) or None, nearest step first
    ground_z : height of the surface before the first step, or None where unknown
    config : TerrainConfig
    lone : see above
    """
    k = np.array([i + 1.0 for i, h in enumerate(heights) if h is not None])
    h = np.array([x for x in heights if x is not None], dtype=np.float64)
    needed = 1 if lone and len(heights) == 1 and ground_z is not None else _MIN_NOSINGS + (ground_z is None)
    if config.common_rise_tolerance_m <= 0 or len(k) < needed:
        return None
    if ground_z is not None:
        h = h - ground_z
        rise = float(k @ h / (k @ k))
        residuals = h - k * rise
    else:
        A = np.stack([k, np.ones_like(k)], axis=1)
        coef = np.linalg.lstsq(A, h, rcond=None)[0]
        rise, residuals = float(coef[0]), h - A @ coef
    if float(np.max(np.abs(residuals))) > config.common_rise_tolerance_m:
        return None
    if not config.min_rise_m <= rise <= config.max_rise_m:
        return None
    return rise, [i for i, x in enumerate(heights) if x is not None]


def misplaced_top(
    measured: dict[int, float], rises: list[int], rise: float, config: TerrainConfig
) -> tuple[float, int] | None:
    """Two neighbouring steps left out of the common rise because the top between them
    (the first's tread, the second's foot: one height) was measured too high or too low:
    one rise is then longer by as much as the next is shorter, and their mean is a rise
    measured as well as any.

    Where every other measured rise agrees (``common_min_steps - 1`` or more of them:
    with the pair's mean, as many as the median's rule asks) and the two lie on either
    side of the common rise, each further than ``common_rise_tolerance_m``, their mean
    within half of it: the common rise and the first of the two's index. The common rise
    is ``rise`` where the others are exactly ``rises`` (a majority already agreed without
    the pair, or the nosings' rise took them); where no majority agreed (``rises``
    empty), the others' median, all of them within the tolerance of it; where ``rises``
    is some other set, there is no such pair. Else None. A single odd rise (a first step
    on a thicker floor, a landing) is no such pair and keeps its own, as do two
    neighbours both too tall (double steps) and a pair beside fewer than
    ``common_min_steps - 1`` others (two rises alone cannot tell which is wrong).

    Parameters
    ----------
    measured : the measured rises by step index (inferred steps left out: two steps with
        an inferred one between them share no top)
    rises, rise : the steps that report the common rise and that rise (none, 0.0: no
        majority agreed)
    config : TerrainConfig (``common_rise_tolerance_m``, ``common_min_steps``)
    """
    tol = config.common_rise_tolerance_m
    if tol <= 0 or len(measured) < config.common_min_steps + 1:
        return None
    for j in sorted(measured):
        if j + 1 not in measured:
            continue
        others = {i: x for i, x in measured.items() if i not in (j, j + 1)}
        if rises:
            if set(rises) != set(others):
                continue
            common = rise
        else:
            common = float(median(np.array(list(others.values()))))
            if any(abs(x - common) > tol for x in others.values()):
                continue
        mean = 0.5 * (measured[j] + measured[j + 1])
        low, high = sorted((measured[j] - common, measured[j + 1] - common))
        if low < -tol and high > tol and abs(mean - common) <= 0.5 * tol:
            return common, j
    return None


def takers_of_rise(
    steps: list[Step], rise_m: float, config: TerrainConfig, *, fits: Collection[int] = ()
) -> list[int]:
    """The indices of the measured steps of ``steps`` that report ``rise_m``, a rise
    measured otherwise (:func:`rise_from_nosings`): those of ``fits`` and those whose
    measured rise is within ``common_rise_tolerance_m`` of it (:func:`common_steps`)."""
    tol = config.common_rise_tolerance_m
    return [
        i for i, s in enumerate(steps) if not s.rise_inferred and (i in fits or abs(s.rise_m - rise_m) <= tol)
    ]


def common_steps(
    steps: list[Step],
    ground_z: float,
    config: TerrainConfig,
    *,
    rise_m: float | None = None,
    fits: Collection[int] = (),
) -> tuple[list[Step], int, int, int | None]:
    """``steps`` with the staircase's common rise and run where their measured ones agree
    (module docstring), how many measured rises and runs they replaced (0, 0:
    unchanged), and the first of two neighbours that report the common rise across a
    misplaced top (:func:`misplaced_top`), or None.

    Parameters
    ----------
    steps : the staircase's steps, nearest first
    ground_z : height of the surface before the first step (the frame's z)
    config : TerrainConfig (``common_rise_tolerance_m``, ``common_run_tolerance_m``,
        ``common_min_steps``, ``common_min_runs``)
    rise_m : the staircase's rise measured otherwise (:func:`rise_from_nosings`), or None.
        Given, the steps of ``fits`` (those whose nosings it fits) and those whose measured
        rise is within ``common_rise_tolerance_m`` of it report it, one or more; where none
        does, the median's rule above decides.
    fits : indices of steps that take ``rise_m`` whatever their measured rise
    """
    measured = {i: s.rise_m for i, s in enumerate(steps) if not s.rise_inferred}
    rises: list[int] = []
    rise = 0.0
    if rise_m is not None:
        rises = takers_of_rise(steps, rise_m, config, fits=fits)
        rise = rise_m
    if not rises:
        rises, rise = _agreeing(measured, config.common_rise_tolerance_m, config.common_min_steps)
    pair = None  # the first of two neighbours across a misplaced top
    found = misplaced_top(measured, rises, rise, config)
    if found is not None:
        rise, pair = found
        rises = sorted(measured)
    runs, run = _agreeing_runs({i: s.run_m for i, s in enumerate(steps) if s.run_m is not None}, config)
    if not rises and not runs:
        return steps, 0, 0, None
    out: list[Step] = []
    level = ground_z
    for i, s in enumerate(steps):
        if i in rises:
            s = dataclasses.replace(s, rise_m=rise, measured_rise_m=s.rise_m)
        elif rises and s.rise_inferred:
            s = dataclasses.replace(s, rise_m=rise)
        if i in runs:
            s = dataclasses.replace(s, run_m=run, measured_run_m=s.run_m)
        level += s.rise_m
        out.append(dataclasses.replace(s, top_z_m=level) if rises else s)
    return out, len(rises), len(runs), pair
