"""The polytope stage on hand-made plane sets with exact geometry."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.cloud import GridSample
from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSegment, PlaneSet
from stereo_terrain.terrain import BOX, NONE, STAIRS, TerrainConfig, build_terrain

from .close_stairs import close_level_stairs_spec

CAM = np.array([0.0, 0.0, 0.6])
EXACT_M = 1e-6
SPACING_M = 0.02
#: The samples have no image geometry; all of them sit on this row of the sample grid,
#: mid-image (away from its top edge, where a face goes on out of view).
MID_ROW = 50


def _mid_grid(n: int) -> dict:
    """Image rows and sample-grid places of ``n`` samples, all on the grid's row ``MID_ROW``."""
    return {
        "rows": np.full(n, MID_ROW * 5, np.int32),
        "grid_index": MID_ROW * n + np.arange(n, dtype=np.int32),
        "grid_shape": (2 * MID_ROW, n),
    }


def _grid(u_range, v_range):
    a = np.arange(*u_range, SPACING_M)
    b = np.arange(*v_range, SPACING_M)
    return np.array(np.meshgrid(a, b, indexing="ij")).reshape(2, -1).T


def _stairs(n_steps=3, rise=0.17, run=0.29, yaw=0.0, distance=1.3, width=1.0, landing=0.6, box_depth=None):
    """Points of ground, risers and treads in the yaw frame, and their segments."""
    u = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    s0 = distance * np.cos(yaw)
    parts = []  # (points, normals, kind, plane)
    g = _grid((0.8, s0 + n_steps * run + 1.0), (-1.5, 1.5))
    ground = g[:, :1] * u + g[:, 1:] * v
    if box_depth is None:
        # ground not under the stairs
        ground = ground[(ground @ u < s0) | (np.abs(ground @ v) > width / 2)]
    else:
        ground = ground[(ground @ u < s0) | (ground @ u > s0 + box_depth) | (np.abs(ground @ v) > width / 2)]
    # Nor the ground the risers hide from the cameras (beside the stairs, behind them): a
    # disparity map holds one depth per pixel.
    for i in range(n_steps):
        d = ground - CAM
        t = ((s0 + i * run) - CAM @ u) / np.where(np.abs(d @ u) > 1e-9, d @ u, np.nan)
        X = CAM + t[:, None] * d
        on_face = (np.abs(X @ v) <= width / 2) & (X[:, 2] >= i * rise) & (X[:, 2] <= (i + 1) * rise)
        hidden = (t > 0) & (t < 1) & on_face
        ground = ground[~hidden]
    parts.append((ground, np.tile([0, 0, 1.0], (len(ground), 1)), HORIZONTAL, Plane([0, 0, 1.0], 0.0)))
    for i in range(n_steps):
        s_i = s0 + i * run
        lat_z = _grid((-width / 2, width / 2), (i * rise + 0.01, (i + 1) * rise - 0.01))
        riser = s_i * u + lat_z[:, :1] * v + lat_z[:, 1:] * np.array([0, 0, 1.0])
        parts.append((riser, np.tile(-u, (len(riser), 1)), VERTICAL, Plane(-u, s_i)))
        depth = box_depth if box_depth is not None else (run if i + 1 < n_steps else landing)
        tz = (i + 1) * rise
        st_lat = _grid((s_i + 0.01, s_i + depth - 0.01), (-width / 2, width / 2))
        tread = st_lat[:, :1] * u + st_lat[:, 1:] * v + np.array([0, 0, tz])
        parts.append((tread, np.tile([0, 0, 1.0], (len(tread), 1)), HORIZONTAL, Plane([0, 0, 1.0], -tz)))
    pts = np.vstack([p[0] for p in parts]).astype(np.float32)
    nrm = np.vstack([p[1] for p in parts]).astype(np.float32)
    n = len(pts)
    samples = GridSample(
        points=pts,
        normals=nrm,
        sigma_m=np.full(n, 0.005, np.float32),
        cols=np.full(n, 300, np.int32),
        **_mid_grid(n),
        stride_px=5,
        frame="yaw",
        camera_position=CAM,
    )
    segs, start = [], 0
    for p, _n, kind, plane in parts:
        idx = np.arange(start, start + len(p))
        segs.append(PlaneSegment(plane, kind, idx, 0.0))
        start += len(p)
    # Columns: put two samples at the image borders so that no riser "touches" them.
    cols = samples.cols.copy()
    cols[0], cols[1] = 0, 639
    samples = GridSample(**{**samples.__dict__, "cols": cols})
    order = np.random.default_rng(0).permutation(len(segs))  # planes come unordered
    return PlaneSet(tuple(segs[i] for i in order), samples, np.array([0, 0, 1.0]), "test", CAM)


def test_staircase_dimensions_exact():
    model = build_terrain(_stairs(n_steps=3, rise=0.17, run=0.29, distance=1.3))
    assert model.obstacle == STAIRS and len(model.steps) == 3
    for i, s in enumerate(model.steps):
        assert s.rise_m == pytest.approx(0.17, abs=0.005)
        assert s.distance_m == pytest.approx(1.3 + 0.29 * i, abs=EXACT_M)
        if i < 2:
            assert s.run_m == pytest.approx(0.29, abs=EXACT_M)
    assert model.steps[-1].run_m is None
    assert model.yaw_rad == pytest.approx(0.0, abs=EXACT_M)


def test_yawed_staircase_distance_where_x_axis_meets_riser():
    yaw = np.radians(20)
    model = build_terrain(_stairs(yaw=yaw, distance=1.5))
    assert model.yaw_rad == pytest.approx(yaw, abs=1e-6)
    assert model.steps[0].distance_m == pytest.approx(1.5, abs=1e-4)
    assert model.steps[1].distance_m == pytest.approx(1.5 + 0.29 / np.cos(yaw), abs=1e-4)


def test_box_is_one_step_with_ground_beyond():
    model = build_terrain(_stairs(n_steps=1, rise=0.2, box_depth=0.5))
    assert model.obstacle == BOX
    assert model.steps[0].rise_m == pytest.approx(0.2, abs=0.005)
    assert model.steps[0].run_m == pytest.approx(0.5, abs=0.03)


def test_ground_only_is_none():
    full = _stairs()
    ground = [s for s in full.segments if s.kind == HORIZONTAL and abs(s.plane.offset) < 1e-9]
    model = build_terrain(PlaneSet(tuple(ground), full.samples, full.up, "test", CAM))
    assert model.obstacle == NONE and model.note


def test_empty_plane_set_is_none():
    full = _stairs()
    assert build_terrain(PlaneSet((), full.samples, full.up, "test", CAM)).obstacle == NONE


def test_wall_is_not_a_step():
    full = _stairs(n_steps=1, rise=1.5)  # a 1.5 m "riser": a wall
    assert build_terrain(full).obstacle == NONE


def test_a_face_whose_plane_goes_on_below_the_ground_is_not_a_riser():
    """A vertical face 0-0.17 m high with a tread on top, but its plane also holds points
    0.3-0.6 m below the "ground" (seen past the ground's edge: the ground is a table top or
    a landing, not the floor this face stands on; the real OAK-D desk): no step. The same
    face without the points below is one."""
    import dataclasses

    full = _stairs(n_steps=1, rise=0.17)
    assert build_terrain(full).obstacle != NONE
    riser = next(s for s in full.segments if s.kind == VERTICAL)
    P = full.samples.points
    face = P[riser.indices]
    below = face[: len(face) // 3].copy()
    below[:, 2] = -0.3 - below[:, 2] * (0.3 / 0.17)  # the same plane, 0.3-0.6 m below the ground
    pts = np.vstack([P, below]).astype(np.float32)
    n = len(pts)
    samples = dataclasses.replace(
        full.samples,
        points=pts,
        normals=np.vstack(
            [full.samples.normals, np.tile(full.samples.normals[riser.indices[0]], (len(below), 1))]
        ),
        sigma_m=np.full(n, 0.005, np.float32),
        cols=np.concatenate([full.samples.cols, np.full(len(below), 300, np.int32)]),
        **_mid_grid(n),
    )
    idx = np.concatenate([riser.indices, np.arange(len(P), n)])
    segs = tuple(dataclasses.replace(s, indices=idx) if s is riser else s for s in full.segments)
    assert build_terrain(dataclasses.replace(full, segments=segs, samples=samples)).obstacle == NONE


def test_needs_gravity_aligned_planes():
    full = _stairs()
    with pytest.raises(ConfigError):
        build_terrain(PlaneSet(full.segments, full.samples, np.array([0, -1.0, 0]), "test", CAM))
    with pytest.raises(ConfigError):
        TerrainConfig(min_rise_m=0.5, max_rise_m=0.3)


@given(
    st.integers(2, 5),
    st.floats(0.10, 0.22),
    st.floats(0.25, 0.35),
    st.floats(-0.4, 0.4),
    st.floats(0.9, 2.0),
)
def test_polytope_vertices_lie_on_their_planes(n, rise, run, yaw, distance):
    model = build_terrain(_stairs(n_steps=n, rise=rise, run=run, yaw=yaw, distance=distance))
    assert model.obstacle == STAIRS and len(model.steps) == n
    verts = model.polytope.vertices
    assert len(model.polytope.faces) == 2 * n
    for k, face in enumerate(model.polytope.faces):
        step = model.steps[k // 2]
        quad = verts[list(face)]
        if k % 2 == 0:  # riser face
            assert np.allclose(quad @ step.riser.normal + step.riser.offset, 0, atol=1e-6)
        else:  # tread face at the step's top
            assert np.allclose(quad[:, 2], step.top_z_m, atol=0.01)
    for s in model.steps:
        assert s.rise_m == pytest.approx(rise, abs=0.01)


def test_parallel_vertical_planes_a_few_cm_apart_do_not_crash():
    full = _stairs(n_steps=2)
    segs = list(full.segments)
    riser = next(s for s in segs if s.kind == VERTICAL)
    pts = full.samples.points.copy()
    extra = pts[riser.indices] + np.array([0.05, 0.0, 0.0], np.float32)  # a parallel ghost 5 cm behind
    samples = GridSample(
        **{
            **full.samples.__dict__,
            "points": np.vstack([pts, extra]),
            "normals": np.vstack([full.samples.normals, full.samples.normals[riser.indices]]),
            "sigma_m": np.concatenate([full.samples.sigma_m, full.samples.sigma_m[riser.indices]]),
            "rows": np.concatenate([full.samples.rows, full.samples.rows[riser.indices]]),
            "cols": np.concatenate([full.samples.cols, full.samples.cols[riser.indices]]),
        }
    )
    ghost_idx = np.arange(len(pts), len(pts) + len(extra))
    ghost = PlaneSegment(
        Plane(riser.plane.normal, riser.plane.offset - 0.05 * riser.plane.normal[0] * -1),
        VERTICAL,
        ghost_idx,
        0.0,
    )
    model = build_terrain(PlaneSet(tuple(segs) + (ghost,), samples, full.up, "test", CAM))
    assert model.obstacle in (STAIRS, BOX, NONE)


def test_obstacle_rise_limit_is_not_below_the_stair_limit():
    with pytest.raises(ConfigError, match="max_obstacle_rise_m"):
        TerrainConfig(max_rise_m=0.35, max_obstacle_rise_m=0.30)


@pytest.mark.parametrize(("yaw_deg", "side"), [(45.0, "left"), (-45.0, "right"), (60.0, "left")])
def test_yawed_stairs_beside_a_wall_the_wall_is_never_a_riser(yaw_deg, side):
    """Stairs yawed by 45-60 deg running along a tall side wall (with and without a rig):
    every step is found, at the right rise and distance, and no riser is the wall."""
    import dataclasses
    import math

    from stereo_terrain.pipeline import Pipeline
    from stereo_terrain.synthetic import default_scene_spec, render_scene

    base = default_scene_spec()
    stairs = dataclasses.replace(
        base.obstacle, yaw_rad=math.radians(yaw_deg), lateral_m=0.0, width_m=1.0, distance_m=1.6
    )
    wall = {f"{side}_wall_m": (0.51 if side == "left" else -0.51)}
    scene = render_scene(dataclasses.replace(base, obstacle=stairs, back_wall_m=None, **wall))
    assert any(p.get("name") == f"{side}_wall" for p in scene.truth["planes"])
    axis = np.array([math.cos(stairs.yaw_rad), math.sin(stairs.yaw_rad), 0.0])
    for rig in (scene.rig, None):
        result = Pipeline(scene.calibration, rig).run(scene.left, scene.right)
        steps = result.terrain.steps
        assert result.terrain.obstacle == "stairs" and len(steps) == len(scene.truth["steps"])
        for got, want in zip(steps, scene.truth["steps"], strict=True):
            assert abs(got.rise_m - want["rise"]) < 0.015
            assert abs(got.distance_m - want["distance"]) < 0.05
            # A riser faces down the stairs; the wall's normal is across them.
            assert abs(got.riser.normal @ axis) > math.cos(math.radians(10.0))


@pytest.mark.parametrize("yaw_deg", [0.0, -30.0])
def test_stairs_filling_the_view_keep_their_first_step(yaw_deg):
    """A level camera 0.45 m high, 0.8 m from a wide staircase: the first riser's foot and the floor are
    below the image. The first step is still reported, at its distance, with its rise
    inferred from the others. (Two steps, both treads below the camera: a tread above it is not seen
    and its rise comes from the riser's top edge, a harder case than this test is about.)"""
    from stereo_terrain.pipeline import Pipeline
    from stereo_terrain.synthetic import render_scene

    spec = close_level_stairs_spec(n_steps=2, width_m=2.5, distance_m=0.8, yaw_deg=yaw_deg, back_wall_m=None)
    scene = render_scene(spec)
    data = Pipeline(scene.calibration).run(scene.left, scene.right).to_json_dict()
    truth = scene.truth["steps"]
    assert data["obstacle"] == "stairs" and len(data["steps"]) == len(truth), data["note"]
    first = data["steps"][0]
    assert first["rise_inferred"] is True and not any(s["rise_inferred"] for s in data["steps"][1:])
    assert abs(first["distance"] - truth[0]["distance"]) < 0.03
    for got, want in zip(data["steps"], truth, strict=True):
        assert abs(got["rise"] - want["rise"]) < 0.02


@pytest.mark.parametrize(("width_m", "distance_m"), [(0.4, 0.75), (0.5, 0.8)])
def test_first_riser_cut_by_the_image_bottom_stands_on_the_floor_seen_beside_it(width_m, distance_m):
    """A level camera 0.45 m high close to a narrow staircase: the first riser's foot is
    below the image, the floor is seen beside the stairs. The first riser's bottom is the
    image's edge, not a riser floating above the floor: it is kept, and its rise measured
    from that floor (not inferred). Beyond the first two steps a tread above the camera is
    not seen (the 0.5 m wide case's third rise), which is not what this test is about."""
    from stereo_terrain.pipeline import Pipeline
    from stereo_terrain.synthetic import render_scene

    scene = render_scene(close_level_stairs_spec(n_steps=3, width_m=width_m, distance_m=distance_m))
    data = Pipeline(scene.calibration, scene.rig).run(scene.left, scene.right).to_json_dict()
    truth = scene.truth["steps"]
    assert data["obstacle"] == "stairs" and len(data["steps"]) == len(truth), data["note"]
    for got, want in zip(data["steps"][:2], truth[:2], strict=True):
        assert abs(got["rise"] - want["rise"]) < 0.01
        assert abs(got["distance"] - want["distance"]) < 0.02
        assert got["rise_inferred"] is False


def test_a_railing_with_more_points_than_the_risers_does_not_set_the_stair_axis():
    """Seen from the side, the balusters between the rails (a short vertical plane along
    the stairs, facing the camera, nearer than the steps) can hold more samples than the
    risers. Their direction must not become the stair axis: the risers chain into steps,
    the railing does not."""
    full = _stairs(n_steps=2, rise=0.17, run=0.29, distance=1.3)
    risers = [s for s in full.segments if s.kind == VERTICAL]
    rail_xz = _grid((0.7, 1.9), (0.21, 0.55))  # 1.2 m along the stairs, 0.34 m tall
    rail = np.column_stack([rail_xz[:, 0], np.full(len(rail_xz), -1.0), rail_xz[:, 1]]).astype(np.float32)
    assert len(rail) > sum(s.count for s in risers)
    s0 = full.samples
    n0 = len(s0.points)
    samples = GridSample(
        **{
            **s0.__dict__,
            "points": np.vstack([s0.points, rail]),
            "normals": np.vstack([s0.normals, np.tile(np.float32([0, 1, 0]), (len(rail), 1))]),
            "sigma_m": np.concatenate([s0.sigma_m, np.full(len(rail), 0.005, np.float32)]),
            "cols": np.concatenate([s0.cols, np.full(len(rail), 300, np.int32)]),
            **_mid_grid(n0 + len(rail)),
        }
    )
    railing = PlaneSegment(Plane([0.0, 1.0, 0.0], 1.0), VERTICAL, np.arange(n0, n0 + len(rail)), 0.0)
    model = build_terrain(PlaneSet((railing, *full.segments), samples, full.up, "test", CAM))
    assert model.obstacle == STAIRS and len(model.steps) == 2, model.note
    assert abs(model.yaw_rad) < np.radians(2.0)
    for s in model.steps:
        assert s.rise_m == pytest.approx(0.17, abs=EXACT_M)


def _riser_edges_numpy(P, plane, v, v_lo, v_hi, *, thr, seed_z):
    """``terrain._riser_edges`` as it was in NumPy (before issue 13's kernel)."""
    from stereo_terrain._numeric import percentile
    from stereo_terrain.terrain.risers import _EDGE_BINS, _EDGE_BOTTOM_QUANTILE, _EDGE_GAP_M, _EDGE_QUANTILE

    near = plane.residuals(P) < thr
    lat = P[near] @ v
    keep = (lat > v_lo) & (lat < v_hi)
    z, lat = P[near, 2][keep], lat[keep]
    if len(z) == 0:
        return None
    order = np.argsort(z)
    z, lat = z[order], lat[order]
    k = int(np.clip(np.searchsorted(z, seed_z), 0, len(z) - 1))
    gaps = np.flatnonzero(np.diff(z) > _EDGE_GAP_M)
    lo_i = int(gaps[gaps < k].max()) + 1 if np.any(gaps < k) else 0
    hi_i = int(gaps[gaps >= k].min()) + 1 if np.any(gaps >= k) else len(z)
    z, lat = z[lo_i:hi_i], lat[lo_i:hi_i]
    bins = np.clip(((lat - v_lo) / max(v_hi - v_lo, 1e-9) * _EDGE_BINS).astype(int), 0, _EDGE_BINS - 1)
    lows, highs = [], []
    for b in range(_EDGE_BINS):
        zb = z[bins == b]
        if len(zb) >= 3:
            lows.append(zb[int(0.02 * (len(zb) - 1) + 0.5)])
            highs.append(zb[int(0.98 * (len(zb) - 1) + 0.5)])
    if not lows:
        return float(z[int(0.02 * (len(z) - 1) + 0.5)]), float(z[int(0.98 * (len(z) - 1) + 0.5)])
    return float(percentile(lows, _EDGE_BOTTOM_QUANTILE)), float(percentile(highs, _EDGE_QUANTILE))


def test_riser_edges_kernel_is_the_numpy_version_bit_for_bit():
    """Issue 13: the compiled slices give NumPy's edges (ties in height, gaps, empty and
    narrow extents, slices with fewer than three samples)."""
    from stereo_terrain.msac import Plane
    from stereo_terrain.terrain.risers import _riser_edges

    rng = np.random.default_rng(0)
    for t in range(1500):
        n = int(rng.integers(0, 400))
        z = rng.normal(0.2, 0.2, n) * rng.choice([20, 200, 1e6])
        P = np.column_stack([rng.normal(0, 0.3, n), rng.uniform(-1, 1, n), np.round(z, 0) / 100])
        if t % 3 == 0:
            P[: n // 2, 2] += 0.3  # a gap in height
        plane = Plane(np.array([1.0, rng.normal(0, 0.1), 0.0]), rng.normal(0, 0.1))
        v = np.array([0.0, 1.0, 0.0])
        v_lo, v_hi = sorted(rng.uniform(-1.2, 1.2, 2))
        kw = {"thr": float(rng.uniform(0.05, 1.0)), "seed_z": float(rng.normal(0.2, 0.3))}
        assert _riser_edges(P, plane, v, v_lo, v_hi, **kw) == _riser_edges_numpy(
            P, plane, v, v_lo, v_hi, **kw
        )


@pytest.mark.parametrize("yaw_deg", [0.0, 25.0])
def test_an_unmatched_first_riser_stands_at_its_treads_front_edge(yaw_deg):
    """The first riser is not a plane (a texture-poor face the matcher missed), but the
    first tread is, and the second riser chains on it: the first step is at the tread's
    front edge."""
    yaw = np.radians(yaw_deg)
    full = _stairs(n_steps=3, rise=0.17, run=0.29, yaw=yaw, distance=1.3)
    u = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    first = [
        s for s in full.segments if s.kind == VERTICAL and abs(s.plane.offset - 1.3 * np.cos(yaw)) < 1e-6
    ]
    assert len(first) == 1
    # Image rows: the ground reaches the image's bottom, the risers do not (their feet are
    # in view).
    ground = [s for s in full.segments if s.kind == HORIZONTAL and abs(s.plane.offset) < 1e-9][0]
    rows = np.full(len(full.samples.points), 200, np.int32)
    rows[ground.indices] = 479
    samples = GridSample(**{**full.samples.__dict__, "rows": rows})
    kept = tuple(s for s in full.segments if s is not first[0])
    assert build_terrain(PlaneSet(tuple(full.segments), samples, full.up, "test", CAM)).steps[
        0
    ].distance_m == (pytest.approx(1.3, abs=1e-4))
    model = build_terrain(PlaneSet(kept, samples, full.up, "test", CAM))
    assert model.obstacle == STAIRS and len(model.steps) == 3
    assert model.steps[0].rise_m == pytest.approx(0.17, abs=0.005)
    assert model.steps[0].distance_m == pytest.approx(
        1.3 + 0.01 / u[0], abs=0.03
    )  # the tread's first samples


def test_a_lone_tread_with_no_riser_behind_it_is_not_a_step():
    """A raised horizontal plane (a table top) and no riser plane chaining on it: none."""
    full = _stairs(n_steps=1, rise=0.17, box_depth=0.5)
    planes = tuple(s for s in full.segments if s.kind == HORIZONTAL)
    assert build_terrain(PlaneSet(planes, full.samples, full.up, "test", CAM)).obstacle == NONE


def test_a_step_too_tall_for_a_stair_needs_its_top_seen():
    """The safety net for steps taller than ``max_rise_m``: a 42 cm box whose top is seen
    is a box; the same front face with no plane on top (a wall's or a piece of furniture's
    front: the real Middlebury Motorcycle and Adirondack scenes) is nothing."""
    boxed = _stairs(n_steps=1, rise=0.42, box_depth=0.5)
    model = build_terrain(boxed)
    assert model.obstacle == BOX and abs(model.steps[0].rise_m - 0.42) < 0.01
    no_top = [s for s in boxed.segments if not (s.kind == HORIZONTAL and abs(s.plane.offset + 0.42) < 1e-6)]
    assert len(no_top) == len(boxed.segments) - 1
    model = build_terrain(PlaneSet(tuple(no_top), boxed.samples, boxed.up, "test", CAM))
    assert model.obstacle == NONE, model.note


@settings(max_examples=50, deadline=None)
@given(yaw=st.floats(-math.pi, math.pi))
def test_stair_axes_are_a_horizontal_right_handed_pair(yaw):
    """``u`` points along the yaw, ``v`` is ``u`` turned +90 deg about z (z x u)."""
    from stereo_terrain.terrain.model import stair_axes

    u, v = stair_axes(yaw)
    assert u @ u == pytest.approx(1.0) and v @ v == pytest.approx(1.0)
    assert u @ v == pytest.approx(0.0, abs=1e-12) and u[2] == v[2] == 0.0
    assert np.allclose(np.cross([0.0, 0.0, 1.0], u), v)
    assert math.remainder(math.atan2(u[1], u[0]) - yaw, 2.0 * math.pi) == pytest.approx(0.0, abs=1e-9)
