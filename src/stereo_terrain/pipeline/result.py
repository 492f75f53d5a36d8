"""What one frame produced: :class:`TerrainResult` and its JSON (the terrain result of
CONVENTIONS.md, version 1)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

from ..cloud import CloudConfig, PointCloud, disparity_to_cloud, transform_cloud
from ..frames import Transform
from ..gravity import GravityReport
from ..planes.orientation import PlaneSet
from ..rectify import RectifiedPair
from ..stereo import DisparityMap
from ..swing import SwingPlan
from ..terrain import ImageLines, StairModel

RESULT_VERSION = 1


@dataclass(frozen=True)
class TerrainResult:
    """Everything one frame produced; :meth:`to_json_dict` gives the JSON contract.

    Attributes
    ----------
    terrain : StairModel
    swing : SwingPlan
    planes : PlaneSet (yaw frame)
    disparity : DisparityMap
    cloud : PointCloud (yaw frame), computed on first access
    rectified : RectifiedPair
    T_yaw_camera_rect : Transform
    gravity_source : str
        ``rig``, ``scene`` (no rig: up from the scene's plane families) or
        ``assumed-level`` (no rig and nothing in view fixes up: a level camera is assumed).
    gravity : GravityReport
        Its uncertainty, and with a rig how far the scene's own estimate is from it.
    timing_ms : dict of stage -> milliseconds
    plane_choice : str
        Why the planes are those of ``planes.method`` (``auto`` explains its pick).
    method_requested : str
    rematched : bool
        The result is a second opinion's: the rematch's, the coarse rematch's, the focus
        rematch's or the denoised ones' (``PipelineConfig.rematch``: the first matcher
        found nothing convincing; ``rematch_focus``, ``rematch_denoised``), or the far
        planes' (``far_planes_sigmas`` and ``far_planes_wider_sigmas``: no pass found an
        obstacle), the lone step two second opinions agree on or the box one sees whole
        (``agreed_lone_step``, ``whole_box``: nor did the far planes), or the redrawn
        planes' (``redraw_planes``: nor did the far planes, or every pass found only a
        lone step or steps that disagree); ``timing_ms["rematch"]`` is there whenever the
        rematch ran, ``timing_ms["far_planes"]`` and ``timing_ms["redraw"]`` whenever
        those did (each the sum over the frame's passes), ``timing_ms["denoise"]``
        whenever the pair was denoised, ``timing_ms["lines_staircase"]`` whenever the
        staircase of the first riser the image's lines show was looked for (nothing else
        found, ``TerrainConfig.lines_first_riser``), ``timing_ms["floor_edge_staircase"]``
        whenever the one whose first riser stands where the floor ends was (nothing found
        after that either, ``TerrainConfig.floor_edge_foot``).
    floor_known, image_lines
        What the terrain stage was given besides the planes (the frame's origin is on the
        floor; the image's line segments), so that it can run again on other planes
        (``PipelineConfig.far_planes_sigmas``).
    """

    terrain: StairModel
    swing: SwingPlan
    planes: PlaneSet = field(repr=False)
    disparity: DisparityMap = field(repr=False)
    rectified: RectifiedPair = field(repr=False)
    T_yaw_camera_rect: Transform = field(repr=False)
    gravity_source: str
    timing_ms: dict[str, float]
    gravity: GravityReport | None = field(default=None, repr=False)
    cloud_config: CloudConfig = field(default_factory=CloudConfig, repr=False)
    plane_choice: str = ""
    method_requested: str = "orientation"
    rematched: bool = False
    floor_known: bool = field(default=False, repr=False)
    image_lines: ImageLines | None = field(default=None, repr=False)

    @functools.cached_property
    def cloud(self) -> PointCloud:
        """The full-resolution organized cloud in the yaw frame (computed on first use)."""
        return transform_cloud(disparity_to_cloud(self.disparity, self.cloud_config), self.T_yaw_camera_rect)

    def to_json_dict(self) -> dict[str, Any]:
        """The terrain result of CONVENTIONS.md (version 1)."""
        t = self.terrain

        def r(x: float | None, nd: int = 4) -> float | None:
            return None if x is None else round(float(x), nd)

        return {
            "version": RESULT_VERSION,
            "frame": "yaw",
            "obstacle": t.obstacle,
            "steps": [
                {
                    "rise": r(s.rise_m),
                    "run": r(s.run_m),
                    "distance": r(s.distance_m),
                    "width": r(s.width_m),
                    "rise_inferred": s.rise_inferred,
                    # issue 11: placed at the staircase's run from the step before, where
                    # the image's line segments show its nosing (terrain/nosings/)
                    "position_inferred": s.position_inferred,
                    # issue 11: the step's own rise (run) where "rise" ("run") is the
                    # staircase's common one
                    "measured_rise": r(s.measured_rise_m),
                    "measured_run": r(s.measured_run_m),
                    # issue 14: 1-sigma of each (null where the value is null or unknown)
                    "rise_sigma": _sigma(s.rise_sigma_m),
                    "run_sigma": _sigma(s.run_sigma_m),
                    "distance_sigma": _sigma(s.distance_sigma_m),
                    "width_sigma": _sigma(s.width_sigma_m),
                }
                for s in t.steps
            ],
            "yaw": r(t.yaw_rad),
            "yaw_sigma": _sigma(t.yaw_sigma_rad, 5),
            "planes": [
                {
                    "normal": [round(float(v), 5) for v in seg.plane.normal],
                    "offset": r(seg.plane.offset),
                    "kind": seg.kind,
                    "inliers": int(seg.count),
                    "rms": r(seg.rms_m, 5),
                }
                for seg in self.planes.segments
            ],
            "polytope": {
                "vertices": [[round(float(c), 4) for c in p] for p in t.polytope.vertices],
                "faces": [list(f) for f in t.polytope.faces],
            },
            "swing": {
                "height": r(self.swing.height_m),
                "trigger_distance": r(self.swing.trigger_distance_m),
                "traversable": self.swing.traversable,
            },
            "timing_ms": {k: round(v, 2) for k, v in self.timing_ms.items()},
            "gravity_source": self.gravity_source,
            "gravity": None if self.gravity is None else self.gravity.to_json_dict(),
            "note": self._note(),
            "plane_stage": {
                "method_requested": self.method_requested,
                "method_used": self.planes.method,
                "reason": self.plane_choice,
                "stop_reason": self.planes.stop_reason,
                "parameters": self.planes.parameters,
            },
        }

    def _note(self) -> str:
        """The terrain's note, and a rig the scene contradicts (why the result may be
        wrong: said up front, not only in ``gravity.note``)."""
        if self.gravity is None or not self.gravity.rig_warning:
            return self.terrain.note
        return f"{self.terrain.note}; {self.gravity.note}"


def _sigma(x: float | None, nd: int = 4) -> float | None:
    """A 1-sigma for the JSON result: None when unknown (None or NaN), never below the
    rounding."""
    if x is None or not math.isfinite(x):
        return None
    return max(round(float(x), nd), 10.0**-nd)
