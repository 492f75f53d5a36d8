"""Issue 11: a staircase whose treads formed no plane takes each top from its riser's top
edge, found a little low (and the bottom edge a little high) where the samples near the
edges are lost; the first step's rise, from the floor plane, must not keep that bias
(terrain/risers.py ``edge_bias``; realistic renders in docs/benchmarks.md)."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.cloud import GridSample
from stereo_terrain.msac import Plane
from stereo_terrain.planes.orientation import HORIZONTAL, VERTICAL, PlaneSegment, PlaneSet
from stereo_terrain.terrain import STAIRS, TerrainConfig, build_terrain

from .test_terrain import CAM, SPACING_M, _grid, _mid_grid


def _stairs_without_treads(
    n_steps: int, rise: float, run: float, short_m: float, distance: float = 1.3
) -> PlaneSet:
    """Floor and risers, no tread planes and no tread samples; each riser's samples stop
    ``short_m`` short of its bottom and top edges (20 heights between them, so that the
    edges found are exactly there)."""
    floor = _grid((0.8, distance - 0.02), (-1.0, 1.0))
    parts = [(np.column_stack([floor, np.zeros(len(floor))]), HORIZONTAL, Plane([0, 0, 1.0], 0.0))]
    lat = np.arange(-0.5, 0.5, SPACING_M)
    for i in range(n_steps):
        s_i = distance + i * run
        z = np.linspace(i * rise + short_m, (i + 1) * rise - short_m, 20)
        g = np.array(np.meshgrid(lat, z, indexing="ij")).reshape(2, -1).T
        riser = np.column_stack([np.full(len(g), s_i), g[:, 0], g[:, 1]])
        parts.append((riser, VERTICAL, Plane([-1.0, 0, 0], s_i)))
    pts = np.vstack([p for p, _, _ in parts]).astype(np.float32)
    nrm = np.vstack(
        [np.tile([0, 0, 1.0] if kind == HORIZONTAL else [-1.0, 0, 0], (len(p), 1)) for p, kind, _ in parts]
    ).astype(np.float32)
    n = len(pts)
    cols = np.full(n, 300, np.int32)
    cols[0], cols[1] = 0, 639  # no riser touches the image's sides
    samples = GridSample(
        points=pts,
        normals=nrm,
        sigma_m=np.full(n, 0.005, np.float32),
        cols=cols,
        **_mid_grid(n),
        stride_px=5,
        frame="yaw",
        camera_position=CAM,
    )
    rows = samples.rows.copy()
    rows[0] = 479  # a floor sample at the image's bottom: the risers' feet are in view
    samples = dataclasses.replace(samples, rows=rows)
    segs, start = [], 0
    for p, kind, plane in parts:
        segs.append(PlaneSegment(plane, kind, np.arange(start, start + len(p)), 0.0))
        start += len(p)
    return PlaneSet(tuple(segs), samples, np.array([0, 0, 1.0]), "test", CAM)


def _own_rises(model) -> list[float]:
    return [s.own_rise_m for s in model.steps]


@settings(max_examples=40, deadline=None)
@given(
    n_steps=st.integers(2, 3),
    rise=st.floats(0.12, 0.18),
    run=st.floats(0.22, 0.34),
    short_m=st.floats(0.0, 0.035),
)
def test_the_first_rise_keeps_no_edge_bias(n_steps, rise, run, short_m):
    """Every step's own rise within 5 mm of the truth, the first one (from the floor
    plane) as well as those between two top edges."""
    model = build_terrain(_stairs_without_treads(n_steps, rise, run, short_m))
    assert model.obstacle == STAIRS and len(model.steps) == n_steps, model.note
    assert _own_rises(model) == pytest.approx([rise] * n_steps, abs=0.005)
    assert [s.top_z_m for s in model.steps] == pytest.approx(
        [rise * (i + 1) for i in range(n_steps)], abs=0.005
    )


def test_without_the_correction_the_first_rise_is_short_by_the_bias():
    """What it mends (the test above fails without it): the edges 3 cm short make the
    first rise 3 cm short and leave the others right."""
    planes = _stairs_without_treads(3, 0.17, 0.28, 0.03)
    off = build_terrain(planes, TerrainConfig(max_edge_bias_m=0.0))
    assert _own_rises(off) == pytest.approx([0.14, 0.17, 0.17], abs=0.003)
    assert _own_rises(build_terrain(planes)) == pytest.approx([0.17, 0.17, 0.17], abs=0.003)


def test_the_correction_is_capped():
    """A gap between the edges larger than twice ``max_edge_bias_m`` is not all bias (a
    riser seen in part, the wrong plane): no more than the cap is added."""
    planes = _stairs_without_treads(3, 0.17, 0.28, 0.03)
    capped = build_terrain(planes, TerrainConfig(max_edge_bias_m=0.01))
    assert _own_rises(capped) == pytest.approx([0.15, 0.17, 0.17], abs=0.003)


def test_a_lone_riser_has_no_gap_to_measure():
    """One step: no next riser's foot to measure the bias against, so nothing is added."""
    model = build_terrain(_stairs_without_treads(1, 0.17, 0.28, 0.02))
    assert model.obstacle != "none", model.note
    assert model.steps[0].own_rise_m == pytest.approx(0.15, abs=0.003)  # 2 cm short, as found
