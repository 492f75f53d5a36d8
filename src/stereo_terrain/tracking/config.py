"""The tracker's settings (:class:`TrackingConfig`) and its states."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..checks import check_fields
from ..errors import ConfigError

TRACK_NONE, TRACK_TENTATIVE, TRACK_CONFIRMED, TRACK_COASTING = "none", "tentative", "confirmed", "coasting"


TRACK_STATES = (TRACK_NONE, TRACK_TENTATIVE, TRACK_CONFIRMED, TRACK_COASTING)


@dataclass(frozen=True)
class TrackingConfig:
    """Parameters of :class:`StairTracker` (``tracking:`` in the pipeline config YAML).

    Attributes
    ----------
    enabled : bool
        Track over frames (default, ``run``/``replay``); false gives single frames.
    gate_sigmas : float
        A measured riser matches a tracked one within this many sigmas of their difference,
    min_gate_m, max_gate_m : float
        bounded by these (keep ``max_gate_m`` below half a run: risers must not swap).
    rise_gate_sigmas, min_rise_gate_m : float
        A matched step's rise is fused only within this many sigmas (at least
        ``min_rise_gate_m``) of the track's; else it is an outlier.
    yaw_gate_deg : float
        A frame whose stair yaw is further from the track's than this, and than
        ``gate_sigmas`` times the sigma of their difference, is an outlier,
    max_yaw_gate_deg : float
        but always one further than this.
    drift_fraction : float
        Odometry drift per metre travelled (1-sigma, common to all risers); at most 1.
    yaw_drift_rad_per_m : float
        Odometry heading drift per metre travelled; at most pi.
    decorrelation_m : float
        Frames taken within this travel of the last fused one count as a fraction of one
        (their errors are shared), at most ``max_inflation`` times weaker.
    max_inflation : float
    confirm_frames : int
        Supporting frames before a track is confirmed,
    confirm_sigma_m : float
        and (with odometry) its first riser's position known within this (1-sigma, the
        shared error included): a third of the swing trigger's gate (``TriggerConfig.gate_m``, 0.08 m),
        so that a correction of 3 sigma after the track is confirmed stays inside that gate
        and the trigger point follows it smoothly. Frames of a staircase seen far and
        turned (their risers fitted off its yaw, their distances with the lever of that:
        :func:`~stereo_terrain.terrain.estimate_step_sigmas`) do not confirm a track alone.
    confirm_lead : int
        and at least this many more than its rival, the candidate track (frames that
        disagreed with the track and agreed with each other): where the frames split
        between two staircases, the one most of them support is confirmed, not the one
        that reached ``confirm_frames`` first. A rival that led once takes a confirmed
        track's place with one frame more than this ahead of it.
    tentative_misses : int
        Frames in a row that do not support a tentative track before it is dropped.
    new_track_frames : int
        Supporting frames of a candidate (a different staircase) before it replaces a
        track that none of them supported.
    drop_after_s : float
        A track no frame supports for this long is dropped.
    max_steps : int
        Largest number of tracked steps.
    min_run_m : float
        A step is added to the track only this far beyond its last (or before its first).
    uniform_runs : bool
        The runs of one staircase are equal (building codes allow about 1 cm). Where a
        track's three or more risers are regular (every run within ``run_tolerance`` of
        their median), a frame's riser past the last is added only that close to one run
        from it; and of two neighbouring risers closer than ``(1 - run_tolerance)`` runs
        the one fewer frames matched is removed (one riser seen twice), never the first
        (of the first two, only a second that fewer frames matched), and neither on a
        tie. A riser before the first is never refused for its run: a first riser kept
        too far would raise the swing late. On the realistic simulated approaches
        (``bench_tracking.py --profile realistic``) frames with runs measured 30 % wrong
        are common, and one of them added steps past the top that no later frame could
        take back (a riser past the frames' reach is never counted as missed). False: no
        such check, the rule of the tracker before the thirty-second session (for stairs
        with a landing between flights, whose runs differ).
    run_tolerance : float
        In (0, 0.9]; 0.4 by default.
    min_visible_m : float
        A tracked riser nearer than this (along the stair axis) may have left the view: a
        frame that does not see it does not count against it.
    step_misses : int
        Frames in a row that should have seen a tracked riser and did not, before it is
        removed (a riser a bad frame made up); at least one more than the frames that saw
        it.
    floor_z_m : float or None
        Height of the floor the robot stands on in the body frame (minus the standing
        height; 0 for a rig off a robot, whose body origin is on the ground); None when not
        known. With single frames (``enabled: false``) a frame whose nearest riser stands
        on a level above that floor has not seen the first riser(s) (near the stairs, they
        are under the camera): its first step's distance sigma then covers them
        (:func:`single_frame_model`).
    shared_error_fraction : float
        Share of a frame's error variance that every frame of one staircase has in common
        (the same faces seen from nearly the same place: fusing frames does not reduce
        it); the tracked sigmas keep this share of the fused frames' variance (weighted as
        the fusion weighs them). On the simulated approaches
        (``benchmarks/bench_tracking.py``) the mean error of an approach's frames is
        about half their sigma, a share near 0.25.
    """

    enabled: bool = True
    gate_sigmas: float = 3.0
    min_gate_m: float = 0.06
    max_gate_m: float = 0.12
    rise_gate_sigmas: float = 3.0
    min_rise_gate_m: float = 0.02
    yaw_gate_deg: float = 8.0
    max_yaw_gate_deg: float = 20.0
    drift_fraction: float = 0.02
    yaw_drift_rad_per_m: float = 0.005
    decorrelation_m: float = 0.08
    max_inflation: float = 30.0
    confirm_frames: int = 3
    confirm_sigma_m: float = 0.03
    confirm_lead: int = 1
    tentative_misses: int = 2
    new_track_frames: int = 4
    drop_after_s: float = 2.0
    max_steps: int = 20
    shared_error_fraction: float = 0.25
    min_visible_m: float = 0.9
    min_run_m: float = 0.1
    uniform_runs: bool = True
    run_tolerance: float = 0.4
    step_misses: int = 3
    floor_z_m: float | None = None

    def __post_init__(self) -> None:
        check_fields(self)
        positive = (
            "gate_sigmas", "max_gate_m", "rise_gate_sigmas", "yaw_gate_deg", "decorrelation_m",
            "confirm_sigma_m",
        )  # fmt: skip
        for name in positive:
            if not getattr(self, name) > 0:
                raise ConfigError(f"TrackingConfig.{name} must be > 0, got {getattr(self, name)}")
        for name in (
            "min_gate_m",
            "min_rise_gate_m",
            "drift_fraction",
            "yaw_drift_rad_per_m",
            "drop_after_s",
        ):
            if getattr(self, name) < 0:
                raise ConfigError(f"TrackingConfig.{name} must be >= 0, got {getattr(self, name)}")
        if self.min_gate_m > self.max_gate_m:
            raise ConfigError("TrackingConfig needs min_gate_m <= max_gate_m")
        if self.yaw_gate_deg > self.max_yaw_gate_deg:
            raise ConfigError("TrackingConfig needs yaw_gate_deg <= max_yaw_gate_deg")
        if not 0 <= self.shared_error_fraction <= 1:
            raise ConfigError(
                f"TrackingConfig.shared_error_fraction must be in [0, 1], got {self.shared_error_fraction}"
            )
        if self.max_inflation < 1:
            raise ConfigError(f"TrackingConfig.max_inflation must be >= 1, got {self.max_inflation}")
        # Drift per metre travelled: a fraction of the distance, an angle per metre; bounds of
        # what can be meant (1e8 made the filter's covariance singular: an internal error).
        if self.drift_fraction > 1:
            raise ConfigError(
                f"TrackingConfig.drift_fraction must be <= 1 (per metre), got {self.drift_fraction}"
            )
        if self.yaw_drift_rad_per_m > math.pi:
            raise ConfigError(
                f"TrackingConfig.yaw_drift_rad_per_m must be <= pi, got {self.yaw_drift_rad_per_m}"
            )
        floor = self.floor_z_m
        if floor is not None and (
            isinstance(floor, bool) or not isinstance(floor, int | float) or not math.isfinite(floor)
        ):
            raise ConfigError(f"TrackingConfig.floor_z_m must be a finite number or null, got {floor!r}")
        if self.min_visible_m < 0 or self.min_run_m < 0:
            raise ConfigError("TrackingConfig.min_visible_m and min_run_m must be >= 0")
        if not 0 < self.run_tolerance <= 0.9:
            raise ConfigError(f"TrackingConfig.run_tolerance must be in (0, 0.9], got {self.run_tolerance}")
        for name in (
            "confirm_frames",
            "confirm_lead",
            "tentative_misses",
            "new_track_frames",
            "max_steps",
            "step_misses",
        ):
            if getattr(self, name) < 1:
                raise ConfigError(f"TrackingConfig.{name} must be >= 1, got {getattr(self, name)}")
