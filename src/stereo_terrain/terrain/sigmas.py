"""The 1-sigmas of a staircase's rise, run, distance, width and yaw (issue 14), from the
disparity noise and the plane fits: :func:`estimate_step_sigmas`."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .._numeric import median, percentile, wrap_angle  # NumPy's bits, a fraction of its time (issue 13)
from ..errors import ConfigError
from ..msac import Plane
from ..planes.orientation import PlaneSet
from .model import StairModel, Step, TerrainConfig, stair_axes

#: How much the rises (runs) of one staircase may differ (1-sigma): building codes allow
#: about a centimetre between the largest and the smallest.
_STEP_VARIATION_M = 0.004


def _median_sigma(own: list[float], values: np.ndarray) -> float:
    """1-sigma of a step's common rise or run (:mod:`.uniform`): the median of ``values``
    (n measured ones, ``own`` their sigmas) is about 1.25 sigma / sqrt(n) off, sigma the
    larger of their own and their spread; and a step's true value may differ from the
    staircase's by :data:`_STEP_VARIATION_M`. NaN with no values."""
    if len(values) == 0:
        return math.nan
    if not np.isfinite(own).any():
        return math.nan  # nothing says how well they were measured
    own_sq = float(np.nanmean(np.square(own)))
    spread_sq = float(np.var(values))
    # The median of n values: pi / 2 times the variance of their mean.
    return math.sqrt(math.pi / 2 * max(own_sq, spread_sq) / len(values) + _STEP_VARIATION_M**2)


def _disagreement(values: dict[int, float]) -> dict[int, float]:
    """Of each step's measured value (rise or run, by step index): how far it lies from
    the median of the other steps' (none where there is no other). The steps of one
    staircase are equal, so a step that disagrees with the rest was measured that far off,
    or is a different step: either way its sigma must cover it (issue 14)."""
    out: dict[int, float] = {}
    for k, value in values.items():
        others = [x for j, x in values.items() if j != k]
        if others:
            out[k] = abs(value - float(median(np.array(others))))
    return out


def _share(sigma: float, other: float) -> float:
    """The part of an error of the sum of two independent errors, 1-sigma ``sigma`` and
    ``other``, expected in the first: ``sigma**2 / (sigma**2 + other**2)`` (a half where
    either is unknown or both are zero)."""
    total = sigma * sigma + other * other
    if not math.isfinite(total) or total <= 0.0:
        return 0.5
    return sigma * sigma / total


#: A sample is on a face when its local normal is within about 30 deg of the face's.
_FACE_COS = 0.85


@dataclass(frozen=True)
class _FaceError:
    """What the samples on one face say about its uncertainty."""

    range_m: float  # median distance of its samples from the camera
    ray: np.ndarray  # (3,) unit, camera -> the samples' median
    n_eff: float  # samples, discounted for shared matching errors
    rms_m: float  # spread of the samples about the plane
    count: int
    centre: np.ndarray  # (3,) the samples' median point (where a fitted plane pivots)


def _face_error(
    P: np.ndarray, normals: np.ndarray, cam: np.ndarray, plane: Plane, mask: np.ndarray, *, n_factor: float
) -> _FaceError | None:
    """The samples on ``plane`` (within ``mask``; local normal within 30 deg of the plane's)."""
    sel = mask & (np.abs(normals @ plane.normal) > _FACE_COS)
    q = P[sel]
    if len(q) < 3:
        return None
    med = median(q, axis=0)
    rel = med - cam
    rng = float(np.linalg.norm(rel))
    if rng < 1e-6:
        return None
    res = plane.signed_distance(q)
    rms = float(np.sqrt(np.mean(res * res)))
    return _FaceError(rng, rel / rng, max(1.0, len(q) * n_factor), rms, len(q), med)


def estimate_step_sigmas(
    model: StairModel,
    planes: PlaneSet,
    *,
    focal_px: float,
    baseline_m: float,
    config: TerrainConfig | None = None,
) -> StairModel:
    """``model`` with a 1-sigma for every step's rise, run, distance and width and for the
    stair yaw, propagated from the disparity noise and the plane fits.

    Per face (riser, tread, ground), from its samples in ``planes``: a disparity error
    ``sigma_d`` moves a point at range ``r`` by ``r**2 sigma_d / (f b)`` along its ray, so
    the face moves along its normal by that times ``|ray . n|``. The shared part
    (``disparity_bias_px``) does not average out over the face; the independent part
    (``disparity_sigma_px``) and the samples' spread about the plane (its fit residual) do,
    over the effective sample count (:attr:`TerrainConfig.matching_window_px`). Added to
    that:

    * a top from the riser's top edge (its tread not seen), a riser put at a tread's front
      edge, and the riser's lateral ends are edges of the sample grid: ``edge_sigma_cells``
      grid cells at the face's range (a cell on the ground is longer by
      ``1 / |ray . z|``);
    * an inferred rise (``rise_inferred``: a first step whose foot is out of view, or a
      step found beyond the last riser plane) is the median of the measured rises: their
      spread and their own sigma;
    * the yaw: each riser's normal turns when its two ends move by their position sigma
      independently (``sqrt(2) sigma / extent``), and by its fit (spread over sqrt(n)
      and the lateral spread); the risers are combined as the stage combines them
      (weighted by inliers), and their weighted spread about the stair yaw is added (a
      riser plane fitted a few degrees off pulls the mean);
    * the distance: where the frame's x axis meets a riser plane turns with the riser's own
      yaw error about its samples' centre, by ``|c_y| / cos^2(yaw)`` per radian (a riser
      seen only off to one side, its plane turned, also meets the axis short or long);
    * what the staircase itself says: its steps are equal, so a measured rise (run) that
      does not report the common one keeps, added to its sigma, how far it lies from the
      median of the other steps' measured rises (runs); a riser's distance, the larger of
      its shares of that of the runs on either side of it (by the two risers' position
      variances). (The model above leaves out the disparity's larger errors on
      webcam-like faces, which move one face and not its neighbour: on the realistic
      renders 17% of such rises lay within 2 sigma, 69% with this, the rest mostly a
      staircase's only measured rise, which nothing checks; docs/benchmarks.md,
      "Twenty-second session".)

    Parameters
    ----------
    model : StairModel
        From :func:`build_terrain` on ``planes``.
    planes : PlaneSet
        Yaw frame (z up).
    focal_px, baseline_m : float
        Of the rectified pair (``Rectification.focal_px``, ``baseline_m``).
    config : TerrainConfig

    Returns
    -------
    StairModel
        The same model with ``rise_sigma_m``, ``run_sigma_m``, ``distance_sigma_m``,
        ``width_sigma_m`` of each step and ``yaw_sigma_rad`` set (None where the value is
        None, NaN where the samples say nothing).
    """
    config = config or TerrainConfig()
    if not (focal_px > 0 and baseline_m > 0):
        raise ConfigError(
            f"estimate_step_sigmas needs focal_px, baseline_m > 0, got {focal_px}, {baseline_m}"
        )
    if not model.steps:
        return model
    samples = planes.samples
    P = samples.points.astype(np.float64)
    normals = samples.normals.astype(np.float64)
    cam = np.asarray(planes.camera_position, dtype=np.float64)
    fb = float(focal_px * baseline_m)
    stride = float(samples.stride_px)
    n_factor = min(1.0, (stride / config.matching_window_px) ** 2)
    u, v = stair_axes(model.yaw_rad)
    s_all, v_all = P @ u, P @ v
    band = config.edge_band_m

    def random_var(face: _FaceError) -> float:
        """Variance of the face's position along its ray from what averages out over it."""
        scale = face.range_m**2 / fb
        return ((scale * config.disparity_sigma_px) ** 2 + face.rms_m**2) / face.n_eff

    def bias_m(face: _FaceError) -> float:
        """1-sigma of the face's position along its ray from the shared disparity error."""
        return face.range_m**2 / fb * config.disparity_bias_px

    def shift_sigma(face: _FaceError) -> float:
        """1-sigma of the face's position along its normal (before the projection)."""
        return math.sqrt(bias_m(face) ** 2 + random_var(face))

    def height(face: _FaceError, edge_m: float = 0.0) -> tuple[float, float]:
        """Of a face's height: the independent variance and the signed coefficient of the
        shared disparity error (a closer face moves along its ray, up or down)."""
        rz = float(face.ray[2])
        return random_var(face) * rz * rz + edge_m * edge_m, bias_m(face) * rz

    def cell_m(face: _FaceError) -> float:
        return stride * face.range_m / focal_px

    steps = list(model.steps)
    positions: list[float] = []  # 1-sigma of each riser's position along the axis
    levers: list[float] = []  # 1-sigma of the distance from the riser's own yaw error
    tops: list[tuple[float, float]] = []  # each step's top height: (independent var, bias coef)
    widths: list[float | None] = []
    yaw_info: list[tuple[float, float, float]] = []  # (weight, 1-sigma of the riser's yaw, its yaw)
    s_prev = -np.inf
    # The runs measured between risers that were found (for the steps placed a run beyond
    # the step before: terrain/nosings/).
    runs_seen: dict[int, float] = {
        k: st.own_run_m
        for k, st in enumerate(steps[:-1])
        if st.own_run_m is not None and not st.position_inferred and not steps[k + 1].position_inferred
    }
    run_spread = float(np.std(list(runs_seen.values()))) if len(runs_seen) > 1 else math.nan
    run_off = _disagreement(runs_seen)
    for i, st in enumerate(steps):
        # The riser's samples lie around the plane and position they gave, not where both
        # images moved it (terrain/photometric.py).
        s_next = steps[i + 1].sampled_position_m if i + 1 < len(steps) else np.inf
        s_pos = st.sampled_position_m
        sampled = st.sampled_riser
        on_riser = (sampled.residuals(P) < band) & (s_all > s_prev) & (s_all < s_next)
        riser = _face_error(P, normals, cam, sampled, on_riser, n_factor=n_factor)
        virtual = riser is None or riser.count < config.min_riser_points
        tread_face = None
        if st.tread is not None:
            on_tread = (st.tread.residuals(P) < band) & (s_all > s_pos - band) & (s_all < s_next + band)
            tread_face = _face_error(P, normals, cam, st.tread, on_tread, n_factor=n_factor)
        # Riser position along the stair axis.
        lever = 0.0
        # A step continued beyond the last riser plane (terrain/continuation.py): its plane
        # has the stair yaw by construction, so its samples give a position, not a yaw.
        continued = i > 0 and st.rise_inferred
        if not virtual:
            assert riser is not None
            sig_pos = shift_sigma(riser) * abs(float(riser.ray @ st.riser.normal))
            # the riser's own samples (the band also holds the tread's and the ground's
            # edges along the riser, which run on beyond a riser seen only in part)
            lat = v_all[on_riser & (np.abs(normals @ st.riser.normal) > _FACE_COS)]
            if len(lat) > 2 and not continued:
                lo, hi = percentile(lat, [2, 98])
                # the riser's own extent (its samples' band may run on along the plane)
                hi = min(hi, lo + st.width_m) if st.width_m is not None else hi
                if hi - lo > 1e-3:
                    # The riser's two ends move independently by the position sigma: the
                    # normal turns by their difference over the riser's extent; the fit
                    # itself adds its spread over sqrt(n) and the lateral spread.
                    turn = math.sqrt(2.0) * sig_pos / float(hi - lo)
                    fit = riser.rms_m / math.sqrt(riser.n_eff) / max(float(np.std(lat)), 1e-3)
                    riser_yaw = math.atan2(-st.riser.normal[1], -st.riser.normal[0])
                    sig_yaw = math.hypot(turn, fit)
                    yaw_info.append((float(riser.count), sig_yaw, riser_yaw))
                    # The plane turns about its samples' centre: where it meets the frame's
                    # x axis (y = 0), x = c_x + c_y tan(yaw), moves by c_y / cos^2(yaw) per
                    # radian (a riser seen only off to one side and turned is also short).
                    cos2 = max(math.cos(riser_yaw) ** 2, 0.04)
                    lever = abs(float(riser.centre[1])) / cos2 * sig_yaw
        elif tread_face is not None:  # at a tread's front edge: an edge on the ground grid
            ground_cell = cell_m(tread_face) / max(abs(float(tread_face.ray[2])), 0.1)
            sig_pos = math.hypot(config.edge_sigma_cells * ground_cell, shift_sigma(tread_face))
        else:
            sig_pos = math.nan
        if st.position_inferred:
            # Placed a run beyond the step before, not measured: that step's error and how
            # much a run may differ from the staircase's (NaN where either is unknown).
            # Its plane has the staircase's yaw: the step before's lever carries over.
            sig_pos = math.hypot(positions[i - 1], run_spread) if i > 0 else math.nan
            lever = levers[i - 1] if i > 0 else math.nan
        if st.riser_move is not None and not st.position_inferred:
            # Where both images put the riser, not its samples: their shared disparity
            # error (disparity_bias_px) is not in it, the fit's own spread is.
            sig_pos = st.riser_move.sigma_m
        positions.append(sig_pos)
        levers.append(lever)
        # Top of the step: the tread plane, else the riser's top edge.
        if tread_face is not None:
            tops.append(height(tread_face))
        elif riser is not None:
            tops.append(height(riser, config.edge_sigma_cells * cell_m(riser)))
        else:
            tops.append((math.nan, math.nan))
        if st.width_m is None:
            widths.append(None)
        elif riser is not None:
            # Two edges of the grid, and the inliers' shortfall at both ends (up to
            # width_loss_cells each; uniform: 1/sqrt(3) of it as a sigma).
            loss = 2.0 * config.width_loss_cells * cell_m(riser) / math.sqrt(3.0)
            widths.append(math.hypot(math.sqrt(2.0) * config.edge_sigma_cells * cell_m(riser), loss))
        else:
            widths.append(math.nan)
        s_prev = s_pos

    # The surface before the first step: the ground (the horizontal samples at its height
    # in front of the first riser).
    first_s = steps[0].sampled_position_m
    ground_plane = Plane(np.array([0.0, 0.0, 1.0]), -model.ground_z_m)
    on_ground = (ground_plane.residuals(P) < band) & (s_all < first_s)
    ground = _face_error(P, normals, cam, ground_plane, on_ground, n_factor=n_factor)
    below_first = height(ground) if ground is not None else tops[0]
    rho = config.face_bias_correlation

    def rise_sigma(top: tuple[float, float], below: tuple[float, float]) -> float:
        # The shared disparity error of two neighbouring faces is correlated (rho): it
        # moves both heights alike and largely cancels in their difference.
        (va, a), (vb, b) = top, below
        var_bias = a * a + b * b - 2.0 * rho * a * b
        return math.sqrt(va + vb + max(var_bias, 0.0))

    # Each step's own measured rise (a step reporting the staircase's common rise keeps
    # its own in measured_rise_m: terrain/uniform.py).
    rises = np.array([s.own_rise_m for s in steps])
    measured = [k for k, other in enumerate(steps) if not other.rise_inferred]
    own_each = [rise_sigma(tops[k], tops[k - 1] if k > 0 else below_first) for k in measured]
    own_of = dict(zip(measured, own_each, strict=True))
    rise_off = _disagreement({k: float(rises[k]) for k in measured})
    common = [k for k in measured if steps[k].measured_rise_m is not None]
    common_rise_sigma = _median_sigma([own_of[k] for k in common], rises[common])

    def own_run_sigma(i: int) -> float:
        nxt = positions[i + 1] if i + 1 < len(positions) else math.nan
        return math.hypot(positions[i], nxt)

    pooled_runs = [k for k, st in enumerate(steps) if st.measured_run_m is not None]
    common_run_sigma = _median_sigma(
        [own_run_sigma(k) for k in pooled_runs], np.array([steps[k].measured_run_m for k in pooled_runs])
    )
    # A run that the others disagree with: its two risers stand that far off together, each
    # its share by their own variances (the expected part of a sum of two independent
    # errors: the farther, less sure riser takes the most); a riser takes the larger of the
    # runs on either side of it. A step placed a run beyond the step before takes that one's.
    off_run: list[float] = []
    for i, st in enumerate(steps):
        if st.position_inferred:
            off_run.append(off_run[i - 1] if i > 0 else 0.0)
            continue
        beside = [
            run_off[k] * _share(positions[i], positions[i - 1 if k < i else i + 1])
            for k in (i - 1, i)
            if k in run_off
        ]
        off_run.append(max(beside, default=0.0))
    out: list[Step] = []
    for i, st in enumerate(steps):
        sig_rise = rise_sigma(tops[i], below_first if i == 0 else tops[i - 1])
        if st.measured_rise_m is not None:
            sig_rise = common_rise_sigma  # the staircase's common rise
        elif st.rise_inferred:
            # the median of the measured rises (a first step whose foot is out of view, a
            # step found beyond the last riser plane: terrain/continuation.py)
            others = rises[measured]
            spread = float(np.std(others)) if len(others) > 1 else 0.0
            finite = [x for x in own_each if math.isfinite(x)]  # a riser the lines show: NaN
            own = float(np.mean(finite)) if finite else math.nan
            # the median of n values: its own error, and how far a rise may differ from it
            sig_rise = math.sqrt(own**2 / max(len(others), 1) + spread**2 + (config.min_rise_m / 2) ** 2)
        else:  # its own measured rise, and how far the others' disagree with it
            sig_rise = math.hypot(sig_rise, rise_off.get(i, 0.0))
        n_x = abs(float(st.riser.normal[0]))
        sig_dist = math.hypot(positions[i] / max(n_x, 0.2), levers[i], off_run[i])
        sig_run = None
        if st.measured_run_m is not None:
            sig_run = common_run_sigma
        elif st.run_m is not None:
            sig_run = math.hypot(own_run_sigma(i), run_off.get(i, 0.0))
        out.append(
            dataclasses.replace(
                st,
                rise_sigma_m=float(sig_rise),
                run_sigma_m=None if sig_run is None else float(sig_run),
                distance_sigma_m=float(sig_dist),
                width_sigma_m=widths[i],
            )
        )
    if yaw_info:
        w = np.array([a for a, _, _ in yaw_info])
        w = w / w.sum()
        sig = np.array([b for _, b, _ in yaw_info])
        dev = np.array([wrap_angle(c - model.yaw_rad) for _, _, c in yaw_info])
        # The risers' own disagreement (one riser plane fitted a few degrees off pulls the
        # weighted mean): their weighted spread about the stair yaw.
        spread = float(np.sqrt(np.sum(w * dev**2)))
        yaw_sigma = math.hypot(float(np.sqrt(np.sum(w**2 * sig**2))), spread)
    else:
        yaw_sigma = math.nan
    return dataclasses.replace(model, steps=tuple(out), yaw_sigma_rad=yaw_sigma)
