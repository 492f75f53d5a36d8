"""A box's depth is where its top's own samples end (terrain/polytope.py ``box_depth``),
not where the last sample at the top's height lies (issue 11)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.cloud import GridSample
from stereo_terrain.errors import ConfigError
from stereo_terrain.msac import Plane
from stereo_terrain.planes.orientation import HORIZONTAL, PlaneSegment, PlaneSet
from stereo_terrain.terrain import BOX, Step, TerrainConfig, build_terrain
from stereo_terrain.terrain.polytope import _classify_single_step, box_depth

from .test_terrain import _mid_grid, _stairs

TOP_GAP_M = TerrainConfig().box_top_gap_m
#: A box's depth from exact samples 2 cm apart: within a sample spacing and the 98th
#: percentile's share of it.
DEPTH_TOL_M = 0.03


def _with_strip_at_top_height(planes: PlaneSet, top_z: float, s_range, v_range) -> PlaneSet:
    """``planes`` with more samples on its plane at ``top_z``: a strip of something else at
    the box top's height (a wall, a shelf, the matcher's plane carried on), apart from it."""
    a = np.arange(*s_range, 0.02)
    b = np.arange(*v_range, 0.02)
    extra = np.array(np.meshgrid(a, b, indexing="ij")).reshape(2, -1).T
    pts = np.column_stack([extra, np.full(len(extra), top_z)]).astype(np.float32)
    old = planes.samples
    n0, n = len(old.points), len(pts)
    samples = GridSample(
        points=np.vstack([old.points, pts]),
        normals=np.vstack([old.normals, np.tile(np.float32([0, 0, 1]), (n, 1))]),
        sigma_m=np.concatenate([old.sigma_m, np.full(n, 0.005, np.float32)]),
        cols=np.concatenate([old.cols, np.full(n, 300, np.int32)]),
        **_mid_grid(n0 + n),
        stride_px=old.stride_px,
        frame=old.frame,
        camera_position=old.camera_position,
    )
    segs = []
    for seg in planes.segments:
        if seg.kind == HORIZONTAL and abs(-seg.plane.offset - top_z) < 1e-9:
            more = np.concatenate([seg.indices, n0 + np.arange(n)])
            seg = PlaneSegment(seg.plane, seg.kind, more, seg.rms_m)
        segs.append(seg)
    return PlaneSet(tuple(segs), samples, planes.up, planes.stop_reason, planes.camera_position)


@pytest.mark.parametrize("lateral", [(-0.4, 0.4), (-1.4, 1.4)])
def test_a_strip_at_the_top_s_height_beyond_the_box_is_not_its_top(lateral):
    # A 0.5 m deep box 1.3 m away, and samples at its top's height 0.9-1.1 m beyond its
    # front (within its width, or across the room), the floor seen beyond them: the box
    # stays 0.5 m deep (it was 1.1 m).
    planes = _stairs(n_steps=1, rise=0.2, box_depth=0.5)
    strip = _with_strip_at_top_height(planes, 0.2, (1.3 + 0.9, 1.3 + 1.1), lateral)
    model = build_terrain(strip)
    assert model.obstacle == BOX, model.note
    assert model.steps[0].run_m == pytest.approx(0.5, abs=DEPTH_TOL_M)


@settings(max_examples=60, deadline=None)
@given(
    depth=st.floats(0.2, 0.9),
    spacing=st.floats(0.01, TOP_GAP_M * 0.9),
    gap=st.floats(TOP_GAP_M * 1.1, 2.0),
    a=st.floats(0.8, 2.5),
    beside=st.floats(0.1, 1.0),
)
def test_box_depth_ends_at_the_first_wide_gap(depth, spacing, gap, a, beside):
    top = a + np.append(np.arange(0.0, depth, spacing), depth)  # to its far edge
    beyond = top[-1] + gap + np.arange(0.0, 0.5, 0.02)  # something else at the top's height
    aside = a + np.linspace(0.0, 3.0, 40)  # beside the box, outside its width
    s = np.concatenate([top, beyond, aside])
    v = np.concatenate([np.zeros(len(top) + len(beyond)), np.full(len(aside), 0.5 + 0.05 + beside)])
    got = box_depth(a, s, v, (-0.5, 0.5), TOP_GAP_M)
    # the 98th percentile of the top's samples: within 2% of its depth and a spacing of its edge
    assert got is not None and 0.98 * depth - spacing <= got <= depth + 1e-9


def test_box_depth_is_none_where_the_top_is_not_seen_beyond_its_front():
    a = 1.2
    assert box_depth(a, np.array([a - 0.01, a + 0.01, a + 1.0]), np.zeros(3), (-0.5, 0.5), TOP_GAP_M) is None
    beside = np.array([2.0])  # only beside the riser
    assert box_depth(a, np.array([a + 0.3]), beside, (-0.5, 0.5), TOP_GAP_M) is None


def test_a_box_whose_top_is_not_seen_beyond_its_front_has_no_depth():
    # The top plane holds 3 cm of the box's top and a shelf at its height 2.5 m beyond;
    # the floor is seen beyond both: a box, of a depth not known (it was 2.5 m).
    a, top_z = 1.2, 0.2
    riser = Plane(np.array([-1.0, 0.0, 0.0]), a)
    tread = Plane(np.array([0.0, 0.0, 1.0]), -top_z)
    step = Step(top_z, None, a, 0.8, top_z, a, riser, tread)
    s_top = np.concatenate([a + np.linspace(0.0, 0.03, 4), a + 2.5 + np.linspace(0.0, 0.2, 11)])
    s_floor = np.linspace(0.0, 5.0, 200)
    h_info = [
        (None, top_z, s_top, np.zeros(len(s_top))),
        (None, 0.0, s_floor, np.zeros(len(s_floor))),
    ]
    config = TerrainConfig()
    obstacle, _, steps = _classify_single_step(step, h_info, 0.0, config, "", (-0.4, 0.4))
    assert obstacle == BOX and steps[0].run_m is None
    # With the top seen to 0.5 m, that is its depth.
    s_top = np.concatenate([a + np.arange(0.0, 0.5001, 0.02), a + 2.5 + np.linspace(0.0, 0.2, 11)])
    h_info[0] = (None, top_z, s_top, np.zeros(len(s_top)))
    obstacle, _, steps = _classify_single_step(step, h_info, 0.0, config, "", (-0.4, 0.4))
    assert obstacle == BOX and steps[0].run_m == pytest.approx(0.5, abs=DEPTH_TOL_M)


def test_box_top_gap_is_checked():
    with pytest.raises(ConfigError):
        TerrainConfig(box_top_gap_m=0.0)
