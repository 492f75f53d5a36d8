"""Box or stairs (a single step), and the polytope's vertices from plane intersections."""

from __future__ import annotations

import dataclasses

import numpy as np

from .._numeric import percentile  # NumPy's bits, a fraction of its time (issue 13)
from .model import BOX, STAIRS, Polytope, Step, TerrainConfig
from .risers import _Riser


def _classify_single_step(
    step: Step, h_info: list, ground_z: float, config: TerrainConfig, note: str
) -> tuple[str, str, list[Step]]:
    """One step is a box when its top is bounded: ground seen again beyond it."""
    if step.tread is None:
        return STAIRS, note + "; top not seen, reported as a one-step staircase", [step]
    top_z = step.top_z_m
    top_far = None
    for _h, z, s_h, _v in h_info:
        if abs(z - top_z) < 1e-9:
            top_far = (
                float(percentile(s_h[s_h > step.axis_position_m - 0.02], 98))
                if np.any(s_h > step.axis_position_m - 0.02)
                else None
            )
    if top_far is None:
        return STAIRS, note, [step]
    for _h, z, s_h, _v in h_info:
        if abs(z - ground_z) < config.min_rise_m and np.sum(s_h > top_far + 0.02) >= config.min_tread_points:
            boxed = dataclasses.replace(step, run_m=float(top_far - step.axis_position_m))
            return BOX, note + "; ground seen beyond the top: a box", [boxed]
    return STAIRS, note, [step]


def _intersect_all(triplets: list[list[tuple[np.ndarray, float]]]) -> np.ndarray:
    """Points where each triplet of planes ``(n, d)`` meets, solved in one batch; NaN rows
    for (near) parallel triplets."""
    A = np.array([[p[0] for p in t] for t in triplets], dtype=np.float64).reshape(-1, 3, 3)
    b = -np.array([[p[1] for p in t] for t in triplets], dtype=np.float64).reshape(-1, 3)
    ok = np.abs(np.linalg.det(A)) > 1e-9
    out = np.full((len(A), 3), np.nan)
    if ok.any():
        out[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    return out


def _polytope(steps: list[Step], risers: list[_Riser], u, v, ground_z: float) -> Polytope:
    """Vertices from plane intersections: riser x horizontal x lateral bounds.

    Per step a riser quad (riser plane with the surface below, the tread above and the two
    lateral bounds) and a tread quad (tread plane with this riser, the next one, and the
    lateral bounds).
    """
    by_s = {round(r.s, 6): r for r in risers}
    # Steps without a riser plane of their own span the staircase's lateral extent.
    default_lat = (min(r.v_lo for r in risers), max(r.v_hi for r in risers)) if risers else (-0.5, 0.5)
    triplets: list[list[tuple[np.ndarray, float]]] = []
    prev_plane = (np.array([0.0, 0.0, 1.0]), -ground_z)
    for i, st in enumerate(steps):
        # (a riser moved to where both images put it is found where its samples put it)
        r = by_s.get(round(st.sampled_position_m, 6))
        v_lo, v_hi = (r.v_lo, r.v_hi) if r is not None else default_lat
        riser = (st.riser.normal, st.riser.offset)
        top = (
            (st.tread.normal, st.tread.offset)
            if st.tread is not None
            else (np.array([0.0, 0.0, 1.0]), -st.top_z_m)
        )
        lat_lo, lat_hi = (v, -v_lo), (v, -v_hi)
        if i + 1 < len(steps):
            nxt = (steps[i + 1].riser.normal, steps[i + 1].riser.offset)
        else:
            depth = st.run_m if st.run_m is not None else 0.3
            nxt = (-u, st.axis_position_m + depth)  # the plane u . x = s_back
        triplets += [
            [riser, prev_plane, lat_lo],
            [riser, prev_plane, lat_hi],
            [riser, top, lat_hi],
            [riser, top, lat_lo],
            [riser, top, lat_lo],
            [riser, top, lat_hi],
            [nxt, top, lat_hi],
            [nxt, top, lat_lo],
        ]
        prev_plane = top
    if not triplets:
        return Polytope(np.zeros((0, 3)))
    pts = _intersect_all(triplets)
    faces: list[tuple[int, int, int, int]] = []
    keep: list[np.ndarray] = []
    for q in range(len(pts) // 4):
        quad = pts[4 * q : 4 * q + 4]
        if np.isfinite(quad).all():
            base = 4 * len(keep)
            keep.append(quad)
            faces.append((base, base + 1, base + 2, base + 3))
    verts = np.vstack(keep) if keep else np.zeros((0, 3))
    return Polytope(verts, tuple(faces))
