"""The state estimator's frame jumps (glitch, relocalisation) are no travel
(stereo_terrain/odometry.py), judged with the poses' own stamps."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.odometry import Odometry, PoseJumpConfig, PoseJumps
from stereo_terrain.runtime.loop import track_and_trigger
from stereo_terrain.swing import SwingTrigger
from stereo_terrain.tracking import StairTracker

from .test_tracking import frame_model


def _xy(odo: Odometry) -> np.ndarray:
    return np.array(odo.position_m[:2])


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(
        st.tuples(
            st.floats(0.005, 0.3), st.floats(0.0, 3.0), st.floats(-math.pi, math.pi), st.floats(-1.5, 1.5)
        ),
        min_size=2,
        max_size=40,
    )
)
def test_walking_and_turning_within_the_limits_is_never_a_jump(steps):
    """(dt, speed, direction, turn rate): any walk the body can make comes out unchanged."""
    jumps = PoseJumps()
    x, y, yaw, t = 0.3, -0.2, 0.1, 100.0
    for dt, speed, direction, rate in steps:
        t += dt
        x += speed * dt * math.cos(direction)
        y += speed * dt * math.sin(direction)
        yaw += rate * dt
        pose = Odometry((x, y, 0.4), yaw, t)
        out = jumps.correct(pose)
        assert out is not None
        assert out.position_m == pytest.approx(pose.position_m, abs=1e-9)
        assert math.cos(out.yaw_rad - pose.yaw_rad) == pytest.approx(1.0, abs=1e-12)
    assert jumps.jumps == 0


def _walk(shift_at, n=40, v=0.5, dt=0.1, skip=()):
    """Stamped poses of a body walking along x at ``v``; ``shift_at(k)`` is the estimator's
    error at pose k (dx, dy, dyaw). Returns (true x, corrected pose) per pose."""
    jumps, out = PoseJumps(), []
    for k in range(n):
        if k in skip:
            continue
        t, x = k * dt, v * k * dt
        dx, dy, dyaw = shift_at(k)
        c, s = math.cos(dyaw), math.sin(dyaw)
        raw = Odometry((c * x + dx, s * x + dy, 0.4), dyaw, t)
        out.append((x, jumps.correct(raw)))
    return jumps, out


def test_a_one_pose_glitch_is_taken_out():
    """Found in review: a +2 m glitch on one pose latched the raised swing 0.9 m early."""
    jumps, out = _walk(lambda k: (2.0, 0.0, 0.0) if k == 12 else (0.0, 0.0, 0.0))
    assert jumps.jumps == 1  # there; the way back returns to the frame from before it
    for x, pose in out:
        assert pose.position_m[0] == pytest.approx(x, abs=0.01)


@pytest.mark.parametrize("turn_deg", [0.0, 30.0])
def test_a_relocalisation_is_taken_out_and_the_origin_goes_back_into_the_estimators_frame(turn_deg):
    """Found in review: a relocalisation 1 m back near the stairs put the trigger 1 m late.
    The frame may also turn; the walk goes on continuously in the corrected frame, and a
    point of it maps into the estimator's frame as the estimator now places it."""
    turn = math.radians(turn_deg)
    jumps, out = _walk(lambda k: (-1.0, 0.3, turn) if k >= 25 else (0.0, 0.0, 0.0))
    assert jumps.jumps == 1
    for x, pose in out:
        assert _xy(pose) == pytest.approx([x, 0.0], abs=0.01)
        assert pose.yaw_rad == pytest.approx(0.0, abs=1e-9)
    # The origin 1.0 m along x in the corrected frame is, in the estimator's frame now,
    # where it puts the body when the body is there.
    p0, heading = jumps.to_raw((1.0, 0.0, 0.4), 0.0)
    c, s = math.cos(turn), math.sin(turn)
    assert p0 == pytest.approx((c * 1.0 - 1.0, s * 1.0 + 0.3, 0.4), abs=0.01)
    assert heading == pytest.approx(turn, abs=1e-9)


def test_a_camera_stall_keeps_its_travel():
    """The first rule (0.5 m a step, no time) took the 0.55 m walked in a 1.1 s camera
    stall for a jump: the swing was raised 0.5 m past the riser."""
    jumps, out = _walk(lambda k: (0.0, 0.0, 0.0), skip=tuple(range(18, 29)))
    assert jumps.jumps == 0
    for x, pose in out:
        assert pose.position_m[0] == pytest.approx(x, abs=1e-9)


def test_poses_without_a_stamp_are_not_judged():
    jumps = PoseJumps()
    assert jumps.correct(Odometry((0.0, 0.0, 0.0))).position_m == (0.0, 0.0, 0.0)
    assert jumps.correct(Odometry((2.0, 0.0, 0.0))).position_m == (2.0, 0.0, 0.0)
    assert jumps.jumps == 0
    assert jumps.correct(None) is None
    nan = Odometry((math.nan, 0.0, 0.0), 0.0, 1.0)
    assert jumps.correct(nan) is nan
    off = PoseJumps(PoseJumpConfig(enabled=False))
    off.correct(Odometry((0.0, 0.0, 0.0), 0.0, 0.0))
    assert off.correct(Odometry((2.0, 0.0, 0.0), 0.0, 0.1)).position_m == (2.0, 0.0, 0.0)


def test_bad_stamps_and_config_are_refused():
    with pytest.raises(InputError, match="stamp_s"):
        Odometry((0.0, 0.0, 0.0), 0.0, math.nan)
    with pytest.raises(InputError, match="stamp_s"):
        Odometry((0.0, 0.0, 0.0), 0.0, "noon")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="max_speed_mps"):
        PoseJumpConfig(max_speed_mps=0.0)


def _approach(odometry_at, *, tracking, frames=30, step_m=0.05, skip_frames=(), correct=True):
    """Frames 0.1 s apart walking toward stairs 2 m ahead through ``PoseJumps`` and
    ``track_and_trigger`` as the live loop does; then controller ticks, stamped, in the
    last frame's estimator frame. Returns the true x where the swing was raised, or None."""
    rng = np.random.default_rng(9)
    tracker, trigger = (StairTracker() if tracking else None), SwingTrigger()
    jumps = PoseJumps(PoseJumpConfig(enabled=correct))
    d_first, shift = 2.0, 0.0
    for k in range(frames):
        x = step_m * k
        if k in skip_frames:
            continue
        raw = odometry_at(k, x)
        shift = raw.position_m[0] - x
        m = frame_model(rng, d_first - x, skip=1 if d_first - x < 0.6 else 0)
        _, _, trig = track_and_trigger(tracker, trigger, m, jumps.correct(raw), k / 10)
        if trig.raise_swing:
            return x
    x, t = step_m * (frames - 1), (frames - 1) / 10
    while x < d_first + 1.0:
        x, t = x + 0.001, t + 0.002
        if trigger.update(jumps.correct(Odometry((x + shift, 0.0, 0.0), 0.0, t))).raise_swing:
            return x
    return None


@pytest.mark.parametrize(
    ("odometry_at", "skip_frames"),
    [
        (lambda k, x: Odometry((x + (2.0 if k == 12 else 0.0), 0.0, 0.0), 0.0, k / 10), ()),
        (lambda k, x: Odometry((x - (1.0 if k >= 25 else 0.0), 0.0, 0.0), 0.0, k / 10), ()),
        (lambda k, x: Odometry((x, 0.0, 0.0), 0.0, k / 10), tuple(range(18, 29))),
    ],
    ids=["glitch", "relocalisation", "stall"],
)
@pytest.mark.parametrize("tracking", [True, False])
def test_the_swing_is_raised_where_the_stairs_are_through_jumps_and_stalls(
    odometry_at, skip_frames, tracking
):
    x = _approach(odometry_at, tracking=tracking, skip_frames=skip_frames)
    assert x is not None and abs(x - (2.0 - SwingTrigger().swing.buffer_m)) < 0.03


@pytest.mark.parametrize("case", ["glitch", "relocalisation"])
def test_without_the_correction_the_swing_is_raised_in_the_wrong_place(case):
    """The cases above are ones that fail without :class:`PoseJumps` (so the test can
    fail): the glitch raises the swing early, the relocalisation late."""
    shift = (lambda k: 2.0 if k == 12 else 0.0) if case == "glitch" else (lambda k: -1.0 if k >= 25 else 0.0)
    # (with tracking: without it, the frames after the relocalisation re-measure the stairs
    # and the trigger starts again from them)
    x = _approach(lambda k, x: Odometry((x + shift(k), 0.0, 0.0), 0.0, k / 10), tracking=True, correct=False)
    assert x is None or abs(x - (2.0 - SwingTrigger().swing.buffer_m)) > 0.3


@pytest.mark.parametrize(("glitch_m", "dropped"), [(2.0, 7), (0.6, 1), (1.0, 3)])
def test_a_glitch_followed_by_a_stall_returns_to_the_frame_before_it(glitch_m, dropped):
    """Found in review of the first version: the way back of a glitch after a stall (the
    next pose comes late, so the step back fits the time) was taken for travel back, and
    the glitch stayed as a shift (the swing raised 0.28 m late)."""
    skip = tuple(range(13, 13 + dropped))
    jumps, out = _walk(lambda k: (glitch_m, 0.0, 0.0) if k == 12 else (0.0, 0.0, 0.0), skip=skip)
    assert jumps.jumps == 1
    for x, pose in out:
        assert pose.position_m[0] == pytest.approx(x, abs=0.01)


def test_stamps_that_do_not_advance_or_are_too_close_are_not_judged(caplog):
    """Found in review: a source that never sets its stamps (LCM utime 0) or gives
    milliseconds where seconds are read made every stall a jump (the travel in it lost)."""
    for scale in (0.0, 1e-3):
        jumps = PoseJumps()
        for k in range(40):
            x = 0.05 * k + (0.55 if k >= 25 else 0.0)  # a 1.1 s stall's travel at pose 25
            t = scale * (k + (11 if k >= 25 else 0)) * 0.1
            assert jumps.correct(Odometry((x, 0.0, 0.0), 0.0, t)).position_m[0] == pytest.approx(x)
    assert "stamps do not advance" in caplog.text and "too close together" in caplog.text


def test_a_late_pose_is_dropped_and_a_restarted_clock_judges_again(caplog):
    jumps = PoseJumps()
    for k in range(10):
        jumps.correct(Odometry((0.05 * k, 0.0, 0.0), 0.0, 100.0 + 0.1 * k))
    # a pose from before the last one, delivered late: no pose (not a step back)
    assert jumps.correct(Odometry((0.3, 0.0, 0.0), 0.0, 100.75)) is None and jumps.late == 1
    # the estimator restarted its clock: judged again from here
    restarted = jumps.correct(Odometry((0.5, 0.0, 0.0), 0.0, 0.0))
    assert restarted.position_m[0] == pytest.approx(0.5) and "went back" in caplog.text
    after = jumps.correct(Odometry((-0.45, 0.0, 0.0), 0.0, 0.1))  # then relocalised 1 m back
    assert after.position_m[0] == pytest.approx(0.55, abs=0.01) and jumps.jumps == 1


def test_a_one_pose_glitch_never_reaches_the_published_origin():
    """Found in the second review: the origin published in the estimator's frame took the
    glitch's shift at once, and a controller whose own odometry never glitched counted the
    glitch as travel (raised up to 1.6 m early). A new shift is published once the pose
    after the jump confirms it."""
    jumps = PoseJumps()
    for k in range(12):
        jumps.correct(Odometry((0.05 * k, 0.0, 0.0), 0.0, 0.1 * k))
    jumps.correct(Odometry((0.6 - 2.0, 0.0, 0.0), 0.0, 1.2))  # a backward glitch
    assert jumps.jumps == 1
    assert jumps.to_raw((1.0, 0.0, 0.0), 0.0)[0] == pytest.approx((1.0, 0.0, 0.0))
    jumps.correct(Odometry((0.65, 0.0, 0.0), 0.0, 1.3))  # back: the glitch's shift never published
    assert jumps.to_raw((1.0, 0.0, 0.0), 0.0)[0] == pytest.approx((1.0, 0.0, 0.0))
    jumps.correct(Odometry((0.7 - 1.0, 0.0, 0.0), 0.0, 1.4))  # a relocalisation 1 m back ...
    jumps.correct(Odometry((0.75 - 1.0, 0.0, 0.0), 0.0, 1.5))  # ... confirmed by the next pose
    assert jumps.to_raw((1.0, 0.0, 0.0), 0.0)[0] == pytest.approx((0.0, 0.0, 0.0), abs=0.01)


def test_a_clock_stepped_back_while_walking_is_not_a_late_pose():
    """Found in the second review: a wall clock set back 2 s made every pose for 2 s a late
    one (dropped), and the travel in it a jump. A pose ahead of the last with an earlier
    stamp is a clock step: judged from there."""
    jumps = PoseJumps()
    for k in range(10):
        jumps.correct(Odometry((0.05 * k, 0.0, 0.0), 0.0, 100.0 + 0.1 * k))
    for k in range(10, 30):
        out = jumps.correct(Odometry((0.05 * k, 0.0, 0.0), 0.0, 98.0 + 0.1 * k))
        assert out is not None and out.position_m[0] == pytest.approx(0.05 * k)
    assert jumps.jumps == 0 and jumps.late == 0


def test_an_old_glitchs_shift_does_not_explain_a_later_stop():
    """Found in the second review: a glitch's shift kept for long was taken again when the
    robot stopped during a later pose gap, its travel taken for the glitch (1.2 m early).
    Kept shifts expire after a second."""
    jumps, t, x = PoseJumps(), 0.0, 0.0
    for k in range(30):
        t, x = 0.1 * k, 0.1 * k  # 1 m/s
        glitch = -1.5 if k == 3 else 0.0
        jumps.correct(Odometry((x + glitch, 0.0, 0.0), 0.0, t))
    out = jumps.correct(Odometry((x, 0.0, 0.0), 0.0, t + 1.5))  # stopped during a 1.5 s gap
    assert out.position_m[0] == pytest.approx(x, abs=0.01)


def test_a_late_pose_after_a_glitch_while_standing_does_not_keep_the_glitch():
    """Found in the third review: standing, a one-pose glitch, then a pose stamped before
    it (delivered late, itself still glitched): it was taken for a clock set back under the
    glitch's shift, which then stayed (0.28 m late)."""
    jumps = PoseJumps()
    for k in range(10):
        jumps.correct(Odometry((1.5, 0.0, 0.0), 0.0, 3.0 + 0.1 * k))  # standing
    jumps.correct(Odometry((1.0, 0.0, 0.0), 0.0, 4.0))  # a glitch of -0.5 m
    jumps.correct(Odometry((1.0, 0.0, 0.0), 0.0, 3.98))  # late, still glitched
    for k in range(1, 10):
        out = jumps.correct(Odometry((1.5 + 0.05 * k, 0.0, 0.0), 0.0, 4.0 + 0.1 * k))  # walks on
        assert out.position_m[0] == pytest.approx(1.5 + 0.05 * k, abs=0.06)


def test_glitches_that_come_back_do_not_switch_the_judging_off():
    """Found in review: three one-pose glitches within a second (each undone by its way
    back) counted as wrong stamps and switched the stage off for good."""
    jumps = PoseJumps()
    for k in range(40):
        glitch = {10: 2.0, 13: -1.0, 16: 1.5}.get(k, 0.0)
        out = jumps.correct(Odometry((0.05 * k + glitch, 0.0, 0.0), 0.0, 0.1 * k))
        if not glitch:
            assert out.position_m[0] == pytest.approx(0.05 * k, abs=0.01)
    assert jumps.jumps == 3 and not jumps.untrusted


def test_a_restarted_clock_forgets_the_old_shifts_and_reset_forgets_everything():
    jumps = PoseJumps()
    for k in range(10):
        jumps.correct(Odometry((0.05 * k + (1.0 if k == 5 else 0.0), 0.0, 0.0), 0.0, 100.0 + 0.1 * k))
    assert jumps._history
    jumps.correct(Odometry((0.6, 0.0, 0.0), 0.0, 0.0))  # the clock went back 101 s
    assert not jumps._history
    jumps.reset()
    assert (
        jumps.jumps == 0
        and jumps.settled
        and jumps.correct(Odometry((5.0, 0.0, 0.0), 0.0, 1.0)).position_m[0] == 5.0
    )
