"""The tracker (:class:`StairTracker`): a track, its candidate, and their states over the
frames."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import InputError
from ..odometry import Odometry, usable_odometry
from ..terrain import NONE, StairModel
from .config import TRACK_COASTING, TRACK_CONFIRMED, TRACK_NONE, TRACK_TENTATIVE, TrackingConfig
from .models import pose_of
from .state import TrackedStaircase
from .track import Track, first_riser_point, measure


class StairTracker:
    """Fuses each frame's stair model with odometry into one tracked staircase.

    Call :meth:`update` once per processed frame, with the frame's model (None or
    ``obstacle == "none"`` when it saw nothing), the body odometry of that frame (world
    frame; None without odometry: each frame is then taken where it stands and the track
    follows the latest frames) and the frame's time.

    Examples
    --------
    >>> tracker = StairTracker()
    >>> tracker.update(None, None, 0.0).state
    'none'
    """

    def __init__(self, config: TrackingConfig | None = None) -> None:
        self.config = config or TrackingConfig()
        self.reset()

    def reset(self) -> None:
        """Forget every track."""
        self._track: Track | None = None
        self._candidate: Track | None = None
        self._ids = 0
        self._last = TrackedStaircase(TRACK_NONE)
        self._had_odometry = False

    @property
    def state(self) -> TrackedStaircase:
        """The latest result."""
        return self._last

    def _new(self, model: StairModel, odometry: Odometry | None, t_s: float) -> Track:
        self._ids += 1
        anchor = first_riser_point(model, odometry)
        xy, _, _ = pose_of(odometry)
        return Track(measure(model, odometry, None, anchor), anchor, t_s, xy, self._ids, self.config)

    def update(self, model: StairModel | None, odometry: Odometry | None, t_s: float) -> TrackedStaircase:
        """Advance by one frame; returns the tracked staircase (``model`` in the body's yaw
        frame now).

        A pose with a NaN is none. Where earlier frames had poses, a frame without one
        cannot be placed in the world: the track is left as it was (dropped after
        ``drop_after_s`` without support, as always) and the result is the last one,
        coasting, without its ``model`` (the frame's own terrain is what there is to use).
        A track built on frames without poses starts again at the first pose.
        """
        if model is not None and not isinstance(model, StairModel):
            raise InputError(
                f"StairTracker.update takes a StairModel (a result's .terrain), got {type(model).__name__}"
            )
        odometry = usable_odometry(odometry)
        cfg = self.config
        if odometry is None and self._had_odometry:
            track = self._track
            if track is not None and track.stale(t_s, cfg):
                self._track = self._candidate = None  # out of touch too long, as below
                self._last = TrackedStaircase(TRACK_NONE)
                return self._last
            state = TRACK_COASTING if self._last.established else self._last.state
            self._last = dataclasses.replace(self._last, state=state, model=None)
            return self._last
        if odometry is not None and not self._had_odometry and self._track is not None:
            # Poses from now on: the track was kept where the frames stood (the world
            # origin), which the poses' frame does not share. It starts again.
            self._track = self._candidate = None
        self._had_odometry = self._had_odometry or odometry is not None
        xy, _, _ = pose_of(odometry)
        have_odo = odometry is not None
        seen = model is not None and model.obstacle != NONE and bool(model.steps)
        track = self._track
        supported = False
        if track is not None:
            track.predict(xy, cfg, have_odo)
            if seen:
                assert model is not None
                m = measure(model, odometry, track.yaw, track.anchor)
                got = track.associate(m, cfg)
                if got is not None:
                    track.update(m, got[0], got[1], xy, t_s, cfg)
                    supported = True
                else:
                    track.outliers += 1
                    self._feed_candidate(model, odometry, t_s, xy, track.hits)
            if not supported:
                track.misses += 1
        elif seen:
            assert model is not None
            self._track = track = self._new(model, odometry, t_s)
            supported = True
        # A candidate that more frames supported than the track since it started: the
        # stairs changed, or the track started from a bad frame.
        cand = self._candidate
        if cand is not None and cand.stale(t_s, cfg):
            self._candidate = cand = None
        if cand is not None and track is not None:
            since = cand.hits - cand.hits_before  # frames that supported it as the candidate
            if since >= cfg.new_track_frames and since > track.hits - cand.rival_hits:
                self._track, self._candidate = cand, None
                track, supported = cand, cand.last_support_s == t_s
            elif (
                (not track.confirmed or cand.hits_before > 0)
                and cand.last_support_s == t_s
                and cand.hits >= track.hits + cfg.confirm_lead + int(track.confirmed)
            ):
                # Two staircases the frames split between, neither confirmed (or the
                # candidate led once): the one most frames supported leads, and the other
                # stays as its rival. Against a confirmed track the rival needs one frame
                # more, or the two could take turns every other frame.
                track, supported = self._swap(), True
        if track is not None:
            stale = track.stale(t_s, cfg)
            if (
                not track.confirmed
                and not stale
                and track.misses >= cfg.tentative_misses
                and self._candidate is not None
            ):
                # A tentative track the last frames did not support: its rival, which they
                # may have supported, leads instead of both going.
                track = self._swap()
                track.misses = 0
                supported = track.last_support_s == t_s
            rival = self._candidate.hits if self._candidate is not None else 0
            tentative = not track.check_confirmed(cfg, have_odo, rival)
            if (tentative and track.misses >= cfg.tentative_misses) or stale:
                self._track = track = None
                if stale:  # out of touch too long: its candidate, fed before, goes too
                    self._candidate = None
        if track is None:
            self._last = TrackedStaircase(TRACK_NONE)
            return self._last
        if not track.confirmed:
            state = TRACK_TENTATIVE
        else:
            state = TRACK_CONFIRMED if supported else TRACK_COASTING
        self._last = track.summary(state, odometry, cfg)
        return self._last

    def _swap(self) -> Track:
        """The candidate becomes the track and the track its candidate; returns the new
        track. Under the rule by which a fresh candidate replaces a confirmed track
        (``new_track_frames``), the displaced track counts only its frames from now on
        (``hits_before``: its own until now) against the track's since (``rival_hits``:
        the track's until now); under the rivals' rule, all of its frames."""
        track, cand = self._track, self._candidate
        assert track is not None and cand is not None
        track.rival_hits, track.hits_before = cand.hits, track.hits
        self._track, self._candidate = cand, track
        return cand

    def _feed_candidate(
        self, model: StairModel, odometry: Odometry | None, t_s: float, xy: np.ndarray, track_hits: int
    ) -> None:
        """An outlier frame of the track: it supports the candidate track, or starts one."""
        cfg = self.config
        cand = self._candidate
        if cand is not None and cand.stale(t_s, cfg):
            cand = None  # out of touch too long: a new candidate, not this one revived
        if cand is not None:
            cand.predict(xy, cfg, odometry is not None)
            m = measure(model, odometry, cand.yaw, cand.anchor)
            got = cand.associate(m, cfg)
            if got is not None:
                cand.update(m, got[0], got[1], xy, t_s, cfg)
                return
        self._candidate = cand = self._new(model, odometry, t_s)
        cand.rival_hits = track_hits  # the track's support when the candidate started
