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
  feeds a *candidate* track, which replaces the track when it is confirmed while the track
  is not supported (the stairs changed);
* frames taken from nearly the same place share their errors: a frame's information is
  weighted by how far the body moved since the last fused frame
  (``decorrelation_m``), so standing still does not make the track over-confident.

State (as Spot's knowledge type): ``none``, ``tentative`` (fewer than ``confirm_frames``
supporting frames, or its first riser not yet known within ``confirm_sigma_m``),
``confirmed`` (the latest frame supported it) and ``coasting`` (it did not; dropped after
``drop_after_s`` without support). The yaw gate widens with the yaws' sigmas, so that a
track started from frames whose risers were fitted off the stair yaw (and say so) turns
toward the better frames that follow instead of rejecting them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ._numeric import wrap_angle
from .checks import check_fields
from .errors import ConfigError, InputError
from .msac import Plane
from .odometry import Odometry, usable_odometry
from .terrain import NONE, STAIRS, Polytope, StairModel, Step

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
        Odometry drift per metre travelled (1-sigma, common to all risers).
    yaw_drift_rad_per_m : float
        Odometry heading drift per metre travelled.
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
    tentative_misses: int = 2
    new_track_frames: int = 4
    drop_after_s: float = 2.0
    max_steps: int = 20
    shared_error_fraction: float = 0.25
    min_visible_m: float = 0.9
    min_run_m: float = 0.1
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
        floor = self.floor_z_m
        if floor is not None and (
            isinstance(floor, bool) or not isinstance(floor, int | float) or not math.isfinite(floor)
        ):
            raise ConfigError(f"TrackingConfig.floor_z_m must be a finite number or null, got {floor!r}")
        if self.min_visible_m < 0 or self.min_run_m < 0:
            raise ConfigError("TrackingConfig.min_visible_m and min_run_m must be >= 0")
        for name in ("confirm_frames", "tentative_misses", "new_track_frames", "max_steps", "step_misses"):
            if getattr(self, name) < 1:
                raise ConfigError(f"TrackingConfig.{name} must be >= 1, got {getattr(self, name)}")


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


def _pose(odo: Odometry | None) -> tuple[np.ndarray, float, float]:
    """(xy, z, yaw) of the body in the world frame; the origin without odometry."""
    if odo is None:
        return np.zeros(2), 0.0, 0.0
    p = odo.position_m
    return np.array([float(p[0]), float(p[1])]), float(p[2]), float(odo.yaw_rad)


def _finite(x: float | None, default: float) -> float:
    return default if x is None or not math.isfinite(x) else float(x)


@dataclass
class _Measured:
    """A frame's model in the world frame."""

    s: np.ndarray  # (m,) riser positions along the track's axis
    s_sigma: np.ndarray
    rise: np.ndarray
    rise_sigma: np.ndarray
    width: list[float | None]
    width_sigma: list[float | None]
    yaw: float
    yaw_sigma: float
    ground_z: float
    ground_sigma: float


def _first_riser_point(model: StairModel, odo: Odometry | None) -> np.ndarray:
    """World (x, y) where the body's x axis meets the model's first riser."""
    xy, _, body_yaw = _pose(odo)
    return xy + model.steps[0].distance_m * np.array([math.cos(body_yaw), math.sin(body_yaw)])


def _measure(model: StairModel, odo: Odometry | None, yaw_w: float | None, anchor: np.ndarray) -> _Measured:
    """``model``'s steps in the world frame: positions along the axis of ``yaw_w`` (the
    model's own when None) from the point ``anchor`` (world x, y), so that a change of the
    yaw estimate turns the risers about a point near them, not about the world origin.
    Unknown sigmas become 5 cm (rises: 2 cm), so that a model without them still fuses,
    weakly."""
    xy, z, body_yaw = _pose(odo)
    yaw_meas = wrap_angle(model.yaw_rad + body_yaw)
    yaw = yaw_meas if yaw_w is None else yaw_w
    u = np.array([math.cos(yaw), math.sin(yaw)])
    rel = wrap_angle(yaw - body_yaw)
    base = float(u @ (xy - anchor))
    steps = model.steps
    s = np.array([base + st.distance_m * math.cos(rel) for st in steps])
    s_sig = np.array([_finite(st.distance_sigma_m, 0.05) * abs(math.cos(rel)) for st in steps])
    rise = np.array([st.rise_m for st in steps])
    rise_sig = np.array([_finite(st.rise_sigma_m, 0.02) for st in steps])
    width = [st.width_m for st in steps]
    width_sig = [None if st.width_m is None else _finite(st.width_sigma_m, 0.05) for st in steps]
    ground_sigma = float(rise_sig[0]) / math.sqrt(2.0) if len(rise_sig) else 0.02
    return _Measured(
        s, np.maximum(s_sig, 1e-4), rise, np.maximum(rise_sig, 1e-4), width, width_sig,
        yaw_meas, _finite(model.yaw_sigma_rad, math.radians(3.0)), z + model.ground_z_m, ground_sigma,
    )  # fmt: skip


class _Track:
    """The fused state of one staircase (world frame)."""

    def __init__(
        self, m: _Measured, anchor: np.ndarray, t_s: float, xy: np.ndarray, track_id: int, cfg: TrackingConfig
    ) -> None:
        self.anchor = anchor  # world (x, y) the riser positions are measured from
        # State: the risers' positions and, last, the odometry's drift rate (metres of
        # apparent riser motion per metre travelled: a scale error of the odometry).
        n = len(m.s)
        self.x = np.append(m.s, 0.0)
        self.P = np.zeros((n + 1, n + 1))
        self.P[:n, :n] = np.diag(m.s_sigma**2)
        self.P[n, n] = cfg.drift_fraction**2 + 1e-8
        self.rise = m.rise.copy()
        self.rise_var = m.rise_sigma**2
        self.width = [w for w in m.width]
        self.width_var = [None if w is None else w * w for w in m.width_sigma]
        self.yaw, self.yaw_var = m.yaw, m.yaw_sigma**2
        # The error a share of which (``shared_error_fraction``) every frame has in common
        # and fusing does not reduce, per quantity (see _Shared).
        self.rise_floor = [_Shared(v) for v in m.rise_sigma]
        self.pos_floor = [_Shared(v) for v in m.s_sigma]
        self.width_floor = [None if w is None else _Shared(w) for w in m.width_sigma]
        self.yaw_floor = _Shared(m.yaw_sigma)
        self.ground, self.ground_var = m.ground_z, m.ground_sigma**2
        self.counts = np.ones(len(self.s), dtype=int)
        self.step_misses = np.zeros(len(self.s), dtype=int)
        self.hits, self.misses, self.outliers = 1, 0, 0
        self.last_support_s = t_s
        self.last_xy = xy.copy()  # body position at the last prediction
        self.fused_xy = xy.copy()  # ... and at the last fused frame
        self.track_id = track_id
        self.rival_hits = 0  # as a candidate: the track's supporting frames when it started
        self.confirmed = False  # latched (see TrackingConfig.confirm_sigma_m)

    # -------------------------------------------------------------- prediction

    @property
    def s(self) -> np.ndarray:
        """Riser positions along the stair axis (world frame)."""
        return self.x[:-1]

    def predict(self, xy: np.ndarray, cfg: TrackingConfig, have_odometry: bool) -> None:
        """Odometry drift since the last prediction: every riser moves by the drift rate
        times the distance travelled (one common shift), plus what the rate does not
        explain (a quarter of ``drift_fraction``) and a slow change of the rate."""
        travel = float(np.linalg.norm(xy - self.last_xy))
        n = len(self.s)
        F = np.eye(n + 1)
        F[:n, n] = travel
        self.x = F @ self.x
        self.P = F @ self.P @ F.T
        q = 0.25 * cfg.drift_fraction * travel + 1e-4 if have_odometry else cfg.max_gate_m
        self.P[:n, :n] += q * q
        self.P[n, n] += (0.2 * cfg.drift_fraction) ** 2 * travel
        self.yaw_var += (cfg.yaw_drift_rad_per_m * travel) ** 2
        self.last_xy = xy.copy()

    # -------------------------------------------------------------- association

    def associate(self, m: _Measured, cfg: TrackingConfig) -> tuple[int, list[tuple[int, int]]] | None:
        """Best index offset ``o`` (measured step ``j`` is tracked step ``j + o``) and its
        matched pairs; None when no riser matches (an outlier frame)."""
        n, k_max = len(self.s), len(m.s)
        yaw_gate = cfg.gate_sigmas * math.sqrt(self.yaw_var + m.yaw_sigma**2)
        yaw_gate = min(max(yaw_gate, math.radians(cfg.yaw_gate_deg)), math.radians(cfg.max_yaw_gate_deg))
        if abs(wrap_angle(m.yaw - self.yaw)) > yaw_gate:
            return None
        best: tuple[int, float, int, list[tuple[int, int]]] | None = None
        for o in range(-(k_max - 1), n):
            pairs, cost, bad_rises = [], 0.0, 0
            for j in range(k_max):
                k = j + o
                if not 0 <= k < n:
                    continue
                e = m.s[j] - self.s[k]
                S = m.s_sigma[j] ** 2 + self.P[k, k]
                gate = min(max(cfg.gate_sigmas * math.sqrt(S), cfg.min_gate_m), cfg.max_gate_m)
                if abs(e) < gate:
                    pairs.append((j, k))
                    cost += e * e / S
                    if not self._rise_ok(m, j, k, cfg):
                        bad_rises += 1
            if not pairs or 2 * bad_rises > len(pairs):
                continue
            key = (len(pairs), -cost)
            if best is None or key > (best[2], -best[1]):
                best = (o, cost, len(pairs), pairs)
        return None if best is None else (best[0], best[3])

    def _rise_ok(self, m: _Measured, j: int, k: int, cfg: TrackingConfig) -> bool:
        S = m.rise_sigma[j] ** 2 + self.rise_var[k]
        gate = max(cfg.rise_gate_sigmas * math.sqrt(S), cfg.min_rise_gate_m)
        return abs(m.rise[j] - self.rise[k]) <= gate

    # -------------------------------------------------------------- update

    def update(
        self,
        m: _Measured,
        offset: int,
        pairs: list[tuple[int, int]],
        xy: np.ndarray,
        t_s: float,
        cfg: TrackingConfig,
    ) -> None:
        """Fuse the matched steps; steps beyond the track's ends are added."""
        travel = float(np.linalg.norm(xy - self.fused_xy))
        inflation = min(max(cfg.decorrelation_m / max(travel, 1e-6), 1.0), cfg.max_inflation)
        # Riser positions: one Kalman update over every matched riser.
        js = [j for j, _ in pairs]
        ks = [k for _, k in pairs]
        H = np.zeros((len(pairs), len(self.x)))
        H[np.arange(len(pairs)), ks] = 1.0
        R = np.diag(m.s_sigma[js] ** 2 * inflation)
        S = H @ self.P @ H.T + R
        K = self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ (m.s[js] - self.s[ks])
        IKH = np.eye(len(self.x)) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T  # Joseph form: stays symmetric positive
        self.P = 0.5 * (self.P + self.P.T)
        shift = float(np.mean(self.s[ks] - m.s[js]))  # the frame's offset from the track
        for j, k in pairs:
            if self._rise_ok(m, j, k, cfg):
                self.rise[k], self.rise_var[k] = _fuse(
                    self.rise[k], self.rise_var[k], m.rise[j], m.rise_sigma[j] ** 2 * inflation
                )
                self.rise_floor[k].add(m.rise_sigma[j])
                self.counts[k] += 1
            w, ws = m.width[j], m.width_sigma[j]
            if w is not None and ws is not None:
                old, old_var = self.width[k], self.width_var[k]
                if old is None or old_var is None:
                    self.width[k], self.width_var[k] = w, ws * ws
                else:
                    self.width[k], self.width_var[k] = _fuse(old, old_var, w, ws * ws * inflation)
                floor = self.width_floor[k]
                if floor is None:
                    self.width_floor[k] = _Shared(ws)
                else:
                    floor.add(ws)
        self.yaw, self.yaw_var = _fuse_angle(self.yaw, self.yaw_var, m.yaw, m.yaw_sigma**2 * inflation)
        self.yaw_floor.add(m.yaw_sigma)
        for j, k in pairs:
            self.pos_floor[k].add(m.s_sigma[j])
        if offset == 0:  # the frame's ground is the track's
            self.ground, self.ground_var = _fuse(
                self.ground, self.ground_var, m.ground_z, m.ground_sigma**2 * inflation
            )
        # Steps the track does not have yet: after its last, or before its first.
        # (in order along the axis, a run apart at least)
        for j in range(len(m.s)):
            k = j + offset
            if k == len(self.s) < cfg.max_steps and m.s[j] + shift > self.s[-1] + cfg.min_run_m:
                self._insert(len(self.s), m, j, shift)
        added = 0
        for j in range(len(m.s) - 1, -1, -1):
            if j + offset < 0 and len(self.s) < cfg.max_steps and m.s[j] + shift < self.s[0] - cfg.min_run_m:
                self._insert(0, m, j, shift)
                added += 1
        self._count_step_misses([k + added for k in ks], xy, cfg)
        if offset < 0:  # a nearer riser than the track's first: the frame's ground is before it
            self.ground, self.ground_var = m.ground_z, m.ground_sigma**2
        self.hits += 1
        self.misses = 0
        self.last_support_s = t_s
        self.fused_xy = xy.copy()

    def _count_step_misses(self, ks: list[int], xy: np.ndarray, cfg: TrackingConfig) -> None:
        """A tracked riser that a frame should have seen and did not (between two it
        matched, or nearer than those and still far enough to be in view) is missed; one
        missed ``step_misses`` frames in a row, and more often than frames saw it, was
        never there (a bad frame made it up) and is removed."""
        lo, hi = min(ks), max(ks)
        u = np.array([math.cos(self.yaw), math.sin(self.yaw)])
        here = float(u @ (xy - self.anchor))
        for k in range(len(self.s)):
            if k in ks:
                self.step_misses[k] = 0
            elif lo < k < hi or (k < lo and self.s[k] - here > cfg.min_visible_m):
                self.step_misses[k] += 1
        gone = [
            k for k in range(len(self.s)) if self.step_misses[k] >= max(cfg.step_misses, self.counts[k] + 1)
        ]
        for k in reversed(gone):
            if len(self.s) > 1:
                self._remove(k)

    def _remove(self, k: int) -> None:
        keep = [i for i in range(len(self.x)) if i != k]
        self.x = self.x[keep]
        self.P = self.P[np.ix_(keep, keep)]
        if k == 0:  # the ground before the first step was the removed riser's: re-learn it
            self.ground_var = max(self.ground_var, 1.0)
        for name in ("rise", "rise_var", "counts", "step_misses"):
            setattr(self, name, np.delete(getattr(self, name), k))
        for name in ("width", "width_var", "width_floor", "rise_floor", "pos_floor"):
            getattr(self, name).pop(k)

    def _insert(self, at: int, m: _Measured, j: int, shift: float) -> None:
        n = len(self.x)  # risers and the drift rate
        P = np.zeros((n + 1, n + 1))
        keep = [i for i in range(n + 1) if i != at]
        P[np.ix_(keep, keep)] = self.P
        P[at, at] = m.s_sigma[j] ** 2 + float(np.min(np.diag(self.P)[:-1]))
        self.P = P
        self.x = np.insert(self.x, at, m.s[j] + shift)
        self.rise = np.insert(self.rise, at, m.rise[j])
        self.rise_var = np.insert(self.rise_var, at, m.rise_sigma[j] ** 2)
        self.rise_floor.insert(at, _Shared(m.rise_sigma[j]))
        self.pos_floor.insert(at, _Shared(m.s_sigma[j]))
        self.width.insert(at, m.width[j])
        ws = m.width_sigma[j]
        self.width_var.insert(at, None if ws is None else ws * ws)
        self.width_floor.insert(at, None if ws is None else _Shared(ws))
        self.counts = np.insert(self.counts, at, 1)
        self.step_misses = np.insert(self.step_misses, at, 0)

    def first_sigma(self, cfg: TrackingConfig) -> float:
        """1-sigma of the first riser's position, the shared error included."""
        return math.sqrt(max(self.P[0, 0], 0.0) + cfg.shared_error_fraction * self.pos_floor[0].var)

    def check_confirmed(self, cfg: TrackingConfig, have_odometry: bool) -> bool:
        """Confirm (once) when enough frames supported it and its first riser is known.
        Without odometry every frame counts as taken where the last one was (its errors
        shared, ``max_inflation``) and the track follows the frames: the supporting frames
        alone confirm it."""
        if not self.confirmed and self.hits >= cfg.confirm_frames:
            self.confirmed = not have_odometry or self.first_sigma(cfg) <= cfg.confirm_sigma_m
        return self.confirmed

    # -------------------------------------------------------------- output

    def summary(self, state: str, odo: Odometry | None, cfg: TrackingConfig) -> TrackedStaircase:
        c = cfg.shared_error_fraction
        steps = []
        n = len(self.s)
        rise_var = self.rise_var + c * np.array([f.var for f in self.rise_floor])
        pos_floor = [f.var for f in self.pos_floor]
        for k in range(n):
            run = run_sigma = None
            if k + 1 < n:
                run = float(self.s[k + 1] - self.s[k])
                var = self.P[k, k] + self.P[k + 1, k + 1] - 2.0 * self.P[k, k + 1]
                run_sigma = math.sqrt(max(var, 0.0) + c * (pos_floor[k] + pos_floor[k + 1]))
            w, wv, wf = self.width[k], self.width_var[k], self.width_floor[k]
            width_sigma = None if wv is None else math.sqrt(wv + c * (0.0 if wf is None else wf.var))
            steps.append(
                TrackedStep(
                    float(self.rise[k]), math.sqrt(rise_var[k]), run, run_sigma,
                    float(self.s[k]), math.sqrt(max(self.P[k, k], 0.0) + c * pos_floor[k]),
                    None if w is None else float(w), width_sigma, int(self.counts[k]),
                )
            )  # fmt: skip
        tracked = TrackedStaircase(
            state=state,
            steps=tuple(steps),
            yaw_rad=float(self.yaw),
            yaw_sigma_rad=math.sqrt(self.yaw_var + c * self.yaw_floor.var),
            ground_z_m=float(self.ground),
            landing_height_m=float(np.sum(self.rise)),
            landing_sigma_m=math.sqrt(float(np.sum(rise_var))),
            frames=self.hits,
            outliers=self.outliers,
            last_support_s=self.last_support_s,
            track_id=self.track_id,
            anchor_xy_m=(float(self.anchor[0]), float(self.anchor[1])),
        )
        return dataclasses.replace(tracked, model=tracked_model(tracked, odo))


class _Shared:
    """The part of the frames' errors they all share, as fusion weighs them: with weights
    ``1 / sigma_i**2``, a fully shared error of ``sigma_i`` in each frame gives the fused
    value an error of ``sum(sigma_i / sigma_i**2) / sum(1 / sigma_i**2)``."""

    __slots__ = ("_inv", "_inv2")

    def __init__(self, sigma: float) -> None:
        self._inv = self._inv2 = 0.0
        self.add(sigma)

    def add(self, sigma: float) -> None:
        sigma = max(float(sigma), 1e-9)
        self._inv += 1.0 / sigma
        self._inv2 += 1.0 / (sigma * sigma)

    @property
    def var(self) -> float:
        return (self._inv / self._inv2) ** 2


def _fuse(x: float, var: float, z: float, z_var: float) -> tuple[float, float]:
    """Inverse-variance fusion of two scalars."""
    k = var / (var + z_var)
    return float(x + k * (z - x)), float((1.0 - k) * var)


def _fuse_angle(x: float, var: float, z: float, z_var: float) -> tuple[float, float]:
    k = var / (var + z_var)
    return wrap_angle(x + k * wrap_angle(z - x)), float((1.0 - k) * var)


def tracked_model(track: TrackedStaircase, odometry: Odometry | None, frame: str = "yaw") -> StairModel:
    """The tracked staircase as a :class:`StairModel` in the body's yaw frame now: each
    riser's distance along the body x axis, its height above the body, the sigmas.

    Risers behind the body (negative distance) are kept: they have only left the view.
    """
    xy, z, body_yaw = _pose(odometry)
    rel = wrap_angle(track.yaw_rad - body_yaw)
    c = math.cos(rel)
    c_safe = c if abs(c) > 0.2 else math.copysign(0.2, c or 1.0)
    u_w = np.array([math.cos(track.yaw_rad), math.sin(track.yaw_rad)])
    base = float(u_w @ (xy - np.asarray(track.anchor_xy_m)))
    u = np.array([math.cos(rel), math.sin(rel), 0.0])
    ground = track.ground_z_m - z
    steps = []
    top = ground
    for ts in track.steps:
        top += ts.rise_m
        dist = (ts.position_m - base) / c_safe
        riser = Plane(-u, dist * c)  # vertical, facing the robot, through (dist, 0, 0)
        steps.append(
            Step(
                ts.rise_m, ts.run_m, float(dist), ts.width_m, float(top), float(dist * c), riser,
                None, False, ts.rise_sigma_m, ts.run_sigma_m, ts.position_sigma_m / abs(c_safe),
                ts.width_sigma_m,
            )
        )  # fmt: skip
    note = f"tracked ({track.state}): {len(steps)} step(s) from {track.frames} frame(s)"
    obstacle = STAIRS if steps else NONE
    return StairModel(
        obstacle, tuple(steps), rel, ground, Polytope(np.zeros((0, 3))), frame, note, track.yaw_sigma_rad
    )


def single_frame_model(model: StairModel, floor_z_m: float | None) -> StairModel:
    """A single frame's model as it is published without tracking: with the robot's floor
    height known, a frame whose surface before its nearest riser is ``k`` rises above that
    floor sees riser ``k + 1`` first (the ``k`` nearer ones have left the view under the
    camera); the first step's distance, meant as the first riser's, is then long by about
    ``k`` runs, and its sigma says so: ``hypot(sigma, k * run)`` (the runs seen, else the
    distance itself: the first riser is between the robot and the one seen).

    Parameters
    ----------
    model : StairModel
        Yaw frame, with the sigmas of :func:`~stereo_terrain.terrain.estimate_step_sigmas`.
    floor_z_m : float or None
        The robot's floor in the same frame (``TrackingConfig.floor_z_m``); None: the model
        unchanged.
    """
    if floor_z_m is None or model.obstacle != STAIRS or not model.steps:
        return model
    rise = float(np.median([st.rise_m for st in model.steps]))
    above = model.ground_z_m - floor_z_m
    if not (rise > 0 and above > 0.5 * rise):
        return model
    hidden = max(1, round(above / rise))
    runs = [st.run_m for st in model.steps if st.run_m is not None]
    first = model.steps[0]
    short = hidden * max(runs) if runs else max(first.distance_m, 0.0)
    sigma = math.hypot(_finite(first.distance_sigma_m, 0.0), short)
    first = dataclasses.replace(first, distance_sigma_m=sigma)
    return dataclasses.replace(model, steps=(first, *model.steps[1:]))


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
        self._track: _Track | None = None
        self._candidate: _Track | None = None
        self._ids = 0
        self._last = TrackedStaircase(TRACK_NONE)
        self._had_odometry = False

    @property
    def state(self) -> TrackedStaircase:
        """The latest result."""
        return self._last

    def _new(self, model: StairModel, odometry: Odometry | None, t_s: float) -> _Track:
        self._ids += 1
        anchor = _first_riser_point(model, odometry)
        xy, _, _ = _pose(odometry)
        return _Track(_measure(model, odometry, None, anchor), anchor, t_s, xy, self._ids, self.config)

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
            if track is not None and t_s - track.last_support_s > cfg.drop_after_s:
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
        xy, _, _ = _pose(odometry)
        have_odo = odometry is not None
        seen = model is not None and model.obstacle != NONE and bool(model.steps)
        track = self._track
        supported = False
        if track is not None:
            track.predict(xy, cfg, have_odo)
            if seen:
                assert model is not None
                m = _measure(model, odometry, track.yaw, track.anchor)
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
        if cand is not None and track is not None:
            if t_s - cand.last_support_s > cfg.drop_after_s:
                self._candidate = cand = None
            elif cand.hits >= cfg.new_track_frames and cand.hits > track.hits - cand.rival_hits:
                self._track, self._candidate = cand, None
                track, supported = cand, cand.last_support_s == t_s
        if track is not None:
            tentative = not track.check_confirmed(cfg, have_odo)
            if (tentative and track.misses >= cfg.tentative_misses) or (
                t_s - track.last_support_s > cfg.drop_after_s
            ):
                self._track = track = None
        if track is None:
            self._last = TrackedStaircase(TRACK_NONE)
            return self._last
        if not track.confirmed:
            state = TRACK_TENTATIVE
        else:
            state = TRACK_CONFIRMED if supported else TRACK_COASTING
        self._last = track.summary(state, odometry, cfg)
        return self._last

    def _feed_candidate(
        self, model: StairModel, odometry: Odometry | None, t_s: float, xy: np.ndarray, track_hits: int
    ) -> None:
        """An outlier frame of the track: it supports the candidate track, or starts one."""
        cfg = self.config
        cand = self._candidate
        if cand is not None:
            cand.predict(xy, cfg, odometry is not None)
            m = _measure(model, odometry, cand.yaw, cand.anchor)
            got = cand.associate(m, cfg)
            if got is not None:
                cand.update(m, got[0], got[1], xy, t_s, cfg)
                return
        self._candidate = cand = self._new(model, odometry, t_s)
        cand.rival_hits = track_hits  # the track's support when the candidate started
