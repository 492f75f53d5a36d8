"""What the tracker reports: the tracked staircase and its steps."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..terrain import StairModel
from .config import TRACK_COASTING, TRACK_CONFIRMED


@dataclass(frozen=True)
class TrackedStep:
    """One step of the tracked staircase.

    Attributes
    ----------
    rise_m, rise_sigma_m : float
    run_m, run_sigma_m : float or None
        From this riser to the next; None for the last step (the landing's depth is not
        tracked).
    position_m, position_sigma_m : float
        Riser along the stair axis in the world frame, from the track's anchor
        (``u . (p_world - anchor)``).
    width_m, width_sigma_m : float or None
        None until a frame saw the whole riser.
    frames : int
        Frames whose measurement of this step was fused.
    """

    rise_m: float
    rise_sigma_m: float
    run_m: float | None
    run_sigma_m: float | None
    position_m: float
    position_sigma_m: float
    width_m: float | None
    width_sigma_m: float | None
    frames: int


@dataclass(frozen=True)
class TrackedStaircase:
    """The tracked staircase after a frame (world frame) and its state.

    Attributes
    ----------
    state : str
        One of :data:`TRACK_STATES`.
    steps : tuple of TrackedStep, nearest first along the stair axis
    yaw_rad, yaw_sigma_rad : float
        Stair axis in the world frame.
    ground_z_m : float
        World height of the surface before the first step.
    landing_height_m, landing_sigma_m : float
        Top of the last step above that surface (the landing).
    frames : int
        Frames that supported the track.
    outliers : int
        Frames rejected since the track started.
    last_support_s : float
    track_id : int
        Counts the tracks started (a new staircase gets a new id).
    anchor_xy_m : (2,) float
        World (x, y) the riser positions count from (where the body's x axis met the first
        riser when the track started).
    model : StairModel or None
        The track in the current yaw frame (distances from the body now), None without a
        track.
    """

    state: str
    steps: tuple[TrackedStep, ...] = ()
    yaw_rad: float = math.nan
    yaw_sigma_rad: float = math.nan
    ground_z_m: float = math.nan
    landing_height_m: float = math.nan
    landing_sigma_m: float = math.nan
    frames: int = 0
    outliers: int = 0
    last_support_s: float = math.nan
    track_id: int = 0
    anchor_xy_m: tuple[float, float] = (0.0, 0.0)
    model: StairModel | None = field(default=None, repr=False)

    @property
    def established(self) -> bool:
        """Confirmed or coasting: the track is what to act on."""
        return self.state in (TRACK_CONFIRMED, TRACK_COASTING)
