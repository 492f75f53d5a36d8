"""Steps beyond the last one where the image's line segments show their nosings
(terrain/nosings/): far risers that formed no plane and whose samples say nothing."""

import dataclasses

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.evaluation import score_result
from stereo_terrain.pipeline import Pipeline
from stereo_terrain.terrain import (
    STAIRS,
    ImageLines,
    TerrainConfig,
    build_terrain,
    estimate_step_sigmas,
    nosings,
)
from stereo_terrain.terrain.nosings import nosing_steps

from .test_line_frame import _realistic
from .test_terrain import CAM
from .test_terrain_continuation import _moved_samples, _unplaned

#: The samples' continuation off: the steps below can come from the lines alone.
NO_SAMPLES = TerrainConfig(continue_steps=False)
WIDTH = 1.0
SIZE = (640, 480)


def _camera(height: float = float(CAM[2])) -> np.ndarray:
    """A level camera at the frame's origin, ``height`` up, looking along +x (camera x
    right = frame -y, camera y down = frame -z)."""
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    T[:3, 3] = [0.0, 0.0, height]
    return T


def _lines(segments: np.ndarray, height: float = float(CAM[2])) -> ImageLines:
    return ImageLines(
        np.asarray(segments, dtype=np.float64).reshape(-1, 4), 500.0, 320.0, 240.0, SIZE, _camera(height)
    )


def _segment(
    lines: ImageLines, s: float, z: float, yaw: float, lateral=(-WIDTH / 2, WIDTH / 2)
) -> np.ndarray:
    """The image of the horizontal line at ``s`` along the stair axis and height ``z``."""
    u = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    ends = np.array([s * u + t * v + [0.0, 0.0, z] for t in lateral])
    uv, depth = lines.project(ends)
    assert (depth > 0).all()
    return uv.reshape(4)


def _stair_lines(
    n_steps: int,
    rise: float,
    run: float,
    distance: float,
    yaw: float = 0.0,
    *,
    feet=True,
    height=float(CAM[2]),
) -> np.ndarray:
    """Segments of every nosing (and riser foot) of the staircase."""
    blank = _lines(np.empty((0, 4)), height)
    segs = []
    for i in range(n_steps):
        s_i = distance * np.cos(yaw) + i * run
        segs.append(_segment(blank, s_i, (i + 1) * rise, yaw))
        if feet:
            segs.append(_segment(blank, s_i, i * rise, yaw))
    return np.array(segs)


def _along_x(steps, planes, segments):
    """:func:`nosing_steps` for a staircase along x, 1 m wide about y = 0, with ``segments``
    as the image's lines (the terrain config without the samples' continuation)."""
    u, v = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    P = planes.samples.points.astype(np.float64)
    return nosing_steps(steps, planes, P, u, v, (-0.5, 0.5), _lines(segments), NO_SAMPLES)


def _planes(
    n_steps: int,
    rise: float,
    run: float,
    distance: float,
    yaw: float = 0.0,
    missing: int = 2,
    height=float(CAM[2]),
):
    """The staircase whose last ``missing`` risers formed no plane; their samples moved far
    below the floor (so that nothing but the lines can show them), and every sample at the
    pixel where the camera sees it (the terrain stage looks for a landing in the image)."""
    return _with_pixels(_unplaned(n_steps, rise, run, distance, yaw, last=missing), height)


def _with_pixels(planes, height=float(CAM[2])):
    """``planes`` with the samples no plane took moved far below the floor, and every
    sample at the pixel where the camera sees it."""
    used = np.zeros(len(planes.samples.points), dtype=bool)
    for seg in planes.segments:
        used[seg.indices] = True
    planes = _moved_samples(planes, ~used, np.array([0.0, 0.0, -10.0]))
    uv, _ = _lines(np.empty((0, 4)), height).project(planes.samples.points.astype(np.float64))
    pixels = np.nan_to_num(np.round(uv), nan=-1e4).clip(-1e4, 1e4).astype(np.int32)
    samples = dataclasses.replace(planes.samples, cols=pixels[:, 0], rows=pixels[:, 1])
    return dataclasses.replace(planes, samples=samples)


def test_nosings_in_the_image_continue_the_staircase():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _planes(5, rise, run, distance)
    before = build_terrain(planes, NO_SAMPLES)
    assert before.obstacle == STAIRS and len(before.steps) == 3
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(_stair_lines(5, rise, run, distance)))
    assert model.obstacle == STAIRS and len(model.steps) == 5
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
    assert all(s.rise_inferred and s.tread is None for s in model.steps[3:])
    assert model.steps[3].rise_m == pytest.approx(rise, abs=0.005)
    assert model.steps[2].run_m == pytest.approx(run, abs=0.01)
    assert model.steps[-1].run_m is None
    assert "line segments show their nosings" in model.note
    assert len(model.polytope.faces) > len(before.polytope.faces)
    # Placed a run beyond the step before, not measured: no surer than that step.
    assert [s.position_inferred for s in model.steps] == [False, False, False, True, True]
    sig = estimate_step_sigmas(model, planes, focal_px=500.0, baseline_m=0.1).steps
    assert all(np.isfinite(s.distance_sigma_m) for s in sig)
    distance_sigmas = [s.distance_sigma_m for s in sig]
    assert distance_sigmas[2] <= distance_sigmas[3] <= distance_sigmas[4]


def test_no_lines_or_lines_only_where_the_steps_were_found_add_nothing():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _planes(5, rise, run, distance)
    none = build_terrain(planes, NO_SAMPLES, lines=_lines(np.empty((0, 4))))
    assert len(none.steps) == 3
    # The first three steps' nosings and feet only (6 segments).
    known = build_terrain(planes, NO_SAMPLES, lines=_lines(_stair_lines(5, rise, run, distance)[:6]))
    assert len(known.steps) == 3
    off = build_terrain(
        planes,
        TerrainConfig(continue_steps=False, nosing_steps=False),
        lines=_lines(_stair_lines(5, rise, run, distance)),
    )
    assert len(off.steps) == 3


def test_a_short_line_is_texture_not_a_nosing():
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _planes(4, rise, run, distance, missing=1)
    blank = _lines(np.empty((0, 4)))
    segs = list(_stair_lines(3, rise, run, distance))
    # The fourth nosing and foot, a fifth of the staircase's width long.
    s4 = distance + 3 * run
    segs.append(_segment(blank, s4, 4 * rise, 0.0, lateral=(0.0, 0.2)))
    segs.append(_segment(blank, s4, 3 * rise, 0.0, lateral=(0.0, 0.2)))
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(np.array(segs))).steps) == 3
    segs[-2] = _segment(blank, s4, 4 * rise, 0.0)  # the nosing across the staircase
    segs[-1] = _segment(blank, s4, 3 * rise, 0.0)
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(np.array(segs))).steps) == 4


def test_a_line_on_a_landing_without_a_riser_foot_is_no_step():
    """Cameras above the last tread see the next riser's foot: a line where the nosing
    would be with the floor (no foot line) under it is a tile joint or a far edge."""
    rise, run, distance = 0.15, 0.30, 1.2
    height = 0.9  # well above the treads: the foot of each riser is in view
    planes = _planes(4, rise, run, distance, missing=1, height=height)
    lines = _stair_lines(4, rise, run, distance, height=height)
    with_foot = build_terrain(planes, NO_SAMPLES, lines=_lines(lines, height))
    assert len(with_foot.steps) == 4
    without_foot = build_terrain(planes, NO_SAMPLES, lines=_lines(lines[:-1], height))
    assert len(without_foot.steps) == 3


def _clipped_to_view(segments: np.ndarray, margin: float = 8.0) -> np.ndarray:
    """Each segment cut to the image less ``margin`` pixels (as the lines' job clips those
    that reach the border); none of these runs along the border."""
    out = []
    lo = np.array([margin, margin])
    hi = np.array([SIZE[0] - 1 - margin, SIZE[1] - 1 - margin])
    for x1, y1, x2, y2 in segments:
        a, b = np.array([x1, y1]), np.array([x2, y2])
        t0, t1 = 0.0, 1.0
        for k in range(2):
            d = b[k] - a[k]
            if abs(d) < 1e-12:
                continue
            ta, tb = sorted(((lo[k] - a[k]) / d, (hi[k] - a[k]) / d))
            t0, t1 = max(t0, ta), min(t1, tb)
        if t1 > t0:
            out.append(np.concatenate([a + t0 * (b - a), a + t1 * (b - a)]))
    return np.array(out)


def test_a_staircase_wider_than_the_view_is_continued_by_its_clipped_nosings():
    """Nosings that run out of the image on both sides reach the lines' job only clipped at
    the border (``ImageLines.at_border``); they continue the staircase as whole ones do."""
    rise, run, distance = 0.17, 0.29, 1.3
    planes = _planes(5, rise, run, distance)
    blank = _lines(np.empty((0, 4)))
    wide = []
    for i in range(5):
        s_i = distance + i * run
        for z in ((i + 1) * rise, i * rise):
            wide.append(_segment(blank, s_i, z, 0.0, lateral=(-4.0, 4.0)))
    clipped = _clipped_to_view(np.array(wide))
    assert len(clipped) == 10
    assert (clipped[:, [0, 2]].min() < 10) and (clipped[:, [0, 2]].max() > SIZE[0] - 11)
    at_border = dataclasses.replace(_lines(np.empty((0, 4))), at_border=clipped)
    model = build_terrain(planes, NO_SAMPLES, lines=at_border)
    assert model.obstacle == STAIRS and len(model.steps) == 5
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)


def test_the_nosing_nearest_where_the_next_one_should_be_is_taken():
    """Two lines across the staircase within the run's tolerance: the next nosing, and a
    line three tenths of a step beyond it (a tread's far edge, a strip on the landing),
    listed first. The nearer to where the next nosing should be is the one tested; the
    other, with no riser foot under it, would stop the staircase."""
    rise, run, distance = 0.15, 0.30, 1.2
    height = 0.9  # above the treads: each riser's foot is in view and must show
    planes = _planes(5, rise, run, distance, missing=2, height=height)
    blank = _lines(np.empty((0, 4)), height)
    beyond = _segment(blank, distance + 3.3 * run, 4.3 * rise, 0.0)  # 1.3 steps after the 3rd
    lines = np.vstack([beyond[None], _stair_lines(5, rise, run, distance, height=height)])
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(lines, height))
    assert len(model.steps) == 5
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
    # Without the next nosing and its foot, the line beyond is no step.
    alone = np.vstack([beyond[None], _stair_lines(3, rise, run, distance, height=height)])
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(alone, height)).steps) == 3


def test_a_wider_line_with_no_riser_foot_under_it_gives_way_to_the_nosing_nearer():
    """The widest line across the staircase within the run's tolerance is no nosing when no
    riser foot shows under it (a tread's far edge, a rail beyond): the lines nearer where
    the next nosing should be are tried next. Here the next nosing shows over 60% of the
    width (a baluster or a blurred end hides the rest), the line 1.3 steps on over all of
    it (the real Middlebury `Staircase` at 0.8 px of blur, benchmarks/bench_staircase_webcam.py)."""
    rise, run, distance = 0.15, 0.30, 1.2
    height = 0.9  # above the treads: each riser's foot is in view and must show
    planes = _planes(5, rise, run, distance, missing=2, height=height)
    blank = _lines(np.empty((0, 4)), height)
    beyond = _segment(blank, distance + 3.3 * run, 4.3 * rise, 0.0)  # 1.3 steps after the 3rd
    full = _stair_lines(5, rise, run, distance, height=height)
    part = _segment(blank, distance + 3 * run, 4 * rise, 0.0, lateral=(-0.3, 0.3))  # the 4th nosing
    lines = np.vstack([beyond[None], full[:6], part[None], full[7:]])
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(lines, height))
    assert len(model.steps) == 5
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
    # The narrower nosing alone, without the foot of its riser, is no step either.
    no_foot = np.vstack([beyond[None], full[:6], part[None]])
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(no_foot, height)).steps) == 3


def test_a_line_across_the_view_at_the_cameras_height_is_no_nosing(monkeypatch):
    """A nosing a centimetre below the cameras is a line through the view less than a
    degree from their horizon, where the horizon or a far wall's foot draw the same line.
    Reaching the border, it is not taken for a nosing; whole (the staircase's sides in
    view), it is."""
    rise, run, distance = 0.17, 0.29, 1.3
    height = 4 * rise + 0.01  # the fourth nosing 1 cm below the cameras, 2.2 m away
    planes = _planes(4, rise, run, distance, missing=1, height=height)
    lines = _stair_lines(4, rise, run, distance, height=height)
    fourth = lines[6]
    assert abs(fourth[1] - 240.0) < 3 and abs(fourth[3] - 240.0) < 3
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(lines, height)).steps) == 4
    across = _clipped_to_view(np.array([[-2000.0, fourth[1], 3000.0, fourth[3]]]))
    border = dataclasses.replace(_lines(np.delete(lines, 6, axis=0), height), at_border=across)
    assert len(build_terrain(planes, NO_SAMPLES, lines=border).steps) == 3
    # It is the horizon's rule that leaves it out: without it the clipped line is taken.
    monkeypatch.setattr(nosings.view, "HORIZON_DEG", 0.0)
    assert len(build_terrain(planes, NO_SAMPLES, lines=border).steps) == 4


def test_the_nosing_after_one_at_the_cameras_height_continues_the_staircase():
    """A nosing at the cameras' height is seen edge-on: its tread is no taller than a line,
    and the riser above meets it there, so no segment tells it from the horizon. The next
    nosing, a step further along the pitch line, continues the staircase by two steps;
    where the missing nosing is not at the cameras' height, a line two steps on adds
    nothing."""
    rise, run, distance = 0.17, 0.29, 1.3
    height = 4 * rise  # the fourth nosing and the fifth riser's foot at the cameras' height
    planes = _planes(5, rise, run, distance, missing=2, height=height)
    lines = _stair_lines(5, rise, run, distance, height=height)
    # Segments 6 and 7: the fourth nosing and foot; 8 and 9: the fifth's.
    assert abs(lines[6][1] - 240.0) < 0.5 and abs(lines[9][1] - 240.0) < 0.5
    seen = np.delete(lines, [6, 9], axis=0)
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(seen, height))
    assert model.obstacle == STAIRS and len(model.steps) == 5
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
    assert all(s.rise_inferred and s.position_inferred for s in model.steps[3:])
    # Without the fifth nosing nothing shows beyond the third step.
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(seen[:-1], height)).steps) == 3
    # Cameras well above the fourth nosing see its tread: its line is asked for, not skipped.
    high = 4 * rise + 0.3
    planes = _planes(5, rise, run, distance, missing=2, height=high)
    lines = _stair_lines(5, rise, run, distance, height=high)
    seen = np.delete(lines, [6, 9], axis=0)
    assert len(build_terrain(planes, NO_SAMPLES, lines=_lines(seen, high)).steps) == 3


def test_nosing_config_is_checked():
    for name in ("nosing_run_tolerance", "nosing_min_cover", "nosing_min_foot_cover"):
        for bad in (0.0, 1.0, -0.1):
            with pytest.raises(ConfigError, match=name):
                TerrainConfig(**{name: bad})
    with pytest.raises(ConfigError, match="max_nosing_steps"):
        TerrainConfig(max_nosing_steps=-1)


@settings(max_examples=25, deadline=None)
@given(
    yaw=st.floats(-0.7, 0.7),
    rise=st.floats(0.13, 0.2),
    run=st.floats(0.25, 0.34),
    distance=st.floats(1.0, 1.6),
)
def test_added_steps_stand_where_the_staircase_does(yaw, rise, run, distance):
    """Whatever the yaw and size, each step the lines add is a true step (within 2 cm) and
    no more are added than the staircase has."""
    planes = _planes(5, rise, run, distance, yaw)
    base = build_terrain(planes, NO_SAMPLES)
    if base.obstacle != STAIRS or len(base.steps) != 3:
        return  # the planes alone did not give the three steps this test extends
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(_stair_lines(5, rise, run, distance, yaw)))
    assert 3 <= len(model.steps) <= 5
    s0 = distance * np.cos(yaw)
    for i, step in enumerate(model.steps):
        assert step.axis_position_m == pytest.approx(s0 + i * run, abs=0.02)


def test_a_lone_step_is_continued_only_where_two_nosings_beyond_it_agree_on_a_run():
    """A single step has no run to say where the next nosing is: the run that puts two
    nosings beyond it (each line across the staircase) is taken; one line is not enough."""
    rise, run, distance = 0.16, 0.31, 1.2
    planes = _planes(4, rise, run, distance, missing=3)
    alone = build_terrain(planes, NO_SAMPLES)
    assert len(alone.steps) == 1
    lines = _stair_lines(4, rise, run, distance)
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(lines))
    assert model.obstacle == STAIRS and len(model.steps) == 4
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.02)
    one_more = build_terrain(planes, NO_SAMPLES, lines=_lines(lines[:4]))  # nosing and foot of step 2 only
    assert len(one_more.steps) == 1


def test_lines_on_a_landing_the_samples_see_are_no_step():
    """Tile joints on a landing where a fourth nosing and its riser's foot would be: the
    samples in the image of that riser lie on the landing, so no step is added there."""
    rise, run, distance, height = 0.17, 0.29, 1.3, 0.9
    planes = _planes(3, rise, run, distance, missing=0, height=height)
    lines = _stair_lines(4, rise, run, distance, height=height)  # the fourth: tile joints
    model = build_terrain(planes, NO_SAMPLES, lines=_lines(lines, height))
    assert model.obstacle == STAIRS and len(model.steps) == 3


def _fourth_riser_matched_beyond(rise: float, run: float, distance: float, height: float, standing: bool):
    """A four-step staircase whose fourth riser formed no plane, its samples placed where a
    matcher biased beyond it puts them: every fourth along its ray down to the third
    tread's height, the others 20 cm further along their rays (``standing``) or none (out
    of the image). Every sample keeps the pixel where the camera sees its true point."""
    planes = _unplaned(4, rise, run, distance, last=1)
    P = planes.samples.points.astype(np.float64)
    uv, _ = _lines(np.empty((0, 4)), height).project(P)
    pixels = np.nan_to_num(np.round(uv), nan=-1e4).clip(-1e4, 1e4).astype(np.int32)
    used = np.zeros(len(P), dtype=bool)
    for seg in planes.segments:
        used[seg.indices] = True
    riser = np.flatnonzero(~used & (np.abs(P[:, 0] - (distance + 3 * run)) < 1e-3))
    assert len(riser) > 100
    centre = np.array([0.0, 0.0, height])
    out = P.copy()
    out[~used] += [0.0, 0.0, -10.0]  # the landing on it: nothing (as _planes)
    floor, rest = riser[::4], np.setdiff1d(riser, riser[::4])
    ray = P[floor] - centre
    out[floor] = centre + ray * ((3 * rise - height) / ray[:, 2])[:, None]
    if standing:
        ray = P[rest] - centre
        out[rest] = centre + ray * (1.0 + 0.2 / ray[:, 0])[:, None]
    else:
        pixels[rest] = -10_000
    samples = dataclasses.replace(
        planes.samples, points=out.astype(np.float32), cols=pixels[:, 0], rows=pixels[:, 1]
    )
    return dataclasses.replace(planes, samples=samples)


def test_a_riser_the_matcher_put_beyond_its_place_is_no_landing():
    """The fourth nosing and its foot show. The samples in the image of its riser that lie
    on the third tread's height beyond it stop the staircase there as a landing's would,
    unless more of them stand above the tread (a riser, wherever the matcher put it)."""
    rise, run, distance, height = 0.17, 0.29, 1.3, 0.9
    lines = _lines(_stair_lines(4, rise, run, distance, height=height), height)
    standing = _fourth_riser_matched_beyond(rise, run, distance, height, standing=True)
    model = build_terrain(standing, NO_SAMPLES, lines=lines)
    assert model.obstacle == STAIRS and len(model.steps) == 4
    assert model.steps[-1].distance_m == pytest.approx(distance + 3 * run, abs=0.02)
    floor_only = _fourth_riser_matched_beyond(rise, run, distance, height, standing=False)
    assert len(build_terrain(floor_only, NO_SAMPLES, lines=lines).steps) == 3


def test_a_double_step_is_split_where_the_image_shows_the_nosing_between():
    """A riser that formed no plane between two that did makes one step of two: twice the
    rise after twice the run. The nosing between in the image splits it; without that line
    it stays a double step."""
    rise, run, distance = 0.16, 0.30, 1.2
    planes = _planes(5, rise, run, distance, missing=0)
    found = list(build_terrain(planes, NO_SAMPLES).steps)
    assert len(found) == 5
    # The chain as it is when the third riser formed no plane.
    double = [
        found[0],
        dataclasses.replace(found[1], run_m=2 * run),
        dataclasses.replace(found[3], rise_m=2 * rise),
        found[4],
    ]
    lines = _stair_lines(5, rise, run, distance)
    steps, added, split = _along_x(double, planes, lines)
    assert (len(steps), added, split) == (5, 0, 1)
    for i, step in enumerate(steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
        assert step.rise_m == pytest.approx(rise, abs=0.01)
    assert steps[2].rise_inferred and steps[3].rise_inferred
    without = np.delete(lines, [4, 5], axis=0)  # the third nosing and its riser's foot
    steps, _, split = _along_x(double, planes, without)
    assert len(steps) == 4 and split == 0


def test_a_staircase_of_every_other_riser_is_split_where_the_nosings_between_show():
    """Every other riser formed a plane: three steps of twice the rise and run, taller than a
    stair rise (``max_rise_m``). With the nosings between in the image each is split, the
    first with a step in front of it; without them nothing changes."""
    rise, run, distance = 0.17, 0.28, 1.2
    planes = _planes(6, rise, run, distance, missing=0)
    found = list(build_terrain(planes, NO_SAMPLES).steps)
    assert len(found) == 6
    doubled = [
        dataclasses.replace(found[k], rise_m=2 * rise, run_m=None if k == 5 else 2 * run) for k in (1, 3, 5)
    ]
    assert all(s.rise_m > NO_SAMPLES.max_rise_m for s in doubled)
    lines = _stair_lines(6, rise, run, distance)
    steps, added, split = _along_x(doubled, planes, lines)
    assert (len(steps), added, split) == (6, 0, 3)
    for i, step in enumerate(steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
        assert step.rise_m == pytest.approx(rise, abs=0.01)
    # The nosings of the steps found only (their risers' feet, from below, are the nosings
    # between: the cameras are lower than those treads).
    odd = lines[[2, 6, 10]]
    steps, _, split = _along_x(doubled, planes, odd)
    assert len(steps) == 3 and split == 0


@settings(max_examples=40, deadline=None)
@given(
    yaw=st.floats(-3.1, 3.1),
    pitch=st.floats(-0.5, 0.5),
    x=st.floats(0.0, 639.0),
    y=st.floats(0.0, 479.0),
    depth=st.floats(0.3, 6.0),
)
def test_image_lines_rays_and_projection_agree(yaw, pitch, x, y, depth):
    """A point on the ray through a pixel projects back onto that pixel, whatever the
    camera's pose in the terrain frame."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    T = _camera(0.5)
    T[:3, :3] = Rz @ Ry @ T[:3, :3]
    lines = ImageLines(np.empty((0, 4)), 480.0, 320.0, 240.0, SIZE, T)
    ray = lines.rays(np.array([[x, y]]))[0]
    point = lines.centre + depth * ray  # the ray's z in the camera is 1: depth is camera z
    uv, z = lines.project(point[None, :])
    assert z[0] == pytest.approx(depth, rel=1e-9)
    assert uv[0] == pytest.approx([x, y], abs=1e-6)


def _stair_image(n_steps, rise, run, distance, height, *, tread=150.0, riser=110.0, seed=0):
    """A grey image of the staircase (1 m wide about y = 0, along x) from the level camera
    ``height`` up: treads and risers of two shades, the rest mid grey, sensor noise."""
    rng = np.random.default_rng(seed)
    img = 130.0 + rng.normal(0.0, 2.0, (SIZE[1], SIZE[0]))
    blank = _lines(np.empty((0, 4)), height)
    w = WIDTH / 2
    for i in reversed(range(n_steps)):  # far first: nearer faces are drawn over them
        s, z = distance + i * run, i * rise
        faces = (
            ([[s + run, -w, z + rise], [s, -w, z + rise], [s, w, z + rise], [s + run, w, z + rise]], tread),
            ([[s, -w, z], [s, -w, z + rise], [s, w, z + rise], [s, w, z]], riser),
        )
        for quad, grey in faces:
            uv, depth = blank.project(np.array(quad, dtype=np.float64))
            if (depth > 0).all():
                cv2.fillPoly(img, [np.round(uv * 16).astype(np.int32)], grey, cv2.LINE_AA, 4)
    return np.clip(img, 0, 255).astype(np.uint8)


def test_a_nosing_no_segment_shows_is_found_as_an_edge_in_the_image():
    """LSD keeps only lines it is sure of: a faint nosing may give it none. The image's
    grey levels still show each nosing as a step edge: with the rectified image and no
    segments at all, the staircase is continued to its five steps; with a noise image
    (no edges), or the edge search off, it is not."""
    rise, run, distance = 0.17, 0.29, 1.3
    height = 1.2  # well above the treads: each riser foot shows apart from the nosings
    planes = _planes(5, rise, run, distance, height=height)
    none = np.empty((0, 4))
    image = _stair_image(5, rise, run, distance, height)
    lines = dataclasses.replace(_lines(none, height), image=image)
    model = build_terrain(planes, NO_SAMPLES, lines=lines)
    assert model.obstacle == STAIRS and len(model.steps) == 5
    for i, step in enumerate(model.steps):
        assert step.distance_m == pytest.approx(distance + i * run, abs=0.01)
    off = dataclasses.replace(NO_SAMPLES, nosing_edge_contrast=0.0)
    assert len(build_terrain(planes, off, lines=lines).steps) == 3
    noise = np.random.default_rng(1).normal(128.0, 12.0, image.shape).clip(0, 255).astype(np.uint8)
    assert len(build_terrain(planes, NO_SAMPLES, lines=dataclasses.replace(lines, image=noise)).steps) == 3
    # A landing beyond the third step (no riser): its far edge is no step.
    flat = _stair_image(3, rise, run, distance, height)
    assert len(build_terrain(planes, NO_SAMPLES, lines=dataclasses.replace(lines, image=flat)).steps) == 3


def test_a_foot_no_segment_shows_is_found_as_an_edge_in_the_image():
    """The next nosing's segment is there and its riser's foot gave LSD none: without the
    image that is a landing's edge (no step); with it, the foot shows as the opposite
    edge and the step is added; an image of a landing there (three steps drawn) adds
    none."""
    rise, run, distance = 0.15, 0.30, 1.2
    height = 0.9
    planes = _planes(4, rise, run, distance, missing=1, height=height)
    segs = _stair_lines(4, rise, run, distance, height=height)[:-1]  # the last foot missing
    lines = _lines(segs, height)
    assert len(build_terrain(planes, NO_SAMPLES, lines=lines).steps) == 3
    image = _stair_image(4, rise, run, distance, height)
    model = build_terrain(planes, NO_SAMPLES, lines=dataclasses.replace(lines, image=image))
    assert len(model.steps) == 4
    assert model.steps[3].distance_m == pytest.approx(distance + 3 * run, abs=0.01)
    landing = _stair_image(3, rise, run, distance, height)
    assert len(build_terrain(planes, NO_SAMPLES, lines=dataclasses.replace(lines, image=landing)).steps) == 3


def test_a_realistic_staircase_is_not_stopped_by_its_riser_matched_beyond_it():
    """Realistic 23 scene 50 (planks, six steps of 14.7 cm from 0.87 m, cameras 0.49 m up):
    the matcher put the third riser's samples beyond it, some down to the second tread's
    height; they stopped the staircase at two steps. With the samples that stand above the
    tread counted, its nosings carry it to all six (docs/benchmarks.md, "Thirty-eighth
    session")."""
    scene = _realistic(50, 23)
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    truth = scene.truth["steps"]
    assert result.terrain.obstacle == STAIRS and len(result.terrain.steps) == len(truth) == 6
    for step, true in zip(result.terrain.steps, truth, strict=True):
        assert step.rise_m == pytest.approx(true["rise"], abs=0.015)
        assert step.distance_m == pytest.approx(true["distance"], abs=0.1)


def test_the_next_nosing_is_looked_for_across_the_narrowest_riser():
    """Realistic 23 scene 6 with its rig (carpet, five steps of 21.9 / 25.6 cm yawed 37
    deg): one of its riser planes runs on over the wall beside the stairs, and across the
    chain's whole lateral extent the fifth nosing covered too little of the width (four
    steps). Looked for across the narrowest riser plane, it is found (docs/benchmarks.md,
    "Fortieth session")."""
    scene = _realistic(6, 23)
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    score = score_result(result.to_json_dict(), scene.truth)
    assert score.count_right, result.terrain.note
    assert len(score.rise_errors_m) == len(scene.truth["steps"]) == 5
    assert max(score.rise_errors_m) <= 0.025
    assert max(score.run_errors_m) <= 0.025
