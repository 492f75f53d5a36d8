"""What finding "up" is asked to do and what it reports: :class:`GravityConfig`,
:class:`GravityEstimate` and :class:`GravityReport`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..checks import check_fields, check_min
from ..errors import ConfigError


@dataclass(frozen=True)
class GravityConfig:
    """How "up" is found in the scene.

    Attributes
    ----------
    prior_cone_deg : float
        Up lies within this angle of the camera's up (-y of the optical frame, or the
        rig's up when a rig is given): the weak prior "camera roughly upright".
    prior_sigma_deg : float
        Within the cone, hypotheses are weighted by a Gaussian of this width on their angle
        to the camera's up.
    family_tol_deg : float
        A sample normal within this angle of up (or of the horizontal) belongs to the
        horizontal (vertical) family when hypotheses are scored.
    refine_tol_deg : float
        Tighter tolerance of the final least-squares passes.
    hypotheses : int
        Up hypotheses drawn (half from single normals, half from pairs).
    score_points : int
        Sample normals each hypothesis is scored on.
    rig_check_hypotheses : int
        With a rig, the local normals' estimate only has to catch a rig that is off by more
        than the orientation tolerance (smaller disagreements are measured on the planes):
        this many hypotheses, scored on half the points, are enough and cost a third.
    min_support : float
        A family counts when its share of the samples is at least this many times what
        isotropic clutter would put in it (``1 - cos t`` for the horizontal family, ``sin t``
        for the vertical one, ``t = refine_tol_deg``); with no family that counts, the scene
        has no gravity to see (slopes, clutter).
    max_sigma_deg : float
        An estimate less certain than this (e.g. one vertical family and no horizontal
        surface: up is free to turn about the wall's normal) is not used.
    structure_sigma_deg : float
        Floor on the normal's uncertainty, per plane and for the result: real surfaces are
        not exactly level or plumb, and a building's floors and walls share that.
    correlation_px : float
        Disparity errors are correlated over about this many pixels (the matching block,
        the aggregation paths, the planar fill), so a plane's ``N`` inliers on a grid of
        stride ``s`` fix its normal only as well as ``N (s / correlation_px)^2``
        independent points would (at least 3); a plane's scatter is at least the depth
        noise of its points.
    plane_pieces : float
        Most independent points a plane's inliers count as, however many: the errors of a
        face's disparities are correlated over the whole face where the matcher had
        little texture (a planar or Manhattan fill, a smooth painted tread) or the lens
        model is off, so its normal is known to its scatter over its extent, divided by
        ``sqrt(plane_pieces)`` at best, not by the root of its count. On realistic
        renders, planes 5-17 deg off then no longer claim a sigma of about 1 deg
        (docs/benchmarks.md); the default profile's planes, thin in scatter, are as sure
        as before.
    rig_tolerance_deg : float
        With a rig, a scene estimate further than this from the rig's up is reported.
    min_floor_drop_m : float
        Without a rig the frame's origin goes on the floor below the camera when the floor
        (lowest large horizontal plane) is at least this far below it; else at the camera.
    levelling_tol_deg : float
        Without a rig, the frame is levelled on planes extracted with this orientation
        tolerance around the local normals' estimate (wider than the plane stage's, so that
        a start a few degrees off still finds the planes), then the plane stage runs in the
        levelled frame.
    corroborated_deg : float
        When the local normals' estimate and the floor's normal agree within this angle,
        the levelling pass is skipped (the plane stage's final correction remains).
    blocks : int
        Image blocks per side for the jackknife uncertainty of the coarse stage.
    seed : int
    """

    prior_cone_deg: float = 45.0
    prior_sigma_deg: float = 25.0
    family_tol_deg: float = 10.0
    refine_tol_deg: float = 6.0
    hypotheses: int = 300
    score_points: int = 2000
    rig_check_hypotheses: int = 100
    min_support: float = 3.0
    max_sigma_deg: float = 4.0
    structure_sigma_deg: float = 0.3
    correlation_px: float = 16.0
    plane_pieces: float = 64.0
    rig_tolerance_deg: float = 3.0
    min_floor_drop_m: float = 0.1
    levelling_tol_deg: float = 12.0
    corroborated_deg: float = 1.0
    blocks: int = 4
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 1, "hypotheses", "score_points", "rig_check_hypotheses")
        check_min(self, 2, "blocks")
        check_min(self, 0, "min_floor_drop_m")
        check_min(self, 1, "min_support")
        check_min(self, 1, "correlation_px", "plane_pieces")
        for name in (
            "prior_cone_deg",
            "prior_sigma_deg",
            "family_tol_deg",
            "refine_tol_deg",
            "levelling_tol_deg",
            "corroborated_deg",
        ):
            if not 0 < getattr(self, name) <= 60:
                raise ConfigError(f"GravityConfig.{name} must be in (0, 60] deg, got {getattr(self, name)}")
        for name in ("max_sigma_deg", "structure_sigma_deg", "rig_tolerance_deg"):
            if not 0 < getattr(self, name) <= 90:
                raise ConfigError(f"GravityConfig.{name} must be in (0, 90] deg, got {getattr(self, name)}")


@dataclass(frozen=True)
class GravityEstimate:
    """Gravity-up seen in the scene.

    Attributes
    ----------
    up : (3,) float64, unit
        Up in ``frame`` (NaN when not ``ok``).
    frame : str
    sigma_deg : float
        1-sigma angular uncertainty of ``up``, degrees (inf when unknown).
    ok : bool
        True when the scene fixes up well enough to be used (see ``reason``).
    horizontal_fraction, vertical_fraction : float
        Fractions of the scored samples (or plane inliers) in the two families.
    reason : str
    """

    up: np.ndarray = field(repr=False)
    frame: str
    sigma_deg: float
    ok: bool
    horizontal_fraction: float = 0.0
    vertical_fraction: float = 0.0
    reason: str = ""


@dataclass(frozen=True)
class GravityReport:
    """What a result says about its gravity-aligned frame.

    Attributes
    ----------
    source : str
        ``rig`` (the rig file or the state estimator), ``scene`` (the scene's plane
        families) or ``assumed-level`` (nothing in view fixes up: a level camera assumed).
    up_camera : (3,) float64
        The up used, in the rectified left camera frame.
    sigma_deg : float or None
        1-sigma of ``up_camera`` when it came from the scene.
    rig_disagreement_deg : float or None
        With a rig: angle between the rig's up and the scene's own estimate.
    note : str
    rig_check_sigma_deg : float or None
        1-sigma of the scene estimate behind ``rig_disagreement_deg``.
    rig_warning : bool
        The scene disagrees with the rig by more than ``rig_tolerance_deg``: ``note`` says
        so, and the result's top-level note repeats it.
    """

    source: str
    up_camera: np.ndarray = field(repr=False)
    sigma_deg: float | None
    rig_disagreement_deg: float | None
    note: str
    rig_check_sigma_deg: float | None = None
    rig_warning: bool = False

    def to_json_dict(self) -> dict:
        def r(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else round(float(x), 3)

        return {
            "source": self.source,
            "up_camera": [round(float(v), 5) for v in self.up_camera],
            "sigma_deg": r(self.sigma_deg),
            "rig_disagreement_deg": r(self.rig_disagreement_deg),
            "rig_check_sigma_deg": r(self.rig_check_sigma_deg),
            "note": self.note,
        }


def _failed(frame: str, reason: str, h: float = 0.0, v: float = 0.0) -> GravityEstimate:
    return GravityEstimate(np.full(3, np.nan), frame, math.inf, False, h, v, reason)
