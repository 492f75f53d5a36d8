"""Scene geometry: the obstacle as boxes in its local frame, and the ray caster."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .spec import SceneSpec, StairSpec, _obstacle_centre_b, _obstacle_far_end

# Face ids of the ray caster: 0 nothing (sky), 1 ground, 2 back wall, then 6 per box:
# 3 + 6 i + k, k = 0 front (-u, riser), 1 back (+u), 2 right (-v), 3 left (+v),
# 4 bottom (-z), 5 top (+z, tread).
_FACE_SKY, _FACE_GROUND, _FACE_WALL, _FACE_BOX0 = 0, 1, 2, 3


# --------------------------------------------------------------------------- geometry


@dataclass(frozen=True)
class _Geometry:
    """Obstacle and wall in the obstacle's local frame ``(a, b, z) = (u . p, v . p, z)``."""

    cos_yaw: float
    sin_yaw: float
    boxes: np.ndarray  # (K, 6): a_lo, a_hi, b_lo, b_hi, z_lo, z_hi
    wall_a: float | None

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
    return _Geometry(
        math.cos(yaw), math.sin(yaw), np.array(boxes, dtype=np.float64).reshape(-1, 6), spec.back_wall_m
    )


def _cast(
    origin: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, geom: _Geometry
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest hit of rays ``origin + t d`` (yaw frame) with the scene.

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
