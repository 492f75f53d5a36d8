"""One tracked staircase's filter: a frame's measurement in the world frame, the risers'
positions as one Kalman state with a common drift noise, association by an index offset,
and the inverse-variance fusion of rises, widths, yaw and ground (the package docstring)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .._numeric import wrap_angle
from ..odometry import Odometry
from ..terrain import StairModel
from .config import TrackingConfig
from .models import finite_or, pose_of, tracked_model
from .state import TrackedStaircase, TrackedStep

#: Risers a track needs before its runs are checked (three runs: with two, their median
#: is their mean and a wrong one passes).
MIN_RISERS = 3


@dataclass
class Measured:
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


def first_riser_point(model: StairModel, odo: Odometry | None) -> np.ndarray:
    """World (x, y) where the body's x axis meets the model's first riser."""
    xy, _, body_yaw = pose_of(odo)
    return xy + model.steps[0].distance_m * np.array([math.cos(body_yaw), math.sin(body_yaw)])


def measure(model: StairModel, odo: Odometry | None, yaw_w: float | None, anchor: np.ndarray) -> Measured:
    """``model``'s steps in the world frame: positions along the axis of ``yaw_w`` (the
    model's own when None) from the point ``anchor`` (world x, y), so that a change of the
    yaw estimate turns the risers about a point near them, not about the world origin.
    Unknown sigmas become 5 cm (rises: 2 cm), so that a model without them still fuses,
    weakly."""
    xy, z, body_yaw = pose_of(odo)
    yaw_meas = wrap_angle(model.yaw_rad + body_yaw)
    yaw = yaw_meas if yaw_w is None else yaw_w
    u = np.array([math.cos(yaw), math.sin(yaw)])
    rel = wrap_angle(yaw - body_yaw)
    base = float(u @ (xy - anchor))
    steps = model.steps
    s = np.array([base + st.distance_m * math.cos(rel) for st in steps])
    s_sig = np.array([finite_or(st.distance_sigma_m, 0.05) * abs(math.cos(rel)) for st in steps])
    rise = np.array([st.rise_m for st in steps])
    rise_sig = np.array([finite_or(st.rise_sigma_m, 0.02) for st in steps])
    width = [st.width_m for st in steps]
    width_sig = [None if st.width_m is None else finite_or(st.width_sigma_m, 0.05) for st in steps]
    ground_sigma = float(rise_sig[0]) / math.sqrt(2.0) if len(rise_sig) else 0.02
    return Measured(
        s, np.maximum(s_sig, 1e-4), rise, np.maximum(rise_sig, 1e-4), width, width_sig,
        yaw_meas, finite_or(model.yaw_sigma_rad, math.radians(3.0)), z + model.ground_z_m, ground_sigma,
    )  # fmt: skip


class Track:
    """The fused state of one staircase (world frame)."""

    def __init__(
        self, m: Measured, anchor: np.ndarray, t_s: float, xy: np.ndarray, track_id: int, cfg: TrackingConfig
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
        # and fusing does not reduce, per quantity (see SharedNoise).
        self.rise_floor = [SharedNoise(v) for v in m.rise_sigma]
        self.pos_floor = [SharedNoise(v) for v in m.s_sigma]
        self.width_floor = [None if w is None else SharedNoise(w) for w in m.width_sigma]
        self.yaw_floor = SharedNoise(m.yaw_sigma)
        self.ground, self.ground_var = m.ground_z, m.ground_sigma**2
        self.counts = np.ones(len(self.s), dtype=int)
        self.step_misses = np.zeros(len(self.s), dtype=int)
        self.hits, self.misses, self.outliers = 1, 0, 0
        self.last_support_s = t_s
        self.last_xy = xy.copy()  # body position at the last prediction
        self.fused_xy = xy.copy()  # ... and at the last fused frame
        self.track_id = track_id
        self.rival_hits = 0  # as a candidate: the track's supporting frames when it started
        self.hits_before = 0  # as a candidate: its own when it started (a track it displaced)
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

    def associate(self, m: Measured, cfg: TrackingConfig) -> tuple[int, list[tuple[int, int]]] | None:
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

    def _rise_ok(self, m: Measured, j: int, k: int, cfg: TrackingConfig) -> bool:
        S = m.rise_sigma[j] ** 2 + self.rise_var[k]
        gate = max(cfg.rise_gate_sigmas * math.sqrt(S), cfg.min_rise_gate_m)
        return abs(m.rise[j] - self.rise[k]) <= gate

    # -------------------------------------------------------------- update

    def update(
        self,
        m: Measured,
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
                self.rise[k], self.rise_var[k] = fuse(
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
                    self.width[k], self.width_var[k] = fuse(old, old_var, w, ws * ws * inflation)
                floor = self.width_floor[k]
                if floor is None:
                    self.width_floor[k] = SharedNoise(ws)
                else:
                    floor.add(ws)
        self.yaw, self.yaw_var = fuse_angle(self.yaw, self.yaw_var, m.yaw, m.yaw_sigma**2 * inflation)
        self.yaw_floor.add(m.yaw_sigma)
        for j, k in pairs:
            self.pos_floor[k].add(m.s_sigma[j])
        if offset == 0:  # the frame's ground is the track's
            self.ground, self.ground_var = fuse(
                self.ground, self.ground_var, m.ground_z, m.ground_sigma**2 * inflation
            )
        # Steps the track does not have yet, in order along the axis: past its last
        # (one run from it where the track's runs agree: _top_gap_ok), or before its
        # first (never refused for its run: a first riser kept too far raises the swing
        # late, while a made-up one before it raises it early).
        for j in range(len(m.s)):
            k = j + offset
            if k == len(self.s) < cfg.max_steps and self._top_gap_ok(m.s[j] + shift - self.s[-1], cfg):
                self._insert(len(self.s), m, j, shift)
        added = 0
        for j in range(len(m.s) - 1, -1, -1):
            if j + offset < 0 and len(self.s) < cfg.max_steps and m.s[j] + shift < self.s[0] - cfg.min_run_m:
                self._insert(0, m, j, shift)
                added += 1
        self._count_step_misses([k + added for k in ks], xy, cfg)
        if added:  # a nearer riser than the track's first: the frame's ground is before it
            self.ground, self.ground_var = m.ground_z, m.ground_sigma**2
        self._merge_close_risers(cfg)
        self.hits += 1
        self.misses = 0
        self.last_support_s = t_s
        self.fused_xy = xy.copy()

    def _regular_run(self, cfg: TrackingConfig) -> float | None:
        """The track's median run where its risers are regular: three or more, every run
        within ``run_tolerance`` of the median (TrackingConfig.uniform_runs); else None
        (too few runs, or runs that disagree: one of them came from a frame that measured
        them wrong, and the next frames must be free to correct it)."""
        if not cfg.uniform_runs or len(self.s) < MIN_RISERS:
            return None
        gaps = np.diff(self.s)
        run = float(np.median(gaps))
        return run if np.all(np.abs(gaps - run) <= cfg.run_tolerance * run) else None

    def _top_gap_ok(self, gap: float, cfg: TrackingConfig) -> bool:
        """May a riser ``gap`` past the track's last riser be added? At least
        ``min_run_m``, and within ``run_tolerance`` of the track's run where it is
        regular (:meth:`_regular_run`)."""
        run = self._regular_run(cfg)
        return gap > cfg.min_run_m and (run is None or abs(gap - run) <= cfg.run_tolerance * run)

    def _merge_close_risers(self, cfg: TrackingConfig) -> None:
        """Two neighbouring risers closer than ``(1 - run_tolerance)`` times the median
        run (three risers or more, ``uniform_runs``) are one riser seen twice: the one
        fewer frames matched with an agreeing rise (``counts``, which start at 1 for the
        frame that added the riser) is removed; but of the first two only the second, and
        only when fewer frames matched it (a first riser dropped for the second is
        published a run too far, and the swing raised late). Where the closest pair have
        the same count nothing says which is the riser, and both stay."""
        while cfg.uniform_runs and len(self.s) >= MIN_RISERS:
            gaps = np.diff(self.s)
            i = int(np.argmin(gaps))
            if (
                gaps[i] >= (1.0 - cfg.run_tolerance) * float(np.median(gaps))
                or self.counts[i] == self.counts[i + 1]
            ):
                return
            if i == 0 and self.counts[1] > self.counts[0]:
                return  # the second is the better seen: misses must take a made-up first riser
            self._remove(i if i > 0 and self.counts[i] < self.counts[i + 1] else i + 1)

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

    def _insert(self, at: int, m: Measured, j: int, shift: float) -> None:
        n = len(self.x)  # risers and the drift rate
        P = np.zeros((n + 1, n + 1))
        keep = [i for i in range(n + 1) if i != at]
        P[np.ix_(keep, keep)] = self.P
        P[at, at] = m.s_sigma[j] ** 2 + float(np.min(np.diag(self.P)[:-1]))
        self.P = P
        self.x = np.insert(self.x, at, m.s[j] + shift)
        self.rise = np.insert(self.rise, at, m.rise[j])
        self.rise_var = np.insert(self.rise_var, at, m.rise_sigma[j] ** 2)
        self.rise_floor.insert(at, SharedNoise(m.rise_sigma[j]))
        self.pos_floor.insert(at, SharedNoise(m.s_sigma[j]))
        self.width.insert(at, m.width[j])
        ws = m.width_sigma[j]
        self.width_var.insert(at, None if ws is None else ws * ws)
        self.width_floor.insert(at, None if ws is None else SharedNoise(ws))
        self.counts = np.insert(self.counts, at, 1)
        self.step_misses = np.insert(self.step_misses, at, 0)

    def stale(self, t_s: float, cfg: TrackingConfig) -> bool:
        """No frame supported it for longer than ``drop_after_s`` before ``t_s``."""
        return t_s - self.last_support_s > cfg.drop_after_s

    def first_sigma(self, cfg: TrackingConfig) -> float:
        """1-sigma of the first riser's position, the shared error included."""
        return math.sqrt(max(self.P[0, 0], 0.0) + cfg.shared_error_fraction * self.pos_floor[0].var)

    def check_confirmed(self, cfg: TrackingConfig, have_odometry: bool, rival_hits: int = 0) -> bool:
        """Confirm (once) when enough frames supported it, ``confirm_lead`` more than its
        rival (the candidate: ``rival_hits`` frames supported it), and its first riser is
        known. Without odometry every frame counts as taken where the last one was (its
        errors shared, ``max_inflation``) and the track follows the frames: the supporting
        frames alone confirm it."""
        if not self.confirmed and self.hits >= max(cfg.confirm_frames, rival_hits + cfg.confirm_lead):
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


class SharedNoise:
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


def fuse(x: float, var: float, z: float, z_var: float) -> tuple[float, float]:
    """Inverse-variance fusion of two scalars."""
    k = var / (var + z_var)
    return float(x + k * (z - x)), float((1.0 - k) * var)


def fuse_angle(x: float, var: float, z: float, z_var: float) -> tuple[float, float]:
    k = var / (var + z_var)
    return wrap_angle(x + k * wrap_angle(z - x)), float((1.0 - k) * var)
