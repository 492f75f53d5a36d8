"""Stage 7 (after ``terrain`` and ``swing``, before ``runtime``): one staircase over many
frames (issue 14).

Each frame's :class:`~stereo_terrain.terrain.StairModel` (yaw frame, with the 1-sigmas
of :func:`~stereo_terrain.terrain.estimate_step_sigmas`) is put into the world frame with
the body's odometry and fused into one tracked staircase:

* the risers' positions ``s_k`` along the stair axis (world frame) are one Kalman state,
  so that odometry drift, which moves all of them together, enters as a *common* process
  noise (``drift_fraction * distance travelled``) and every frame that sees some risers
  re-anchors all of them, also those that have left the view;
* each step's rise and width, the stair yaw and the ground height are fused by inverse
  variance;
* frames are associated by an index offset (a frame whose nearest riser is the track's
  second one, once the first has left the view near the stairs, is offset by one), gated
  on the positions, the rises and the yaw; a frame that matches nothing is an outlier and
  feeds a *candidate* track. The candidate replaces a confirmed track once
  ``new_track_frames`` frames supported it and fewer supported the track meanwhile (the
  stairs changed, or the track started from a bad frame). Where the frames split between
  two staircases before either is confirmed, the two are rivals: the one more frames
  supported leads (also where the leader is dropped for its misses), the other stays as
  the candidate, and the leader is confirmed only ``confirm_lead`` frames ahead of it; a
  rival that led once takes a confirmed track's place only ``confirm_lead`` + 1 frames
  ahead of it in all (else two could take turns every other frame); a track dropped for
  ``drop_after_s`` goes with its candidate;
* frames taken from nearly the same place share their errors: a frame's information is
  weighted by how far the body moved since the last fused frame
  (``decorrelation_m``), so standing still does not make the track over-confident.

State (as Spot's knowledge type): ``none``, ``tentative`` (fewer than ``confirm_frames``
supporting frames, or its first riser not yet known within ``confirm_sigma_m``),
``confirmed`` (the latest frame supported it) and ``coasting`` (it did not; dropped after
``drop_after_s`` without support). The yaw gate widens with the yaws' sigmas, so that a
track started from frames whose risers were fitted off the stair yaw (and say so) turns
toward the better frames that follow instead of rejecting them.

Layout (each module imports only those before it): ``config`` (:class:`TrackingConfig`,
the states) -> ``state`` (:class:`TrackedStaircase`, :class:`TrackedStep`) -> ``models``
(:func:`tracked_model`, :func:`single_frame_model`) -> ``track`` (the filter of one
staircase) -> ``tracker`` (:class:`StairTracker`).
"""

from .config import TRACK_COASTING, TRACK_CONFIRMED, TRACK_NONE, TRACK_STATES, TRACK_TENTATIVE, TrackingConfig
from .models import single_frame_model, tracked_model
from .state import TrackedStaircase, TrackedStep
from .tracker import StairTracker

__all__ = [
    "TRACK_COASTING",
    "TRACK_CONFIRMED",
    "TRACK_NONE",
    "TRACK_STATES",
    "TRACK_TENTATIVE",
    "StairTracker",
    "TrackedStaircase",
    "TrackedStep",
    "TrackingConfig",
    "single_frame_model",
    "tracked_model",
]
