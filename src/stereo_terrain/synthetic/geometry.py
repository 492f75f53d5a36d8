"""Scene geometry: the obstacle as boxes in its local frame, and the ray caster."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from .spec import (
    SceneSpec,
    StairSpec,
    _obstacle_centre_b,
    _obstacle_far_end,
    _obstacle_lateral_span,
    _side_wall_span,
)

# Face ids of the ray caster: 0 nothing (sky), 1 ground, 2 back wall, then 6 per box:
# 3 + 6 i + k, k = 0 front (-u, riser), 1 back (+u), 2 right (-v), 3 left (+v),
# 4 bottom (-z), 5 top (+z, tread); the boxes are the obstacle's, then the side walls'.
# After the K boxes come 6 per rail part (baluster or handrail): 3 + 6 (K + j) + k, with
# k = 4, 5 the faces of its (maybe sloped) bottom and top.
_FACE_SKY, _FACE_GROUND, _FACE_WALL, _FACE_BOX0 = 0, 1, 2, 3

#: Box kinds: the obstacle's boxes (risers, treads), side walls.
_BOX_OBSTACLE, _BOX_SIDE_WALL = 0, 1

#: Thickness of a side wall, metres (only its inner face is seen from between the walls).
_SIDE_WALL_THICKNESS_M = 0.1
#: Handrail: square section, distance of its centre from a side wall, metres.
_RAIL_SECTION_M = 0.045
_RAIL_WALL_GAP_M = 0.07
#: Balusters: square section; newel post at the foot of a balustrade, metres.
_BALUSTER_SECTION_M = 0.024
_NEWEL_SECTION_M = 0.07


# --------------------------------------------------------------------------- geometry


@dataclass(frozen=True)
class _Geometry:
    """Obstacle and wall in the obstacle's local frame ``(a, b, z) = (u . p, v . p, z)``."""

    cos_yaw: float
    sin_yaw: float
    boxes: np.ndarray  # (K, 6): a_lo, a_hi, b_lo, b_hi, z_lo, z_hi
    wall_a: float | None
    # (K,) int8: _BOX_OBSTACLE or _BOX_SIDE_WALL; None: all obstacle.
    box_kind: np.ndarray | None = None
    # (M, 7): a_lo, a_hi, b_lo, b_hi, q_lo, q_hi, slope with q = z - slope * a: balusters
    # (slope 0) and sloped handrails, cast after the boxes.
    rails: np.ndarray | None = None
    # Side ("left"/"right") of each side-wall box, in order.
    wall_sides: tuple[str, ...] = ()

    @property
    def n_boxes(self) -> int:
        return int(self.boxes.shape[0])

    @property
    def n_rails(self) -> int:
        return 0 if self.rails is None else int(self.rails.shape[0])

    @property
    def n_obstacle_boxes(self) -> int:
        if self.box_kind is None:
            return self.n_boxes
        return int(np.count_nonzero(self.box_kind == _BOX_OBSTACLE))

    def to_local(self, x, y):
        return self.cos_yaw * x + self.sin_yaw * y, -self.sin_yaw * x + self.cos_yaw * y


def _scene_geometry(spec: SceneSpec) -> _Geometry:
    ob = spec.obstacle
    yaw = 0.0 if ob is None else ob.yaw_rad
    boxes = []
    if ob is not None:
        s0 = ob.distance_m * math.cos(ob.yaw_rad)
        end = _obstacle_far_end(ob)
        b_mid = _obstacle_centre_b(ob)
        b_lo, b_hi = b_mid - ob.width_m / 2, b_mid + ob.width_m / 2
        if isinstance(ob, StairSpec):
            # The staircase is the union of n boxes, box i from riser i to the far end of
            # the landing and up to tread i: the nearest hit of the union is the surface.
            for i in range(ob.n_steps):
                boxes.append([s0 + i * ob.run_m, end, b_lo, b_hi, 0.0, (i + 1) * ob.rise_m])
        else:
            boxes.append([s0, end, b_lo, b_hi, 0.0, ob.height_m])
    walls = _side_wall_boxes(spec)
    rails = _rail_parts(spec)
    if not walls and not rails:
        return _Geometry(
            math.cos(yaw), math.sin(yaw), np.array(boxes, dtype=np.float64).reshape(-1, 6), spec.back_wall_m
        )
    kinds = [_BOX_OBSTACLE] * len(boxes) + [_BOX_SIDE_WALL] * len(walls)
    return _Geometry(
        math.cos(yaw),
        math.sin(yaw),
        np.array(boxes + [w[1] for w in walls], dtype=np.float64).reshape(-1, 6),
        spec.back_wall_m,
        np.array(kinds, dtype=np.int8),
        np.array(rails, dtype=np.float64).reshape(-1, 7) if rails else None,
        tuple(w[0] for w in walls),
    )


def _side_wall_boxes(spec: SceneSpec) -> list[tuple[str, list[float]]]:
    """Side walls as (side, box) in the local frame; the inner face is the wall plane."""
    a0, a1 = _side_wall_span(spec)
    h, th = spec.side_wall_height_m, _SIDE_WALL_THICKNESS_M
    out = []
    if spec.left_wall_m is not None:
        out.append(("left", [a0, a1, spec.left_wall_m, spec.left_wall_m + th, 0.0, h]))
    if spec.right_wall_m is not None:
        out.append(("right", [a0, a1, spec.right_wall_m - th, spec.right_wall_m, 0.0, h]))
    return out


def _rail_parts(spec: SceneSpec) -> list[list[float]]:
    """Handrails (sloped along the nosing line) and balusters, rows of ``_Geometry.rails``."""
    ob = spec.obstacle
    if not isinstance(ob, StairSpec) or not spec.handrails or ob.n_steps < 2:
        return []
    s0 = ob.distance_m * math.cos(ob.yaw_rad)
    rise, run, n = ob.rise_m, ob.run_m, ob.n_steps
    slope = rise / run
    b_lo, b_hi = _obstacle_lateral_span(ob)
    q_nose = rise - slope * s0  # the nosing line: z = q_nose + slope * a
    q_top = q_nose + spec.handrail_height_m
    a_end = s0 + (n - 1) * run
    rs = _RAIL_SECTION_M
    parts = []
    for side in spec.handrails:
        wall = spec.left_wall_m if side == "left" else spec.right_wall_m
        if wall is not None:
            b_c = wall - _RAIL_WALL_GAP_M if side == "left" else wall + _RAIL_WALL_GAP_M
        else:
            b_c = b_hi - 0.04 if side == "left" else b_lo + 0.04
        parts.append([s0 - 0.05, a_end + 0.05, b_c - rs / 2, b_c + rs / 2, q_top - rs, q_top, slope])
        if wall is not None or not spec.balusters:
            continue
        hb = _BALUSTER_SECTION_M / 2
        spots = []
        for i in range(n - 1):  # treads 1..n-1 (the landing has none)
            a_i = s0 + i * run
            fractions = (0.3, 0.75) if run > 0.28 else (0.5,)
            spots += [(a_i + f * run, (i + 1) * rise) for f in fractions]
        for a_p, z_p in spots:
            z_top = q_top - rs + slope * a_p + 0.01  # into the rail
            parts.append([a_p - hb, a_p + hb, b_c - hb, b_c + hb, z_p, z_top, 0.0])
        hn = _NEWEL_SECTION_M / 2
        a_n = s0 + hn + 0.01
        parts.append([a_n - hn, a_n + hn, b_c - hn, b_c + hn, rise, q_top + slope * a_n + 0.08, 0.0])
    return parts


def _cast(
    origin: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, geom: _Geometry
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest hit of rays ``origin + t d`` (yaw frame) with the scene.

    Returns ``t`` (inf where nothing is hit; the camera depth Z when ``d`` is the
    rotated ``(x, y, 1)`` of a camera ray) and the face id (int16).
    """
    t, face = _cast_boxes(origin, dx, dy, dz, geom)
    if geom.n_rails:
        _cast_rails(origin, dx, dy, dz, geom, t, face)
    return t, face


def _cast_rails(
    origin: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    geom: _Geometry,
    t: np.ndarray,
    face: np.ndarray,
) -> None:
    """Update ``t, face`` in place with the nearer hits of the rail parts.

    A part is the intersection of three slabs (a parallelepiped): ``a``, ``b`` and
    ``q = z - slope * a`` between bounds, so a sloped handrail is one part.
    """
    rails = cast(np.ndarray, geom.rails)  # n_rails > 0
    ox, oy, oz = (float(v) for v in origin)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        da, db = geom.to_local(dx, dy)
        oa, ob = geom.to_local(ox, oy)
        z_lo = rails[:, 4] + np.minimum(rails[:, 6] * rails[:, 0], rails[:, 6] * rails[:, 1])
        z_hi = rails[:, 5] + np.maximum(rails[:, 6] * rails[:, 0], rails[:, 6] * rails[:, 1])
        bb = [
            rails[:, 0].min(),
            rails[:, 1].max(),
            rails[:, 2].min(),
            rails[:, 3].max(),
            z_lo.min(),
            z_hi.max(),
        ]
        tiny = np.float32(1e-12)

        def inv(d: np.ndarray) -> np.ndarray:
            return 1.0 / np.where(np.abs(d) < tiny, tiny, d)

        def slab(lo, hi, o, iv):
            t1 = (lo - o) * iv
            t2 = (hi - o) * iv
            return np.minimum(t1, t2), np.maximum(t1, t2), iv > 0

        inv_a, inv_b, inv_z = inv(da), inv(db), inv(dz)
        na, fa, _ = slab(bb[0], bb[1], oa, inv_a)
        nb, fb, _ = slab(bb[2], bb[3], ob, inv_b)
        nz, fz, _ = slab(bb[4], bb[5], oz, inv_z)
        tn = np.maximum(np.maximum(na, nb), nz)
        tf = np.minimum(np.minimum(fa, fb), fz)
        idx = np.nonzero((tn <= tf) & (tf > 0) & (tn < t))[0]
        if idx.size == 0:
            return
        ia, ib = inv_a[idx], inv_b[idx]
        da_s, dz_s = da[idx], dz[idx]
        t_sub = t[idx]
        f_sub = face[idx]
        base = _FACE_BOX0 + 6 * geom.n_boxes
        for j, part in enumerate(rails):
            a_lo, a_hi, b_lo, b_hi, q_lo, q_hi, slope = (float(v) for v in part)
            na, fa, pa = slab(a_lo, a_hi, oa, ia)
            nb, fb, pb = slab(b_lo, b_hi, ob, ib)
            iq = inv_z[idx] if slope == 0.0 else inv(dz_s - np.float32(slope) * da_s)
            nq, fq, pq = slab(q_lo, q_hi, oz - slope * oa, iq)
            tn = np.maximum(np.maximum(na, nb), nq)
            tf = np.minimum(np.minimum(fa, fb), fq)
            hit = (tn <= tf) & (tn > 0) & (tn < t_sub)
            if not hit.any():
                continue
            k = np.where(
                (na >= nb) & (na >= nq),
                np.where(pa, 0, 1),
                np.where(nb >= nq, np.where(pb, 2, 3), np.where(pq, 4, 5)),
            )
            t_sub = np.where(hit, tn, t_sub)
            f_sub = np.where(hit, base + 6 * j + k, f_sub).astype(np.int16)
        t[idx] = t_sub
        face[idx] = f_sub


def _cast_boxes(
    origin: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, geom: _Geometry
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest hit of rays with the ground, the back wall and the boxes.

    Returns ``t`` (inf where nothing is hit; the camera depth Z when ``d`` is the
    rotated ``(x, y, 1)`` of a camera ray) and the face id (int16).
    """
    n = dx.shape[0]
    t = np.full(n, np.inf, dtype=np.float32)
    face = np.zeros(n, dtype=np.int16)
    ox, oy, oz = (float(v) for v in origin)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        down = dz < 0
        t[down] = (-oz / dz[down]).astype(np.float32)
        face[down] = _FACE_GROUND
        if geom.wall_a is None and geom.boxes.shape[0] == 0:
            return t, face
        da, db = geom.to_local(dx, dy)
        oa, ob = geom.to_local(ox, oy)
        if geom.wall_a is not None:
            tw = (geom.wall_a - oa) / da
            m = (da > 0) & (tw < t)
            t[m] = tw[m]
            face[m] = _FACE_WALL
        if geom.boxes.shape[0] == 0:
            return t, face
        # Slab test (Kay & Kajiya) against the obstacle's bounding box first, then against
        # each box only for the rays that enter it.
        bb = np.array(
            [
                geom.boxes[:, 0].min(),
                geom.boxes[:, 1].max(),
                geom.boxes[:, 2].min(),
                geom.boxes[:, 3].max(),
                0.0,
                geom.boxes[:, 5].max(),
            ]
        )
        tiny = np.float32(1e-12)
        inv_a = 1.0 / np.where(np.abs(da) < tiny, tiny, da)
        inv_b = 1.0 / np.where(np.abs(db) < tiny, tiny, db)
        inv_z = 1.0 / np.where(np.abs(dz) < tiny, tiny, dz)

        def slab(lo, hi, o, inv):
            t1 = (lo - o) * inv
            t2 = (hi - o) * inv
            return np.minimum(t1, t2), np.maximum(t1, t2)

        na, fa = slab(bb[0], bb[1], oa, inv_a)
        nb, fb = slab(bb[2], bb[3], ob, inv_b)
        nz, fz = slab(bb[4], bb[5], oz, inv_z)
        tn = np.maximum(np.maximum(na, nb), nz)
        tf = np.minimum(np.minimum(fa, fb), fz)
        idx = np.nonzero((tn <= tf) & (tf > 0) & (tn < t))[0]
        if idx.size == 0:
            return t, face
        o_sub = (oa, ob, oz)
        inv_sub = (inv_a[idx], inv_b[idx], inv_z[idx])
        # The boxes of a staircase share their lateral slab, far end and floor: cache the
        # slab distances per (axis, bound) so each extra box costs a few operations.
        t_cache: dict[tuple[int, float], np.ndarray] = {}
        slab_cache: dict[tuple[int, float, float], tuple[np.ndarray, np.ndarray]] = {}

        def bound_t(axis: int, value: float) -> np.ndarray:
            key = (axis, float(value))
            if key not in t_cache:
                t_cache[key] = (value - o_sub[axis]) * inv_sub[axis]
            return t_cache[key]

        def box_slab(axis: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
            key = (axis, float(lo), float(hi))
            if key not in slab_cache:
                t1, t2 = bound_t(axis, lo), bound_t(axis, hi)
                slab_cache[key] = (np.minimum(t1, t2), np.maximum(t1, t2))
            return slab_cache[key]

        t_sub = t[idx]
        winner = np.full(idx.size, -1, dtype=np.int16)
        for i, box in enumerate(geom.boxes):
            na, fa = box_slab(0, box[0], box[1])
            nb, fb = box_slab(1, box[2], box[3])
            nz, fz = box_slab(2, box[4], box[5])
            tn = np.maximum(np.maximum(na, nb), nz)
            tf = np.minimum(np.minimum(fa, fb), fz)
            hit = (tn <= tf) & (tn > 0) & (tn < t_sub)
            t_sub = np.where(hit, tn, t_sub)
            winner[hit] = i
            t_cache.pop((0, float(box[0])), None)  # the next riser has its own near bound
            slab_cache.pop((0, float(box[0]), float(box[1])), None)
        # The entry face of the winning box: the axis whose near bound is the hit.
        w = np.nonzero(winner >= 0)[0]
        bi = winner[w]
        near = []
        for axis in range(3):
            inv = inv_sub[axis][w]
            t1 = (geom.boxes[bi, 2 * axis] - o_sub[axis]) * inv
            t2 = (geom.boxes[bi, 2 * axis + 1] - o_sub[axis]) * inv
            near.append((np.minimum(t1, t2), inv > 0))
        (na, pa), (nb, pb), (nz, pz) = near
        k = np.where(
            (na >= nb) & (na >= nz),
            np.where(pa, 0, 1),
            np.where(nb >= nz, np.where(pb, 2, 3), np.where(pz, 4, 5)),
        )
        f_sub = face[idx]
        f_sub[w] = (_FACE_BOX0 + 6 * bi.astype(np.int64) + k).astype(np.int16)
        t[idx] = t_sub
        face[idx] = f_sub
    return t, face
