"""Single-scene pipeline tests and the CPU's rounding.

The pipeline's arithmetic is chaotic in the small: OpenCV, NumPy, OpenBLAS and Numba
each pick their SIMD kernels by the CPU, a last-bit difference in one disparity moves an
MSAC draw, a plane's inliers, a pass's verdict, and so which second opinion finds a
hard scene's stairs. A test that runs the whole pipeline on one scene to show one
mechanism holds two kinds of assertion:

- what holds wherever the mechanism acts, or whatever finds the stairs: the obstacle,
  the steps where the truth has them, gravity within its bound. These are asserted
  always;
- the scene's premise: that the opinions before the mechanism miss what it then finds,
  or that the setting it replaced got the scene wrong. On another CPU the premise may
  not hold (an earlier opinion finds the stairs first), and the scene then does not
  exercise the mechanism. :func:`premise` skips the rest of the test and says so, after
  the assertions that hold either way have run.

Every premise holds on the machines the tests were written on (the last: an AMD EPYC
with AVX2). ``make test-other-cpu`` runs the suite with those four libraries held to
their baseline kernels (no AVX, AVX2, FMA or AVX-512: another rounding of the same
arithmetic); there ten single-scene tests did not set their premise up, and skip saying
so (README, "Development").
"""

from __future__ import annotations

import os

import pytest


def premise(holds: bool, what: str) -> None:
    """Skip the rest of the test, saying so, where its scene does not set up ``what``
    (one line: what the scene must show for the mechanism to be the one tested)."""
    if not holds:
        test = os.environ.get("PYTEST_CURRENT_TEST", "").split(" ")[0]
        pytest.skip(f"{test}: premise not set up by this CPU's rounding: {what}")
