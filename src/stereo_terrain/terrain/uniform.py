"""A staircase's common rise: the steps whose measured rises agree report one rise, their
median (issue 11).

The rises of one staircase are equal: building codes allow a few millimetres between the
tallest and the lowest, and the data's real staircases keep to that. The measured rises
are not: each is the difference of two edges or planes a few centimetres of disparity
noise apart, and on far steps that noise is one or two centimetres. So where a staircase
has ``common_rise_min_steps`` or more measured rises within ``common_rise_tolerance_m`` of
their median, the median of those is its rise, and each of those steps reports it instead
of its own (kept in ``Step.measured_rise_m``). A step further off keeps its
own: it is either a different step (a first step on a thicker floor, a landing) or a
measurement gone wrong, and averaging would hide either from the swing plan. Steps whose
rise was already inferred (:mod:`.continuation`, a first step whose foot is out of view)
take the new median too. The tread heights follow the rises (each tread stands its rise
above the one before it, the first above the ground), so that the model's heights agree
with its rises; the planes and the polytope stay as measured.

Measured on the plane sets of 280 rendered staircases per profile (docs/benchmarks.md,
"Eighth session"): the default profile's rise error p90 halves (about 1-2 cm to 0.4-0.6
cm), the realistic profile's median falls by up to a third; the step count and detection
are unchanged, since only rises change.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._numeric import median
from .model import Step, TerrainConfig


def common_rise(steps: list[Step], ground_z: float, config: TerrainConfig) -> tuple[list[Step], int]:
    """``steps`` with the staircase's common rise where their measured rises agree (module
    docstring), and how many measured rises it replaced (0: unchanged).

    Parameters
    ----------
    steps : the staircase's steps, nearest first
    ground_z : height of the surface before the first step (the frame's z)
    config : TerrainConfig (``common_rise_tolerance_m``, ``common_rise_min_steps``)
    """
    tol = config.common_rise_tolerance_m
    measured = [i for i, s in enumerate(steps) if not s.rise_inferred]
    if tol <= 0 or len(measured) < config.common_rise_min_steps:
        return steps, 0
    rise = float(median(np.array([steps[i].rise_m for i in measured])))
    agree = [i for i in measured if abs(steps[i].rise_m - rise) <= tol]
    if len(agree) < config.common_rise_min_steps:
        return steps, 0  # no majority of agreeing rises: nothing to call the staircase's
    # The median of the rises that agree (a step left out does not pull it).
    rise = float(median(np.array([steps[i].rise_m for i in agree])))
    out: list[Step] = []
    level = ground_z
    for i, s in enumerate(steps):
        if i in agree:
            s = dataclasses.replace(s, rise_m=rise, measured_rise_m=s.rise_m)
        elif s.rise_inferred:
            s = dataclasses.replace(s, rise_m=rise)
        level += s.rise_m
        out.append(dataclasses.replace(s, top_z_m=level))
    return out, len(agree)
