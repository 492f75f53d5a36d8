"""The project's own Semi-Global Matching engine (Hirschmüller 2005), compiled with Numba.

Stages:

1. **Census cost.** A 5x5 census transform (24 bits) of both images. The matching cost is
   the Hamming distance between the two bit strings (uint8 volume ``C[y, x, d]``). It
   depends only on the order of intensities, so a gain or offset between cheap webcams
   leaves it unchanged. Optionally (``census_epsilon_grey``) a ternary census, blind to
   differences within a few grey levels, for near-uniform faces under noise and JPEG.
2. **Aggregation along 4, 8 or 16 directions r**, the paper's recurrence:
   ``L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d±1) + P1, min_k L_r(p-r, k) + P2')
   - min_k L_r(p-r, k)``.
   P1 penalises 1-px disparity steps. ``P2' = max(P1 + 1, P2 / (1 + |I(p) - I(p-r)| /
   p2_gradient_scale))`` penalises larger jumps, less so across intensity edges.
   ``S(p, d) = sum_r L_r(p, d)``.
3. **Disparity selection.** Winner-take-all with a uniqueness ratio, parabola sub-pixel
   refinement, a left-right consistency check, and speckle removal. Invalid pixels become
   NaN.
4. **Confidence** of each pixel from its cost curve:
   ``(S_second - S_best) / S_second``, with the second best taken outside ``d_best ± 1``.

How it is made fast on two cores (numbers in ``docs/benchmarks.md``):

- Every path update is one loop over d in int16 that LLVM vectorises (32 disparities per
  AVX-512 instruction); see :func:`.aggregate._path_update` for what keeps it vectorisable, and
  :func:`.noalias._allow_noalias_option` for what keeps it free of per-pixel overlap checks.
- Two raster sweeps, one per core: the forward sweep carries the path from the left and
  the paths from the rows above, the backward sweep the mirror images. Each computes the
  matching costs of four rows at a time and, for those rows, first the paths from
  earlier rows (no dependence between the pixels of a row, visited left to right), then
  the paths along the row (the four rows interleaved, so that one pixel's wait on its
  neighbour overlaps with other rows' work). The cost volume is never stored whole.
- One volume S for both sweeps, filled in two phases: the forward sweep writes the top
  half while the backward sweep writes the bottom half; then each goes on into the
  other half, adds its paths, and chooses the disparities of each row it finishes while
  the row is still in cache.

Modules, in the order a frame goes through them:

- :mod:`.config`: :class:`SGMConfig`;
- :mod:`.census`: the census transforms and the matching cost;
- :mod:`.aggregate`: the paths' recurrence and the two sweeps;
- :mod:`.select`: the disparity, sub-pixel and left-right choice, and the confidence;
- :mod:`.speckle`: speckle removal;
- :mod:`.engine`: :class:`SGM`, which runs them on a rectified pair;
- :mod:`.threads` (the sweeps' two threads), :mod:`.noalias` (the compiler flag) and
  :mod:`.cuda` (the same algorithm on a GPU).

Memory: S (int16), ``2 * H * W * D`` bytes: 79 MB at 640x480x128 and 39 MB at 64
disparities, plus row buffers (under 2 MB). An engine keeps S between calls (the next
frame of the same size reuses it).
"""

from .aggregate import ROW_PATHS, aggregate_sweep, p2_table, sweep_state
from .census import census5x5, census_cost, census_ternary
from .config import SGMConfig
from .engine import SGM
from .noalias import NOALIAS
from .select import MAX_DISPARITIES, select_disparity_rows
from .threads import cpu_halves, sweep_pool

__all__ = [
    "MAX_DISPARITIES",
    "NOALIAS",
    "ROW_PATHS",
    "SGM",
    "SGMConfig",
    "aggregate_sweep",
    "census5x5",
    "census_cost",
    "census_ternary",
    "cpu_halves",
    "p2_table",
    "select_disparity_rows",
    "sweep_pool",
    "sweep_state",
]
