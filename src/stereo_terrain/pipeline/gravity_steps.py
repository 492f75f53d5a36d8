"""The gravity steps of :meth:`Pipeline.run <stereo_terrain.pipeline.Pipeline.run>`: the
yaw frame levelled from the scene without a rig (its planes, the image's lines, their
Manhattan frame), the origin put on the floor, the rig checked against the scene, and
what the result says about gravity (:mod:`stereo_terrain.gravity` holds the estimators).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..cloud import GridSample, transform_sample
from ..frames import R_BODY_OPTICAL, Transform
from ..gravity import (
    CAMERA_UP,
    GravityConfig,
    GravityEstimate,
    GravityReport,
    angle_deg,
    combine_with_lines,
    estimate_up,
    floor_up,
    levelling,
    refine_up_from_planes,
    up_from_lines_and_planes,
    yaw_frame_from_up,
)
from ..planes.orientation import HORIZONTAL, VERTICAL, PlaneSet, extract_planes_orientation, transform_planes
from ..rectify import RectifiedPair
from .config import PipelineConfig


def _level_from_scene(
    cam_sample: GridSample, coarse: GravityEstimate, config: PipelineConfig
) -> tuple[Transform, str, GravityEstimate]:
    """``T_yaw_camera_rect``, its source and the estimate behind it, without a rig.

    Two starts: the local normals' estimate (``coarse``) and the floor's normal
    (:func:`floor_up`: a plane fitted to points, exact where normals are noisy but
    blind without a floor). From each, planes are extracted with a wide orientation
    tolerance (``gravity.levelling_tol_deg``) and their normals, fitted to many points
    each, level the frame (:func:`refine_up_from_planes`). The start whose levelled
    frame puts most samples on horizontal and vertical planes wins (Manhattan
    structure). With neither, a level camera is assumed.
    """
    cfg = config
    starts = [coarse.up] if coarse.ok else []
    floor = floor_up(cam_sample)
    if floor is not None and coarse.ok and angle_deg(floor, coarse.up) < cfg.gravity.corroborated_deg:
        # Two independent estimates (local normals, the floor's points) agree: the plane
        # stage's own tolerance covers what is left; no levelling pass needed.
        return yaw_frame_from_up(coarse.up, "camera_rect"), "scene", coarse
    if floor is not None:
        starts.append(floor)
    if not starts:
        return (
            Transform.from_rt(R_BODY_OPTICAL, np.zeros(3), "yaw", "camera_rect"),
            "assumed-level",
            coarse,
        )
    wide = dataclasses.replace(
        cfg.orientation, angle_tol_deg=max(cfg.orientation.angle_tol_deg, cfg.gravity.levelling_tol_deg)
    )
    best: tuple[int, Transform, GravityEstimate] | None = None
    for up in starts:
        T = yaw_frame_from_up(up, "camera_rect")
        planes = extract_planes_orientation(transform_sample(cam_sample, T), wide)
        fine = refine_up_from_planes(planes, cfg.gravity)
        explained = sum(s.count for s in planes.segments if s.kind in (HORIZONTAL, VERTICAL))
        if fine.ok:
            T = levelling(fine.up) @ T
            why = fine
        elif coarse.ok and up is coarse.up:
            why = coarse
        else:  # sigma unknown: a floor that no other plane confirmed
            why = GravityEstimate(up, "camera_rect", math.inf, True, reason="the floor plane alone")
        if best is None or explained > best[0]:
            best = (explained, T, why)
    assert best is not None
    return best[1], "scene", best[2]


def _rig_check(
    cam_sample: GridSample,
    fine: GravityEstimate,
    rig_up: np.ndarray | None,
    config: GravityConfig,
    orientation_tol_deg: float,
) -> GravityEstimate:
    """With a rig, the local normals' estimate of up (camera frame) that checks it, or a
    placeholder when the planes settle the check alone.

    The planes were extracted in the rig's frame: when their up (``fine``) is sure and
    within ``rig_tolerance_deg`` of the rig's, the rig is not off by more than the
    orientation tolerance (a rig that far off leaves the planes of at most one family
    within the tolerance, and one family does not fix up), so the local normals are not
    estimated (issue 13: about 2 ms a frame). :func:`_gravity_report` then reports the
    planes' estimate; before, it reported the local normals' where they put the rig more
    than the orientation tolerance away (on renders with their true rig, 13 of 120 such
    reports were false alarms of the coarse estimate). Otherwise a coarse estimate, with
    ``rig_check_hypotheses`` scored on half the points (it only has to catch a rig off by
    more than the orientation tolerance).

    That estimate looks for up within ``prior_cone_deg`` of the rig's, so it cannot see a
    rig off by more than that (an identity ``T_body_camera`` puts up along the optical
    axis: 90 deg off for a level camera, and the check said 8). Where the rig itself puts
    up further than ``prior_cone_deg`` from the camera's upright, the scene's up is also
    estimated as without a rig (the camera roughly upright), and the better fixed of the
    two (the smaller sigma) is the check: for a correct rig pitched 50-60 deg the upright
    estimate takes the risers' normals for up (2.5 deg sigma against 1.0)."""
    if fine.ok and angle_deg(fine.up, [0.0, 0.0, 1.0]) <= min(config.rig_tolerance_deg, orientation_tol_deg):
        return GravityEstimate(np.full(3, np.nan), "camera_rect", math.inf, False, reason="the planes agree")
    cheap = dataclasses.replace(
        config, hypotheses=config.rig_check_hypotheses, score_points=max(1, config.score_points // 2)
    )
    checked = estimate_up(cam_sample, cheap, prior_up=rig_up)
    if rig_up is None or angle_deg(rig_up, CAMERA_UP) <= config.prior_cone_deg:
        return checked
    upright = estimate_up(cam_sample, cheap)  # the prior of a frame without a rig
    if upright.ok and (not checked.ok or upright.sigma_deg < checked.sigma_deg):
        return upright
    return checked


def origin_on_floor(planes: PlaneSet, T: Transform, min_drop_m: float) -> tuple[PlaneSet, Transform, bool]:
    """Put the yaw frame's origin on the floor below the camera (CONVENTIONS: a rig off a
    robot has its body origin on the ground below the left camera). The floor is the lowest
    large horizontal plane (a quarter of the largest one's inliers or more) at least
    ``min_drop_m`` below the camera; with none, the origin stays at the camera. The flag
    says whether a floor was found."""
    P = planes.samples.points
    flat = [s for s in planes.segments if s.kind == HORIZONTAL]
    cam_z = float(planes.camera_position[2])
    if not flat:
        return planes, T, False
    biggest = max(s.count for s in flat)
    heights = [float(np.median(P[s.indices, 2])) for s in flat if s.count >= 0.25 * biggest]
    below = [z for z in heights if z <= cam_z - min_drop_m]
    if not below:
        return planes, T, False
    shift = Transform.from_rt(np.eye(3), [0.0, 0.0, -min(below)], "yaw", "yaw")
    return transform_planes(planes, shift), shift @ T, True


def _level_with_lines(
    T: Transform, source: str, before: GravityEstimate, lines: GravityEstimate, overrule: bool
) -> tuple[Transform, str, GravityEstimate]:
    """``T_yaw_camera_rect`` levelled again with the up of the image's vertical lines
    (:func:`combine_with_lines` of the planes' start and the lines), before the planes are
    extracted in it: where the lines fill in for a start without a sigma (or, with
    ``vanishing.overrule_planes``, overrule one that a junk plane tilted), the plane stage
    then classifies the faces in the lines' frame."""
    start_up = T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
    start = GravityEstimate(
        start_up, "camera_rect", before.sigma_deg, source == "scene", reason=before.reason
    )
    both = combine_with_lines(start, lines, overrule=overrule)
    return levelling(T.apply_vectors(both.up)) @ T, "scene", both


def _level_with_line_frame(
    fine: GravityEstimate,
    before: GravityEstimate | None,
    source: str,
    T: Transform,
    segments: np.ndarray,
    pair: RectifiedPair,
    config: PipelineConfig,
) -> GravityEstimate | None:
    """Without a rig, where the scene's up so far (the final planes', else the one that
    levelled the frame) is less certain than ``vanishing.frame_above_deg``: up from the
    Manhattan frame of all the image's line segments (:func:`up_from_lines_and_planes`),
    with that up as its prior (the camera's up where there is none), in ``fine``'s frame. None
    where the planes are sure enough or the lines do not fix up."""
    v = config.vanishing
    prior, width = None, math.inf
    if fine.ok:
        prior, width = T.inverse().apply_vectors(fine.up), fine.sigma_deg
    elif source == "scene" and before is not None and before.ok and math.isfinite(before.sigma_deg):
        prior, width = T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0])), before.sigma_deg
    if width <= v.frame_above_deg:
        return None
    found = up_from_lines_and_planes(
        segments,
        pair.rectification,
        prior,
        width,
        v,
        prior_cone_deg=config.gravity.prior_cone_deg,
        unsure_max_sigma_deg=config.gravity.max_sigma_deg,
        overrule=v.overrule_planes,
    )
    if not found.ok:
        return None
    why = f"{fine.reason}, then {found.reason}" if fine.ok else found.reason
    return dataclasses.replace(
        found,
        up=T.apply_vectors(found.up),
        frame=fine.frame,
        horizontal_fraction=fine.horizontal_fraction,
        reason=why,
    )


def _gravity_report(
    source: str,
    T: Transform,
    coarse: GravityEstimate,
    fine: GravityEstimate,
    config: GravityConfig,
    orientation_tol_deg: float,
) -> GravityReport:
    """What the result says about gravity: where it came from, how sure, and with a rig
    how far the scene's own estimate is from it (the planes' estimate when the rig is close
    enough for the planes to have been found, else the local normals').

    ``coarse`` is, with a rig, the local normals' estimate in the camera frame; without
    one, the estimate that levelled the frame (only its sigma and reason are used).
    """
    up_cam = T.inverse().apply_vectors(np.array([0.0, 0.0, 1.0]))
    if source == "rig":
        # Planes were found in the rig's frame: the fine estimate measures small
        # disagreements exactly; the coarse one (independent of the rig) the large ones.
        far = coarse.ok and angle_deg(coarse.up, up_cam) > orientation_tol_deg
        if fine.ok and not far:
            angle, sigma = angle_deg(fine.up, [0.0, 0.0, 1.0]), fine.sigma_deg
        elif coarse.ok:
            angle, sigma = angle_deg(coarse.up, up_cam), coarse.sigma_deg
        else:
            return GravityReport(source, up_cam, None, None, "the scene does not fix up: rig not checked")
        warning = angle > config.rig_tolerance_deg
        if warning:
            note = f"the scene's up is {angle:.1f} deg from the rig's (check the rig file or the IMU)"
        else:
            note = f"the scene agrees with the rig within {config.rig_tolerance_deg:g} deg"
        return GravityReport(source, up_cam, None, angle, note, sigma, warning)
    if source == "scene":
        best = fine if fine.ok else coarse
        return GravityReport(source, up_cam, best.sigma_deg, None, best.reason)
    return GravityReport(source, up_cam, None, None, coarse.reason)
