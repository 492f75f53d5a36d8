"""Sub-pixel refinement shared by the CPU (:mod:`.sgm`) and CUDA (:mod:`.sgm.cuda`) SGM
selections; in its own module so that neither imports the other."""

from __future__ import annotations

from numba.extending import register_jitable


@register_jitable
def parabola_peak(arg, a, b, c):  # pragma: no cover - compiled
    """The winner ``arg`` refined by the parabola through its cost ``b`` and its
    neighbours' ``a`` (arg - 1) and ``c`` (arg + 1); float64. Shared by the CPU and the
    CUDA selection. Scalars, not the volume: a jitted call with an array argument counts
    references, measured as a third of the selection's time."""
    den = float(a) - 2.0 * float(b) + float(c)
    if den > 0:
        return arg + 0.5 * (float(a) - float(c)) / den
    return float(arg)
