"""The second opinions of a frame (issue 11): what decides that a pass's terrain wants
another, and the opinions that need no new matching.

:class:`~..core.Pipeline` runs a frame's passes (the first matcher; the rematch, the coarse
and focus rematches where :func:`wants_rematch` asks for them; last, the rematch and the
coarse rematch again on the pair denoised, ``PipelineConfig.rematch_denoised``) and hands
their results here:

- :func:`far_planes`: the passes' samples with the plane stage's normal tests widened by
  the far samples' noise, where no pass found an obstacle;
- :func:`corroborated_up`: without a rig, the up that most passes agree on, where all of
  them found nothing;
- :func:`agreed_lone_step`: the lone step (a box, a one-step staircase) that two
  second opinions find alike, where no pass found more;
- :func:`whole_box`: else, a box that one second opinion sees whole (its front, its top
  and the ground beyond it);
- :func:`redrawn_planes`: the last pass's samples with other seeds of the plane stage's
  random draws;
- :func:`corroborated_frame`: without a rig, an obstacle found again in the frame of the
  up the passes corroborate, where they do not corroborate the up of the pass that found
  it;
- :func:`staircase_of_lines`: last, where nothing was found and the floor is known, the
  staircase whose first riser the image's lines show (no riser formed a plane);
- :func:`staircase_of_finer_lines`: then, with a rig (whose frame's lines are found at
  half size), the same with the lines of the full-size image;
- :func:`staircase_of_ends`: last of all, the staircase its risers' ends show;
- :func:`staircase_at_floor_edge`: where even those found nothing, the staircase whose
  first riser stands where the floor the matcher holds ends;
- :func:`floor_a_step_below`: without a rig, where those found no more steps, the
  staircase found again with the floor a rise lower, where the "floor" it stands on is
  its first tread (the ends then asked again, in that frame);
- :func:`kept_staircase`: what every one of them asks of a staircase before it is kept.

The package's files, by what they hold:

- ``verdicts.py``: whether a pass wants another opinion and whether a rematch replaces
  what was kept; what a second opinion's staircase must be (its steps agree, no rise
  taller than a stair's);
- ``adopt.py``: a second opinion's find made the frame's result (its note, its steps'
  sigmas from the frame's matcher, its swing plan);
- ``replanned.py``: the planes found again in a pass's samples (the far planes, the
  redrawn planes);
- ``lone_steps.py``: the agreed lone step and the whole box;
- ``image_staircases.py``: the staircases of the image's lines, of the floor's edge and
  of the risers' ends;
- ``frames.py``: without a rig, the corroborated up and frame and the floor a step below.
"""

from __future__ import annotations

from .adopt import kept_staircase
from .frames import corroborated_frame, corroborated_up, floor_a_step_below, scene_up
from .image_staircases import (
    finer_lines_noted,
    staircase_at_floor_edge,
    staircase_of_ends,
    staircase_of_finer_lines,
    staircase_of_lines,
)
from .lone_steps import agreed_lone_step, whole_box
from .replanned import far_planes, redrawn_planes
from .verdicts import (
    COARSE_NOTE,
    DENOISED_COARSE_NOTE,
    DENOISED_NOTE,
    FOCUS_NOTE,
    REMATCH_NOTE,
    Passes,
    rematch_kept,
    stair_rises,
    steps_agree,
    steps_disagree,
    unconvincing,
    wants_rematch,
)

__all__ = [
    "COARSE_NOTE",
    "DENOISED_COARSE_NOTE",
    "DENOISED_NOTE",
    "FOCUS_NOTE",
    "Passes",
    "REMATCH_NOTE",
    "agreed_lone_step",
    "corroborated_frame",
    "corroborated_up",
    "far_planes",
    "finer_lines_noted",
    "floor_a_step_below",
    "kept_staircase",
    "redrawn_planes",
    "rematch_kept",
    "scene_up",
    "stair_rises",
    "staircase_at_floor_edge",
    "staircase_of_ends",
    "staircase_of_finer_lines",
    "staircase_of_lines",
    "steps_agree",
    "steps_disagree",
    "unconvincing",
    "wants_rematch",
    "whole_box",
]
