"""Combining the planes of the orientation and contour methods (``method: auto``).

The orientation method finds horizontal and vertical planes wherever the disparity is
good; the contour method adds faces the image separates by shade (a riser whose
disparity is too sparse for the orientation method's local samples, a slanted face). The
union keeps every orientation plane and adds each contour plane that is neither the same
plane as one already kept nor mostly made of samples already explained.
"""

from __future__ import annotations

import math

import numpy as np

from .orientation import PlaneSet


def combine_plane_sets(
    base: PlaneSet,
    extra: PlaneSet,
    *,
    same_angle_deg: float = 5.0,
    same_distance_m: float = 0.03,
    max_shared_fraction: float = 0.5,
) -> tuple[PlaneSet, int]:
    """Planes of ``base`` plus the new planes of ``extra`` (both on the same samples).

    Parameters
    ----------
    base, extra : PlaneSet
        Must index the same :class:`GridSample`.
    same_angle_deg, same_distance_m : float
        An extra plane within this angle of a base plane whose points lie (median) within
        this distance of it is the same plane.
    max_shared_fraction : float
        An extra plane with more of its samples already in base planes is not new.

    Returns
    -------
    (PlaneSet with ``method == "combined"``, number of planes added from ``extra``)
    """
    if extra.samples is not base.samples:
        raise ValueError("combine_plane_sets needs two plane sets on the same GridSample")
    P = base.samples.points.astype(np.float64)
    taken = np.zeros(len(P), dtype=bool)
    for seg in base.segments:
        taken[seg.indices] = True
    cos_same = math.cos(math.radians(same_angle_deg))
    added = []
    for seg in extra.segments:
        if seg.count == 0 or taken[seg.indices].mean() > max_shared_fraction:
            continue
        pts = P[seg.indices]
        dup = any(
            abs(float(seg.plane.normal @ b.plane.normal)) >= cos_same
            and float(np.median(b.plane.residuals(pts))) < same_distance_m
            for b in base.segments
        )
        if dup:
            continue
        new = seg.indices[~taken[seg.indices]]
        added.append(type(seg)(seg.plane, seg.kind, new, seg.rms_m))
        taken[new] = True
    params = {"orientation": base.parameters, "contour": extra.parameters, "contour_planes_added": len(added)}
    stop = f"orientation: {base.stop_reason}; contour: {extra.stop_reason}; {len(added)} plane(s) added"
    combined = PlaneSet(
        base.segments + tuple(added), base.samples, base.up, stop, base.camera_position, "combined", params
    )
    return combined, len(added)
