"""A staircase none of whose risers formed a plane, from its first riser's foot and nosing
as the image's lines show them (terrain/nosings/first_riser.py, TerrainConfig.lines_first_riser)."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.evaluation import score_result
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.pipeline.second_opinions import staircase_at_floor_edge, staircase_of_lines
from stereo_terrain.synthetic import random_scene_spec, render_scene
from stereo_terrain.terrain import NONE, STAIRS, TerrainConfig
from stereo_terrain.terrain.from_lines import floor_edge
from stereo_terrain.terrain.nosings import first_risers, line_axes
from stereo_terrain.terrain.nosings.view import parallel_segments

from .test_line_frame import _realistic
from .test_terrain_nosings import _lines, _segment, _stair_lines

HEIGHT = 0.6
CONFIG = TerrainConfig()


def _axes(yaw: float) -> tuple[np.ndarray, np.ndarray]:
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    return u, np.array([-u[1], u[0], 0.0])


@settings(max_examples=40, deadline=None)
@given(
    yaw=st.floats(-45.0, 45.0),
    rise=st.floats(0.12, 0.21),
    run=st.floats(0.22, 0.35),
    distance=st.floats(1.0, 2.2),
    n_steps=st.integers(2, 4),
)
def test_the_first_riser_is_its_foot_on_the_floor_and_the_nosing_over_it(yaw, rise, run, distance, n_steps):
    true_yaw = math.radians(yaw)
    lines = _lines(_stair_lines(n_steps, rise, run, distance, true_yaw, height=HEIGHT), HEIGHT)
    yaws = line_axes(lines)
    assert yaws, "the nosings show an axis"
    assert math.degrees(yaws[0] - true_yaw) == pytest.approx(0.0, abs=0.5)
    u, v = _axes(yaws[0])
    segs = parallel_segments(lines, v)
    assert segs is not None
    found = first_risers(lines, segs, u, v, 0.0, CONFIG)
    assert found, "the first riser shows"
    first = found[0]
    assert first.axis_position_m == pytest.approx(distance * math.cos(true_yaw), abs=0.02)
    assert first.top_z_m == pytest.approx(rise, abs=0.01)
    assert first.lateral[1] - first.lateral[0] == pytest.approx(1.0, abs=0.05)


def test_the_axis_points_away_from_the_cameras():
    """A line has no sign: the axis is the one up the stairs, whichever way it is yawed."""
    for yaw_deg in (-50.0, -20.0, 0.0, 30.0, 55.0):
        yaw = math.radians(yaw_deg)
        lines = _lines(_stair_lines(3, 0.17, 0.29, 1.5, yaw, height=HEIGHT), HEIGHT)
        assert math.degrees(line_axes(lines)[0] - yaw) == pytest.approx(0.0, abs=0.5)


def test_short_lines_show_no_axis():
    """Pieces shorter than a quarter of the image's width together are no staircase's."""
    blank = _lines(np.empty((0, 4)), HEIGHT)
    short = _segment(blank, 1.5, 0.17, 0.0, lateral=(-0.05, 0.05))
    assert line_axes(_lines(short[None], HEIGHT)) == []


def test_a_narrow_foot_is_no_first_riser():
    """A line on the floor narrower than ``MIN_WIDTH_M`` (a box's foot, a rug's edge) with
    a line over it is not taken."""
    blank = _lines(np.empty((0, 4)), HEIGHT)
    narrow = (-0.15, 0.15)
    segments = np.array(
        [_segment(blank, 1.5, 0.0, 0.0, lateral=narrow), _segment(blank, 1.5, 0.17, 0.0, lateral=narrow)]
    )
    lines = _lines(segments, HEIGHT)
    u, v = _axes(0.0)
    segs = parallel_segments(lines, v)
    assert segs is not None
    assert first_risers(lines, segs, u, v, 0.0, CONFIG) == []


def test_a_foot_without_a_nosing_over_it_is_no_first_riser():
    """A lone long line on the floor (a threshold, a rug's edge) has no riser over it."""
    blank = _lines(np.empty((0, 4)), HEIGHT)
    lines = _lines(_segment(blank, 1.5, 0.0, 0.0)[None], HEIGHT)
    u, v = _axes(0.0)
    segs = parallel_segments(lines, v)
    assert segs is not None
    assert first_risers(lines, segs, u, v, 0.0, CONFIG) == []


def test_a_painted_staircase_whose_risers_form_no_plane_is_found_from_its_lines():
    """Realistic 23 scene 0 with its rig: five painted steps of 12.4 / 31.3 cm, 1.43 m
    ahead, cameras 0.70 m up. No vertical plane looked like a riser (every pass found
    nothing); the image shows the first riser's foot and every nosing as lines, and the
    staircase is found from them (docs/benchmarks.md, "Forty-first session")."""
    scene = _realistic(0, 23)
    config = PipelineConfig()
    no_lines = dataclasses.replace(config.terrain, lines_first_riser=False)
    without = dataclasses.replace(config, terrain=no_lines)
    alone = Pipeline(scene.calibration, scene.rig, without, warm_up=False).run(scene.left, scene.right)
    assert alone.terrain.obstacle == NONE
    result = Pipeline(scene.calibration, scene.rig, config, warm_up=False).run(scene.left, scene.right)
    assert "from the image's lines" in result.terrain.note
    score = score_result(result.to_json_dict(), scene.truth)
    assert score.count_right, result.terrain.note
    assert max(score.rise_errors_m) <= 0.02
    assert result.terrain.steps[0].distance_m == pytest.approx(scene.truth["steps"][0]["distance"], abs=0.05)


def test_an_empty_realistic_view_stays_empty_and_says_it_looked():
    """Nothing found and the floor known (a rig): the lines are asked, find no staircase
    on a floor with walls (realistic, no obstacle), and the frame says what it cost."""
    scene = render_scene(random_scene_spec(np.random.default_rng(5), profile="realistic", kind="none"))
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == NONE
    assert "lines_staircase" in result.timing_ms


def test_a_staircase_found_from_its_risers_is_not_asked_of_the_lines():
    """The lines' staircase is the last resort: a frame that found an obstacle keeps it."""
    scene = render_scene(random_scene_spec(np.random.default_rng(3), kind="stairs"))
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert result.terrain.obstacle == STAIRS
    assert "lines_staircase" not in result.timing_ms
    assert "from the image's lines" not in result.terrain.note


def _ground(floor_along: np.ndarray, lateral: float = 0.4):
    """:func:`floor_edge`'s ``ground``: one floor plane at height 0 whose inliers lie at
    ``floor_along`` along the axis, spread across ``+-lateral``."""
    across = np.linspace(-lateral, lateral, len(floor_along))
    return [0.0], [np.asarray(floor_along, dtype=np.float64)], [across], 0.0


@settings(max_examples=60, deadline=None)
@given(
    height=st.floats(0.3, 0.7),
    foot=st.floats(0.9, 2.5),
    line_beyond=st.floats(0.15, 0.8),
    per_row=st.integers(8, 60),
    stray_share=st.floats(0.0, 0.015),
)
def test_the_floor_edge_is_where_the_floor_the_matcher_holds_ends(
    height, foot, line_beyond, per_row, stray_share
):
    """The floor's samples come row by row (a grid row every 5 px, sparser along the axis
    the farther it is) from the view's bottom to the first riser's foot; a few strays (a
    painted riser's samples along their rays, 1-2% on realistic 41 scenes 1 and 48) lie
    beyond it. The edge found in front of a line farther on (the first nosing met with the
    floor) is the foot, within a row or so."""
    f, cy, stride, bottom = 550.0, 240.0, 5.0, 475.0
    rows = np.arange(cy + height * f / foot, bottom, stride)
    along = np.repeat(height * f / (rows - cy), per_row)
    rng = np.random.default_rng(per_row)
    strays = foot + rng.uniform(0.0, 0.3, int(stray_share * len(along)))
    edge = floor_edge(_ground(np.concatenate([along, strays])), foot + line_beyond, (-0.5, 0.5), CONFIG)
    if len(along) < 4 * CONFIG.min_tread_points:
        assert edge is None
        return
    spacing = foot**2 * stride / (f * height)  # metres between the grid rows at the foot
    assert edge is not None
    assert foot - 1.5 * spacing - 0.01 <= edge <= foot + 0.01


def test_no_floor_edge_without_floor_or_next_to_the_line():
    """Too few floor samples give no edge, and an edge within half a short run of the line
    is the line's own foot (the line is the foot then)."""
    rng = np.random.default_rng(0)
    few = rng.uniform(0.5, 1.2, 4 * CONFIG.min_tread_points - 1)
    assert floor_edge(_ground(few), 1.6, (-0.5, 0.5), CONFIG) is None
    many = rng.uniform(0.5, 1.2, 400)
    assert floor_edge(_ground(many), 1.25, (-0.5, 0.5), CONFIG) is None
    assert floor_edge(_ground(many), 1.6, (-0.5, 0.5), CONFIG) == pytest.approx(1.2, abs=0.03)
    # Only the floor across the line's width counts (here a twelfth of it: too few).
    assert floor_edge(_ground(many, lateral=3.0), 1.6, (2.5, 3.0), CONFIG) is None


def test_a_painted_staircase_on_a_plank_floor_stands_where_the_floor_ends():
    """Realistic 41 scene 48 with its rig: two painted steps of 12.4 / 34.1 cm, 1.22 m
    ahead, on a plank floor. No pass found a riser; the first long line on the floor is the
    first nosing (met with the floor at 1.57 m), the riser's foot against the planks no
    line. The floor the matcher holds ends at the foot, and the nosings over it make the
    staircase (docs/benchmarks.md, "Forty-eighth session")."""
    scene = _realistic(48, 41)
    config = PipelineConfig()
    off = dataclasses.replace(config, terrain=dataclasses.replace(config.terrain, floor_edge_foot=False))
    kept = Pipeline(scene.calibration, scene.rig, off, warm_up=False).run(scene.left, scene.right)
    assert kept.terrain.obstacle == NONE, kept.terrain.note
    assert staircase_of_lines(kept, config).terrain.obstacle == NONE  # the lines' feet alone: none
    assert staircase_at_floor_edge(kept, off).terrain.obstacle == NONE  # turned off
    result = staircase_at_floor_edge(kept, config)
    assert "from the floor's edge and the image's lines" in result.terrain.note
    assert "floor_edge_staircase" in result.timing_ms
    score = score_result(result.to_json_dict(), scene.truth)
    assert score.count_right, result.terrain.note
    assert max(score.rise_errors_m) <= 0.015
    assert result.terrain.steps[0].distance_m == pytest.approx(scene.truth["steps"][0]["distance"], abs=0.05)


def test_a_plank_floors_joints_are_no_staircase_where_its_samples_stay_on_the_floor():
    """Realistic 37 scene 48 with its rig: an empty corridor with a plank floor. The floor
    formed two small planes only, so the floor's planes did not show it going on beyond a
    joint taken for a first riser's foot, and the joints beyond fit a pitch of three 15 cm
    steps. Every sample where those steps would stand lies at the floor's height: no
    staircase (docs/benchmarks.md, "Forty-eighth session")."""
    scene = _realistic(48, 37)
    assert scene.truth["obstacle"] == NONE
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    assert "lines_staircase" in result.timing_ms  # the lines were asked
    assert result.terrain.obstacle == NONE, result.terrain.note
