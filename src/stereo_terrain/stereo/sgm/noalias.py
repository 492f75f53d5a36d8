"""Numba's ``noalias`` compiler flag for the SGM engine's inner loops."""

from __future__ import annotations

from typing import Any

from numba import njit
from numba.core import cpu as numba_cpu


def _allow_noalias_option() -> bool:
    """Let ``@njit`` take ``noalias=True``.

    Numba has this compiler flag (its parallel back end sets it on the kernels it writes)
    but its decorator does not expose it. With it, LLVM knows that no two array arguments
    of the function overlap. Without it, every inner loop over d that writes one array and
    reads others first compares their address ranges at run time before it may use the
    vector code, for each pixel and path; those comparisons (over a hundred instructions
    for three paths) cost more than the 64-disparity loop itself: measured 3x slower.

    Returns False, and the engine compiles without the flag (same result, slower), if a
    Numba version lays out its options differently.
    """
    from numba.core.compiler import Flags

    options = getattr(numba_cpu, "CPUTargetOptions", None)
    if options is None or not callable(getattr(options, "Mapping", None)) or not hasattr(Flags, "noalias"):
        return False
    existing = getattr(options, "noalias", None)
    if existing is None:
        options.noalias = options.Mapping("noalias")
    elif not isinstance(existing, options.Mapping):
        return False
    return True


NOALIAS = _allow_noalias_option()
# ``@njit`` with the flag; for functions whose array arguments never overlap.
njit_no_overlap: Any = njit(cache=True, nogil=True, **({"noalias": True} if NOALIAS else {}))  # type: ignore[call-overload]
