"""Steps carried on where the image shows their risers' ends: vertical edges placed by both
images (terrain/photometric.py edge_disparities, terrain/nosings/view.py vertical_edges,
terrain/nosings/riser_ends.py, TerrainConfig.riser_end_steps)."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.terrain import STAIRS, build_terrain
from stereo_terrain.terrain.nosings.view import MIN_EDGE_SCORE, ImageLines, VerticalEdges
from stereo_terrain.terrain.photometric import StereoView, edge_disparities

from .test_line_frame import _realistic
from .test_terrain_nosings import NO_SAMPLES, SIZE, _camera, _planes

FOCAL, CX, CY, BASELINE = 500.0, 320.0, 240.0, 0.08


def _edge_image(x_edge: np.ndarray, shape=(160, 240), seed=0) -> np.ndarray:
    """A dark left half and a bright right half meeting at ``x_edge[row]`` (a ramp a pixel
    wide, so that the edge's place is sub-pixel), with a grey level of noise."""
    h, w = shape
    cols = np.arange(w, dtype=np.float64)[None, :]
    ramp = np.clip(cols - x_edge[:, None] + 0.5, 0.0, 1.0)
    noise = np.random.default_rng(seed).normal(0.0, 1.0, (h, w))
    return np.clip(70.0 + 90.0 * ramp + noise, 0, 255).astype(np.uint8)


def _stereo(left: np.ndarray, right: np.ndarray, T: np.ndarray | None = None) -> StereoView:
    return StereoView(left, right, FOCAL, CX, CY, BASELINE, 0.0, np.eye(4) if T is None else T)


@settings(max_examples=30, deadline=None)
@given(disparity=st.floats(3.0, 45.0), x_top=st.floats(120.0, 200.0), lean=st.floats(-3.0, 3.0))
def test_an_edge_is_placed_at_its_disparity(disparity, x_top, lean):
    rows = np.arange(160, dtype=np.float64)
    x_left = x_top + lean * rows / 160.0
    left = _edge_image(x_left, seed=1)
    right = _edge_image(x_left - disparity, seed=2)
    segment = np.array([[x_left[20], 20.0, x_left[140], 140.0]])
    d, score = edge_disparities(_stereo(left, right), segment, (0.0, 60.0))
    assert d[0] == pytest.approx(disparity, abs=0.15)
    assert score[0] > 0.9


def test_a_uniform_face_places_no_edge():
    """Where the left image shows an edge the right one does not (a reflection, or nothing
    to match), the correlation stays low and the edge is not placed."""
    rng = np.random.default_rng(3)
    left = _edge_image(np.full(160, 150.0), seed=4)
    right = np.clip(115.0 + rng.normal(0.0, 1.0, (160, 240)), 0, 255).astype(np.uint8)
    d, score = edge_disparities(_stereo(left, right), np.array([[150.0, 20.0, 150.0, 140.0]]), (0.0, 60.0))
    assert not score[0] >= MIN_EDGE_SCORE
    short = np.array([[150.0, 20.0, 150.0, 24.0]])  # too few rows to match
    assert np.isnan(edge_disparities(_stereo(left, right), short, (0.0, 60.0))[0][0])


def test_vertical_edges_are_placed_where_the_bar_stands():
    """A bright bar 2 m ahead of a level camera 0.6 m up: both of its sides are vertical
    lines at its depth, their feet and tops at the heights the rows show."""
    depth, height = 2.0, 0.6
    disparity = FOCAL * BASELINE / depth
    h, w = SIZE[1], SIZE[0]
    cols = np.arange(w, dtype=np.float64)[None, :]

    def bar(x0: float) -> np.ndarray:
        inside = np.clip(cols - x0 + 0.5, 0.0, 1.0) * np.clip(x0 + 40.0 - cols + 0.5, 0.0, 1.0)
        img = np.repeat(60.0 + 120.0 * inside, h, axis=0)
        return np.clip(img + np.random.default_rng(int(x0)).normal(0.0, 1.0, (h, w)), 0, 255).astype(np.uint8)

    T = _camera(height)
    left, right = bar(300.0), bar(300.0 - disparity)
    segments = np.array(
        [[300.0, 150.0, 300.0, 350.0], [340.0, 350.0, 340.0, 150.0], [100.0, 300.0, 200.0, 300.0]]
    )
    lines = ImageLines(segments, FOCAL, CX, CY, SIZE, T, stereo=_stereo(left, right, T))
    edges = lines.vertical_edges
    assert len(edges.foot) == 2  # the horizontal segment is none
    assert edges.foot[:, 0] == pytest.approx([depth, depth], abs=0.03)
    assert edges.foot[:, 2] == pytest.approx(height - (350.0 - CY) / FOCAL * depth, abs=0.02)
    assert edges.top[:, 2] == pytest.approx(height - (150.0 - CY) / FOCAL * depth, abs=0.02)


def _with_edges(edges: VerticalEdges) -> ImageLines:
    """Image lines without segments whose vertical edges are ``edges`` (as if placed)."""
    tiny = np.zeros((8, 8), dtype=np.uint8)
    lines = ImageLines(np.empty((0, 4)), FOCAL, CX, CY, SIZE, _camera(0.6), stereo=_stereo(tiny, tiny))
    lines.__dict__["vertical_edges"] = edges  # the cached property, as vertical_edges would fill it
    return lines


def _side_profile(n: int, rise: float, run: float, distance: float, side: float, *, runs=None, span=None):
    """The ends of ``n`` risers on the staircase's side at ``side`` along y: each from a
    centimetre above its tread to a centimetre below its nosing (the segments' ends are not
    the corners), or ``span`` tall."""
    feet, tops = [], []
    a = distance
    for k in range(n):
        if k:
            a += run if runs is None else runs[k - 1]
        feet.append([a, side, k * rise + 0.01])
        tops.append([a, side, (k + 1) * rise - 0.01 if span is None else k * rise + span])
    return VerticalEdges(np.array(feet), np.array(tops))


@settings(max_examples=25, deadline=None)
@given(
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.22, 0.35),
    distance=st.floats(1.0, 2.0),
    n=st.integers(3, 5),
    side=st.sampled_from([-0.55, 0.55]),
)
def test_a_lone_riser_is_carried_on_by_its_side_profile(rise, run, distance, n, side):
    """The staircase's first riser alone formed a plane; the ends of all ``n`` risers show
    on its side: the staircase has ``n`` steps, a run apart, at the first one's rise."""
    planes = _planes(n, rise, run, distance, missing=n - 1)
    without = build_terrain(planes, NO_SAMPLES)
    assert len(without.steps) == 1  # a box, or a one-step staircase
    lines = _with_edges(_side_profile(n, rise, run, distance, side))
    model = build_terrain(planes, NO_SAMPLES, lines=lines)
    assert model.obstacle == STAIRS and len(model.steps) == n
    for k, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + k * run, abs=0.01)
    assert all(s.rise_inferred for s in model.steps[1:])
    assert "risers' ends" in model.note
    off = build_terrain(planes, dataclasses.replace(NO_SAMPLES, riser_end_steps=False), lines=lines)
    assert len(off.steps) == 1


@pytest.mark.parametrize(
    "kind",
    ["door frames", "uneven runs", "far from the stairs", "beside the first riser only"],
)
def test_vertical_lines_that_are_no_profile_add_nothing(kind):
    """Edges taller than a rise (a door's frame, a wall's corner), ends whose runs differ
    by more than a quarter, a profile a metre beside the staircase, or one that does not
    start at its first riser are not its risers' ends."""
    rise, run, distance = 0.17, 0.29, 1.4
    planes = _planes(4, rise, run, distance, missing=3)
    edges = {
        "door frames": _side_profile(4, rise, run, distance, 0.55, span=0.9),
        "uneven runs": _side_profile(4, rise, run, distance, 0.55, runs=[0.2, 0.4, 0.2]),
        "far from the stairs": _side_profile(4, rise, run, distance, 1.6),
        "beside the first riser only": _side_profile(4, rise, run, distance + 0.3, 0.55),
    }[kind]
    model = build_terrain(planes, NO_SAMPLES, lines=_with_edges(edges))
    assert len(model.steps) == 1


def test_a_painted_staircase_counts_its_steps_by_their_ends():
    """Realistic render 38 of seed 57 (five painted steps of 16.5 cm seen 27 deg off their
    axis, with its rig): the chain the matcher's planes give ends after three steps (rise
    14.8 cm); the ends of all five risers show on the staircase's left side."""
    scene = _realistic(38, seed=57)
    assert len(scene.truth["steps"]) == 5
    config = PipelineConfig()
    result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == STAIRS
    assert len(result.terrain.steps) == 5
    assert "risers' ends" in result.terrain.note
    # (the ends' own staircase, asked last, now finds the five steps too: off as well)
    off_terrain = dataclasses.replace(config.terrain, riser_end_steps=False, ends_staircase=False)
    off = dataclasses.replace(config, terrain=off_terrain)
    before = Pipeline(scene.calibration, scene.rig, off, warm_up=False).run(scene.left, scene.right)
    assert len(before.terrain.steps) == 3


def test_edges_need_both_images():
    """Without the rectified pair (a terrain stage run on planes alone) there are no edges."""
    lines = ImageLines(np.array([[300.0, 150.0, 300.0, 350.0]]), FOCAL, CX, CY, SIZE, _camera(0.6))
    assert len(lines.vertical_edges.foot) == 0


def test_the_ends_heights_give_the_staircase_its_rise():
    """Where no nosings fit a rise, the staircase reports the one its risers' ends show
    (both images place them), not its first riser's measured top."""
    rise, run, distance = 0.17, 0.29, 1.4
    planes = _planes(4, rise, run, distance, missing=3)
    shown = 0.185  # the ends a centimetre and a half taller each
    model = build_terrain(planes, NO_SAMPLES, lines=_with_edges(_side_profile(4, shown, run, distance, 0.55)))
    assert len(model.steps) == 4
    assert [s.rise_m for s in model.steps] == pytest.approx([shown] * 4, abs=0.002)
    assert model.steps[0].measured_rise_m == pytest.approx(rise, abs=0.005)
    assert "risers' ends show" in model.note
