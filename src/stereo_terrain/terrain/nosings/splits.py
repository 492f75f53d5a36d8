"""Steps split where the image shows the nosing between: a double step (a riser between
formed no plane), and steps taller than a stair rise (a chain of every other riser)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..model import Step, TerrainConfig
from .next_nosing import inferred_step, next_nosing
from .view import StairView


def split_too_tall(
    steps: list[Step],
    view: StairView,
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """``steps`` with each step taller than a stair rise (``max_rise_m``) split where the
    image shows the nosing halfway, and how many were split.

    Where every other riser formed no plane (or the first did not), the chain is one of
    double steps: twice the rise, twice the run, self-consistent, so
    :func:`split_double_steps` has no ordinary step to compare with. A rise above
    ``max_rise_m`` is no stair's (the samples' continuation carries it on at that rise).
    A later step is split as a double step is; the first one, the second riser chained
    from the ground, gets a step of half its rise in front of it, a run before it (half
    the staircase's median run where every step is too tall, else that run), where that
    step's nosing shows on the pitch line from the ground. Halves of less than
    ``min_rise_m`` or runs of less than ``min_run_m`` are not made."""
    u = view.u
    out = list(steps)
    if not any(s.rise_m > config.max_rise_m for s in out):
        return out, 0
    runs = [s.run_m for s in out if s.run_m is not None]
    all_tall = all(s.rise_m > config.max_rise_m for s in out)
    split = 0
    i = 0
    while i < len(out):
        step = out[i]
        half_rise = step.rise_m / 2
        if step.rise_m <= config.max_rise_m or half_rise < config.min_rise_m:
            i += 1
            continue
        if i == 0:
            if not runs:
                break
            run = float(np.median(runs)) / (2 if all_tall else 1)
            ground = step.top_z_m - step.rise_m
            a_before = step.axis_position_m - run
            if run < config.min_run_m or (
                next_nosing(view, a_before - run, ground, half_rise, run, config) is None
            ):
                i += 1
                continue
            before = inferred_step(u, a_before, ground + half_rise, half_rise, run)
            out[0] = dataclasses.replace(step, rise_m=half_rise, rise_inferred=True)
            out.insert(0, before)
        else:
            run_before = out[i - 1].run_m
            if (
                run_before is None
                or run_before / 2 < config.min_run_m
                or not _split_at_nosing(out, i, view, half_rise, run_before / 2, config)
            ):
                i += 1
                continue
        split += 1
        i += 2
    return out, split


def _split_at_nosing(
    out: list[Step], i: int, view: StairView, half_rise: float, half_run: float, config: TerrainConfig
) -> bool:
    """Split ``out[i]`` in two, in place, where the nosing halfway along the pitch from
    ``out[i - 1]`` (``half_rise``, ``half_run``) shows (:func:`next_nosing`): the run
    before it halved, a step of ``half_rise`` inserted, both rises inferred. Whether it
    was split."""
    prev, step = out[i - 1], out[i]
    if next_nosing(view, prev.axis_position_m, prev.top_z_m, half_rise, half_run, config) is None:
        return False
    a_mid = prev.axis_position_m + half_run
    out[i - 1] = dataclasses.replace(prev, run_m=half_run)
    out[i] = dataclasses.replace(step, rise_m=half_rise, rise_inferred=True)
    out.insert(i, inferred_step(view.u, a_mid, prev.top_z_m + half_rise, half_rise, half_run))
    return True


def split_double_steps(
    steps: list[Step],
    view: StairView,
    config: TerrainConfig,
) -> tuple[list[Step], int]:
    """``steps`` with each double step split where the image shows the nosing between, and
    how many were split.

    A riser that formed no plane between two that did makes one step of two: about twice
    the staircase's rise, after a run about twice its run (the others' medians; without
    another run, twice the ordinary range). Where a nosing lies halfway along the pitch
    from the step before (:func:`next_nosing`, with half the double rise and run), the
    step becomes two of half its rise, the run before it halved; both rises are inferred.
    Not the first step: the ground before it has no nosing to start the pitch from."""
    out = list(steps)
    split = 0
    i = 1
    while i < len(out):
        step, prev = out[i], out[i - 1]
        rises = [s.rise_m for j, s in enumerate(out) if j != i and not s.rise_inferred]
        runs = [s.run_m for j, s in enumerate(out) if j != i - 1 and s.run_m is not None]
        run_before = prev.run_m
        if step.rise_inferred or not rises or run_before is None:
            i += 1
            continue
        rise = float(np.median(rises))
        if runs:
            run = float(np.median(runs))
            double_run = 1.5 * run <= run_before <= 2.5 * run
        else:
            double_run = 2 * config.continue_min_run_m <= run_before <= 2 * config.continue_max_run_m
        if not (double_run and 1.6 * rise <= step.rise_m <= 2.4 * rise):
            i += 1
            continue
        if not _split_at_nosing(out, i, view, step.rise_m / 2, run_before / 2, config):
            i += 1
            continue
        split += 1
        i += 2
    return out, split
