"""Stage 5: a polytope (stairs, box, or nothing) from unordered planes (paper section 3.3).

Input is a :class:`PlaneSet` in a gravity-aligned frame (``yaw``: z up). The vertical
planes that can be risers (short, facing the robot, all facing the same way) are ordered
by their position along the stair axis; between each consecutive pair the *active*
horizontal plane is the one with most inliers in between; neighbouring planes are
intersected to get the edges and vertices of every step.

Step height comes from the tread plane when it is visible; treads above the cameras are
not, and then the height comes from the riser's top edge.

Package layout (data flows one way, each module imports only those before it):
``model`` (:class:`TerrainConfig`, :class:`StairModel`, :class:`Step`, :class:`Polytope`) ->
``_kernels`` (compiled inner loop of the riser edges, Numba) -> ``risers`` (riser
candidates and their edges) -> ``polytope`` (box or stairs, the polytope's vertices),
``continuation`` (steps beyond the last riser plane) -> ``below`` (steps between a known
floor and a chain that starts above it, and the samples under a floor that is a first
tread), ``nosings`` (steps beyond those
whose nosings the image's line segments show), ``uniform`` (the staircase's common
rise and run), ``photometric`` (risers moved to where both rectified images of their
faces agree) -> ``assemble`` (stair-axis families, the ground, the chain of steps and the
first-step rules) -> ``build`` (:func:`build_terrain`, with the safety net for a step too tall to climb),
``from_lines`` (:func:`staircase_from_lines`: where no riser formed a plane, the staircase
of the first riser the image's lines show), ``from_ends`` (:func:`staircase_from_ends`:
the staircase its risers' ends show, where the chain counts fewer steps);
``sigmas`` (:func:`estimate_step_sigmas`) needs only ``model``.
"""

from __future__ import annotations

from .below import floor_to_view_bottom, nosing_under_floor, samples_below_floor
from .build import build_terrain
from .from_ends import staircase_from_ends
from .from_lines import staircase_from_lines
from .model import BOX, NONE, STAIRS, Polytope, RiserMove, StairModel, Step, TerrainConfig
from .nosings import ImageLines
from .photometric import StereoView
from .sigmas import estimate_step_sigmas

__all__ = [
    "BOX",
    "ImageLines",
    "NONE",
    "STAIRS",
    "Polytope",
    "RiserMove",
    "StairModel",
    "StereoView",
    "Step",
    "TerrainConfig",
    "build_terrain",
    "estimate_step_sigmas",
    "floor_to_view_bottom",
    "nosing_under_floor",
    "samples_below_floor",
    "staircase_from_ends",
    "staircase_from_lines",
]
