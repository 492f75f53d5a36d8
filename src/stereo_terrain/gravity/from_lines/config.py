"""How the image's lines are found and used (:class:`VerticalLinesConfig`)."""

from __future__ import annotations

from dataclasses import dataclass

from ...checks import check_fields, check_min
from ...errors import ConfigError


@dataclass(frozen=True)
class VerticalLinesConfig:
    """How the vertical vanishing point is found.

    Attributes
    ----------
    enabled : bool
        Use the image's vertical lines for gravity when no rig is given (the pipeline
        combines them with the planes' estimate, see :mod:`stereo_terrain.pipeline`).
    detect_scale : float
        The segments are detected on the image resized by this factor, their ends then
        scaled back. LSD costs 16-35 ms on a 640x480 image on one core of the project's
        machine and 6-13 ms at half size, but at half size gravity from the scene is
        within 2 deg in 63% of the realistic scenes instead of 73-75%
        (docs/benchmarks.md).
    min_length_px : float
        Shortest segment used, in pixels of a 640-pixel-wide raw image (scaled with the
        raw width).
    terrain_min_length_px : float
        Shortest segment the terrain stage's vertical edges take (the risers' ends,
        :func:`stereo_terrain.terrain.nosings.view.vertical_edges`), as ``min_length_px``:
        the segments between the two lengths go to them alone (:attr:`SceneLines.short`);
        gravity, the horizontal direction and the nosings keep to ``min_length_px``. The
        end of a riser at the top of a staircase 3 m away is 20-25 px tall; the shorter
        segments for the nosings too made as many counts wrong as right without a rig
        (docs/benchmarks.md, "Forty-fifth session").
    max_tilt_deg : float
        Segments within this angle of the image's vertical are candidates.
    inlier_deg : float
        A segment supports a vanishing point when the line from its midpoint to the point
        is within this angle of it.
    hypotheses : int
        MSAC hypotheses (pairs of segments).
    min_inliers : int
        Fewest supporting segments for an estimate that counts.
    max_sigma_deg : float
        An estimate less certain than this does not count.
    structure_sigma_deg : float
        Floor of the reported sigma: real vertical edges lean by a few tenths of a degree.
    bootstrap : int
        Resamples of the inliers behind the sigma.
    seed : int
    overrule_planes : bool
        Where the planes' estimate and the lines' disagree by more than three combined
        sigmas, take the lines' (True, the default) or keep the planes' (False; see
        :func:`combine_with_lines`; the Manhattan frame of all the lines,
        :func:`~stereo_terrain.gravity.line_frame.up_from_lines_and_planes`, follows it too). On
        60 realistic rendered scenes overruling puts 75% of
        them within 2 deg (73% without); on the real scenes the lines' up is the one that
        makes their door frames and wall slats vertical (docs/benchmarks.md).
    horizontal_scale : float
        With up known from a rig, the segments behind :func:`horizontal_direction` are
        found on the image resized by this (long lines are enough for a direction; LSD at
        half size costs a fifth). Without a rig the full-size segments of the vertical
        lines are used again.
    finer_scale : float
        Where a frame's lines were found at another scale (``horizontal_scale``, with a
        rig) and it found no obstacle, the terrain stage looks once more for a staircase
        in the lines found at this scale (``pipeline.second_opinions.staircase_of_finer_lines``;
        set it to ``horizontal_scale`` to turn that off). A staircase 2-4 m ahead loses its
        nosings and risers' ends at half size (docs/benchmarks.md, "Forty-seventh
        session"); nearer ones keep more of theirs there, where the full-size segments
        break a faint line into pieces and add the floor's, so the frame keeps its own
        lines wherever it finds anything.
    horizontal_window_deg : float
        Segments whose horizontal direction is within this angle of the histogram's peak
        (modulo 90 deg) support it.
    horizontal_max_slope_deg : float
        Where :func:`horizontal_direction` is given a disparity map, a segment whose 3D
        line (from the disparity along it) rises more steeply than this is left out: the
        histogram takes every segment for the image of a horizontal line, and a long
        sloped one (a handrail, a stair's skirting or string, parallel to its pitch) points
        it somewhere. 0 = off. On the webcam-degraded real ``Staircase`` three handrail
        lines outweighed its eleven nosings (docs/benchmarks.md, twenty-eighth session).
    frame : bool
        Without a rig, where the planes do not fix up to ``frame_above_deg`` (or at all),
        fit the scene's Manhattan frame to all the segments, vertical and horizontal, with
        the planes' up as its prior (:mod:`stereo_terrain.gravity.line_frame`): a level camera near
        a staircase sees few vertical lines but many step edges. On 60 realistic rendered
        scenes, gravity within 2 deg of the truth in 93% of them instead of 75% (median
        0.88 -> 0.50 deg; 78-80% instead of 62-68% on two fresh sets of 40); the default
        profile's planes fix up to about 0.45 deg and are left alone (docs/benchmarks.md).
    frame_at_border : bool
        The frame is also fitted to the segments that run out of the view (clipped at the
        border of the valid region, :attr:`SceneLines.at_border`), not only the whole ones
        (True, the default): a staircase wider than the view, or yawed so that its
        nosings leave the image, has few whole lines (realistic 41 scene 57: 3 whole of
        10). Gravity within 2 deg without a rig on eight sets went up on four and held on
        four, the planes' worst errors (10-37 deg) mostly mended; a wooden floor's plank
        lines cut by the border misled it in two scenes (docs/benchmarks.md, thirty-sixth
        session). The other estimates keep to whole segments.
    frame_start_deg, frame_inlier_deg : float
        A segment belongs to the frame's direction whose vanishing point it points at
        within this angle: ``frame_start_deg`` at the start, narrowing to
        ``frame_inlier_deg``.
    endpoint_sigma_px : float
        1-sigma of a segment's ends across it: its angle is known to ``2 *
        endpoint_sigma_px / length`` (plus ``structure_sigma_deg``).
    frame_above_deg : float
        The frame is fitted where the planes' up is less certain than this (the lines fix
        up to about 1 deg: where the planes do better, they are kept; fitted everywhere,
        the default profile's median error goes from 0.12 to 0.16 deg). 0.55 (0.7
        before): on realistic and lab-like renders the planes' reported sigma covers
        their error within 2 sigma in only 67-83% of the scenes, and planes reporting
        0.55-0.7 deg were 2-8 deg off in several; gravity within 2 deg on eight sets
        went up on three and down on one, the median down or level on all
        (docs/benchmarks.md, thirty-sixth session).
    frame_prior_floor_deg : float
        The planes' up enters the frame as a prior at least this wide (their sigma is
        over-confident where a junk plane tilted them).
    upright_sigma_deg : float
        The upright camera's prior, with this 1-sigma: the frame's only prior where the
        planes do not fix up, and a second frame's beside the one near the planes' up
        where they leave it unsure.
    """

    enabled: bool = True
    detect_scale: float = 1.0
    min_length_px: float = 20.0
    terrain_min_length_px: float = 14.0
    max_tilt_deg: float = 30.0
    inlier_deg: float = 1.0
    hypotheses: int = 300
    min_inliers: int = 4
    max_sigma_deg: float = 2.0
    structure_sigma_deg: float = 0.3
    bootstrap: int = 30
    seed: int = 0
    overrule_planes: bool = True
    horizontal_scale: float = 0.5
    finer_scale: float = 1.0
    horizontal_window_deg: float = 4.0
    horizontal_max_slope_deg: float = 20.0
    frame: bool = True
    frame_at_border: bool = True
    frame_start_deg: float = 3.0
    frame_inlier_deg: float = 1.5
    endpoint_sigma_px: float = 1.0
    frame_above_deg: float = 0.55
    frame_prior_floor_deg: float = 1.0
    upright_sigma_deg: float = 8.0

    def __post_init__(self) -> None:
        check_fields(self)
        check_min(self, 2, "min_inliers")
        check_min(self, 1, "hypotheses", "bootstrap")
        check_min(self, 0, "structure_sigma_deg")
        if not 0 < self.max_tilt_deg < 90:
            raise ConfigError(f"max_tilt_deg must be in (0, 90), got {self.max_tilt_deg}")
        for name in ("detect_scale", "horizontal_scale", "finer_scale"):
            if not 0 < getattr(self, name) <= 1:
                raise ConfigError(f"{name} must be in (0, 1], got {getattr(self, name)}")
        if not 0 <= self.horizontal_max_slope_deg < 90:
            raise ConfigError(
                f"horizontal_max_slope_deg must be in [0, 90), got {self.horizontal_max_slope_deg}"
            )
        if not 0 < self.horizontal_window_deg < 45:
            raise ConfigError(f"horizontal_window_deg must be in (0, 45), got {self.horizontal_window_deg}")
        if not 0 < self.frame_inlier_deg <= self.frame_start_deg < 45:
            raise ConfigError(
                "need 0 < frame_inlier_deg <= frame_start_deg < 45, got "
                f"{self.frame_inlier_deg} and {self.frame_start_deg}"
            )
        if not 0 < self.terrain_min_length_px <= self.min_length_px:
            raise ConfigError(
                "need 0 < terrain_min_length_px <= min_length_px, got "
                f"{self.terrain_min_length_px} and {self.min_length_px}"
            )
        for name in (
            "min_length_px",
            "inlier_deg",
            "max_sigma_deg",
            "endpoint_sigma_px",
            "frame_above_deg",
            "frame_prior_floor_deg",
            "upright_sigma_deg",
        ):
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)}")
