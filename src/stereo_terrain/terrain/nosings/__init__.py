"""Steps the image's line segments show: beyond the last one, and inside double steps
(issue 11).

Far up a staircase the risers are a few pixels of disparity noise tall: they form no plane
and their samples do not sit at one position (:mod:`~stereo_terrain.terrain.continuation` then finds nothing),
but their edges are still plain in the image. On realistic rendered stairs a step's nosing
is a long straight intensity edge (a dark strip, or the shading change between riser and
tread) where the matcher holds nothing (docs/benchmarks.md, "Twelfth session").

A nosing is a horizontal 3D line along the staircase's lateral direction ``v``. The line
segments of the rectified left image (LSD, found beside the matcher for gravity and the
Manhattan fill, :mod:`stereo_terrain.gravity.from_lines`) that are images of such lines are
those whose plane through the camera centre contains ``v``. Where the chain's last step is
``(a_k, top_k)`` and its steps' median rise and run are ``R`` and ``L``, the next nosing
lies on the staircase's pitch line ``(a_k + lam L, top_k + lam R)`` near ``lam = 1``: each
such segment's plane meets that line at one ``lam``. A height error of the last top, or a
nosing near the cameras' horizon, would make the segment's own depth (its plane met with
the tread's height) unreliable; the pitch line's slope keeps the intersection well posed.

The next step is accepted where:

- segments within ``LAM_GROUP`` of one ``lam`` in ``[1 - tol, 1 + tol]`` (``tol`` =
  ``nosing_run_tolerance``) cover ``nosing_min_cover`` of the staircase's width as far as
  it is in view at that depth: texture, grout lines and plank joints are short or broken
  lines; a nosing spans the staircase. The group that covers most is the candidate; of
  groups that cover as much (each across the whole staircase), the one nearest ``lam =
  1`` (with a run measured a few centimetres long, the next nosing and a line beyond it
  both fall within the tolerance);
- where the cameras are above the last tread (so the foot of the next riser is in view)
  and see it steeply enough that the foot's line is not the last nosing's, segments on
  that tread's height at the same position cover ``nosing_min_foot_cover``: a riser has a
  foot; the grout lines of a landing's tiles or the far edge of a platform have a floor at
  that height beyond them instead. Where the candidate's foot does not show, the groups
  nearer ``lam = 1`` that cover ``nosing_min_cover`` are tried in turn (a line beyond the
  nosing can cover more of the width than the nosing itself, which a baluster crosses);

and it is not added where the samples in the image of its riser lie on the last tread's
height beyond it, more of them than stand above that tread (a landing the matcher holds:
tile joints are long lines too), or a wall stands across the stairs there.

A nosing at the cameras' height is seen edge-on: its tread is no taller than a line in
the image (``view.EDGE_ON_PX``) and the foot of the riser above meets it there, so nothing
tells its line from the horizon. Where it does not show and its tread is so seen, the
nosing after it (a step further along the same pitch line) is asked of the segments
alone; where that one shows, both steps are added. Level cameras at a staircase's foot
see this at every staircase taller than they are (docs/benchmarks.md, "Twenty-fourth
session").

A step so found gets the staircase's median run as its position and the median rise (a
step found beyond the last riser plane by :mod:`~stereo_terrain.terrain.continuation`
does the same, and says so with ``rise_inferred``): the segment gives where a nosing is,
not precisely which of a nosing strip's two edges it is. Measured on the same renders,
its positions are closer to the truth that way (docs/benchmarks.md).

Where the segments show no next nosing, the image itself is asked
(:func:`edge_nosing`, ``nosing_edge_contrast``; the pipeline hands the rectified left
image over in :class:`ImageLines`): LSD keeps only the lines it is sure of, and a white
nosing between two white faces seen from below gives it a few short pieces. Along the
predicted line's image, a nosing is a step edge: the grey levels a few pixels either side
differ, with one sign, over ``nosing_min_cover`` of the width (texture differs either way,
a plank gap or a dark strip's middle not at all; :func:`edge_cover`). The same foot test
follows, with the foot's image apart from the nosing's (a camera a little above the last
tread sees the tread's far end as one edge for both), and no line within ``HORIZON_DEG``
of the cameras' height is taken (the horizon, the sky's edge).

The same test on other pitch lines serves three more cases: a lone step, whose run is the
one that puts two nosings beyond it (:func:`~.steps._run_from_two_nosings`); a double step, split
where the nosing halfway shows (:func:`split_double_steps`); and steps taller than a
stair rise, a chain of every other riser, split the same way (:func:`split_too_tall`).

Each step's nosing height as its segments show it on its riser plane
(:func:`nosing_heights`) is what the staircase's rise is fitted to where two or more show
(:func:`~stereo_terrain.terrain.uniform.rise_from_nosings`, ``TerrainConfig.nosing_rise``).

A chain is also carried on where the image shows its next risers' ends: vertical edges a
rise tall, about a run apart, placed by both images (:func:`end_steps`,
``TerrainConfig.riser_end_steps``: a painted staircase seen at an angle).

The chain's axis itself is turned to the one its nosings' segments show where they
show one clearly (:func:`axis_from_nosings`, ``TerrainConfig.nosing_axis``).

Layout (each module imports only those before it): ``view`` (:class:`ImageLines`, the
segments parallel to a staircase's nosings, what of a line is in view) -> ``axis`` (the
stair axis the segments show) -> ``edges`` (the
grey-level tests) -> ``next_nosing`` (the test of one nosing and its foot) -> ``splits``
(double and too-tall steps split) -> ``steps`` (:func:`nosing_steps`,
:func:`nosing_heights`) -> ``riser_ends`` (:func:`end_steps`: steps where the risers' ends
show) -> ``first_riser`` (a staircase's first riser where no riser formed a plane: its foot
and nosing as lines).
"""

from .axis import axis_from_nosings
from .first_riser import FirstRiser, first_risers, line_axes, nosings_over
from .riser_ends import end_steps
from .steps import nosing_heights, nosing_steps, nosing_under_first, pitched_steps
from .view import ImageLines

__all__ = [
    "FirstRiser",
    "ImageLines",
    "axis_from_nosings",
    "end_steps",
    "first_risers",
    "line_axes",
    "nosing_heights",
    "nosing_steps",
    "nosing_under_first",
    "nosings_over",
    "pitched_steps",
]
