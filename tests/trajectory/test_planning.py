"""Point-to-point and multi-waypoint trajectories: boundary states, limits under dense
sampling, continuity by finite differences, refusals."""
import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from rtctl.errors import TrajectoryError
from rtctl.trajectory import JointLimits, JointTrajectory, hold, point_to_point, through_waypoints
from rtctl.trajectory.quintic import PEAK_ACCELERATION, PEAK_VELOCITY, coefficients

from trajectory_checks import assert_continuous, assert_within, dense


@pytest.mark.parametrize("jump", [(0.0, 1e-3, 0.0), (0.0, 0.0, 0.05)])
def test_continuity_check_detects_a_velocity_or_acceleration_jump(jump):
    dv, da = jump[1], jump[2]
    c = [coefficients([0.0], 0.0, 0.0, [0.5], 0.5, 0.0, 1.0), coefficients([0.5], 0.5 + dv, da, [1.0], 0.0, 0.0, 1.0)]
    with pytest.raises(AssertionError):
        assert_continuous(JointTrajectory.from_segments(0.0, [1.0, 1.0], np.array(c)))
    c[1] = coefficients([0.5], 0.5, 0.0, [1.0], 0.0, 0.0, 1.0)
    assert_continuous(JointTrajectory.from_segments(0.0, [1.0, 1.0], np.array(c)))


def test_point_to_point_boundaries_and_shortest_duration(limits3):
    q0, q1 = np.array([0.5, -1.0, 0.0]), np.array([-0.5, 1.5, 0.2])
    tr = point_to_point(q0, q1, limits3, t0=2.0)
    # joint 1 is binding: acceleration 10/√3 · 2.5 / T² = 4 → T = 1.900…; velocity would need 2.34
    expected = max(np.max(PEAK_VELOCITY * np.abs(q1 - q0) / limits3.v_max),
                   np.max(np.sqrt(PEAK_ACCELERATION * np.abs(q1 - q0) / limits3.a_max)))
    assert tr.t_start == 2.0 and tr.duration == pytest.approx(expected)
    for t, q in ((1.0, q0), (2.0, q0), (tr.t_end, q1), (tr.t_end + 5.0, q1)):
        p, v, a = tr.state_at(t)
        np.testing.assert_allclose(p, q, atol=1e-12)
        np.testing.assert_allclose(v, 0, atol=1e-12)
        np.testing.assert_allclose(a, 0, atol=1e-12)
    assert_within(tr, limits3)
    _, _, qd, qdd = dense(tr)
    ratio = max(np.max(np.abs(qd) / limits3.v_max), np.max(np.sqrt(np.abs(qdd) / limits3.a_max)))
    assert ratio > 0.999  # a shorter duration would break a limit
    # synchronised: every joint follows the same normalised profile
    t_mid = tr.t_start + 0.3 * tr.duration
    p, _, _ = tr.state_at(t_mid)
    s = 0.3
    np.testing.assert_allclose(p, q0 + (q1 - q0) * (10 * s**3 - 15 * s**4 + 6 * s**5), atol=1e-12)


def test_point_to_point_longer_duration_kept_shorter_refused(limits3):
    q0, q1 = [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]
    assert point_to_point(q0, q1, limits3, duration=5.0).duration == pytest.approx(5.0)
    t_min = point_to_point(q0, q1, limits3).duration
    with pytest.raises(TrajectoryError, match="below"):
        point_to_point(q0, q1, limits3, duration=0.9 * t_min)


def test_forced_short_smooth_durations_break_limits_and_are_refused(limits3):
    W = [[0, 0, 0], [1, 1, 1], [2, 2, 0.5]]
    tr = through_waypoints(W, limits3, smooth=True)
    T = np.diff(tr.knots)
    assert through_waypoints(W, limits3, smooth=True, durations=list(T * 1.1)).duration == pytest.approx(tr.duration * 1.1)
    with pytest.raises(TrajectoryError, match="violates"):
        through_waypoints(W, limits3, smooth=True, durations=list(T * 0.95))


def test_stop_mode_visits_each_waypoint_at_rest_with_dwell(limits3):
    W = np.array([[0.3, 0.0, 0.0], [1.0, -1.0, 0.5], [1.0, 1.0, -0.5]])
    start = np.array([0.0, 0.2, 0.1])
    tr = through_waypoints(W, limits3, start=start, dwell=[0.0, 0.5, 0.0])
    assert len(tr.knots) == 5  # three moves and one dwell
    p, v, a = tr.state_at(tr.t_start)
    np.testing.assert_allclose(p, start)
    for k, w in zip((1, 2, 4), W):
        p, v, a = tr.state_at(tr.knots[k])
        np.testing.assert_allclose(p, w, atol=1e-12)
        np.testing.assert_allclose(v, 0, atol=1e-9)
    # the dwell holds waypoint 1 for 0.5 s
    assert tr.knots[3] - tr.knots[2] == pytest.approx(0.5)
    np.testing.assert_allclose(tr.state_at(tr.knots[2] + 0.25)[0], W[1])
    assert_within(tr, limits3)
    assert_continuous(tr)


def test_smooth_passes_waypoints_moving_and_is_faster(limits3):
    W = np.array([[0.0, 0.0, 0.0], [0.5, 0.4, 0.2], [1.0, 0.9, 0.3], [1.6, 1.2, 0.6], [2.0, 1.5, 0.2]])
    smooth = through_waypoints(W, limits3, smooth=True)
    stop = through_waypoints(W, limits3, smooth=False)
    assert smooth.duration < 0.75 * stop.duration
    for k, w in enumerate(W):
        p, v, _ = smooth.state_at(smooth.knots[k])
        np.testing.assert_allclose(p, w, atol=1e-12)
        if 0 < k < len(W) - 1:
            assert np.any(np.abs(v) > 0.1)  # did not stop
    assert_within(smooth, limits3)
    assert_continuous(smooth)
    _, _, qd, qdd = dense(smooth)
    assert max(np.max(np.abs(qd) / limits3.v_max), np.max(np.sqrt(np.abs(qdd) / limits3.a_max))) > 0.999


def test_smooth_stops_at_dwell_and_repeated_points(limits3):
    W = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.5, 1.5, 0.0]])
    tr = through_waypoints(W, limits3, smooth=True, dwell=[0, 0.2, 0, 0, 0])
    # segments: 0→1, dwell at 1, 1→2, (2→3 repeated, skipped), 3→4
    assert len(tr.knots) == 5
    for k in (1, 2, 3):
        np.testing.assert_allclose(tr.state_at(tr.knots[k])[1], 0, atol=1e-12)
    assert_within(tr, limits3)
    assert_continuous(tr)


def test_hold_and_single_waypoint(limits3):
    tr = through_waypoints([[0.1, 0.2, 0.3]], limits3)
    assert tr.duration == 0.0
    q = np.empty(3)
    qd = np.full(3, 9.0)
    qdd = np.full(3, 9.0)
    for t in (-1.0, 0.0, 7.0):
        tr.sample(t, q, qd, qdd)
        np.testing.assert_allclose(q, [0.1, 0.2, 0.3])
        assert not np.any(qd) and not np.any(qdd)
    assert hold([1.0, 2.0], t0=3.0).state_at(4.0)[0].tolist() == [1.0, 2.0]


def test_refusals(limits3):
    with pytest.raises(TrajectoryError, match="waypoint 1"):
        through_waypoints([[0, 0, 0], [0, 3.5, 0]], limits3)
    with pytest.raises(TrajectoryError, match="start"):
        through_waypoints([[0, 0, 0]], limits3, start=[-3.1, 0, 0])
    with pytest.raises(TrajectoryError):
        through_waypoints([[0, 0]], limits3)
    with pytest.raises(TrajectoryError):
        JointLimits([1.0, 0.0], [1.0, 1.0])
    with pytest.raises(TrajectoryError, match="dwell"):
        through_waypoints([[0, 0, 0], [1, 1, 1]], limits3, dwell=-1.0)


def test_smooth_overshoot_past_position_limit_is_refused():
    # fast into waypoint 1, slow to waypoint 2: the via velocity (mean of the slopes, 1.475)
    # carries joint 0 past q_max = 3 before it turns back; the speed limits are not the reason
    W = [[0.0], [2.9], [3.0], [0.0]]
    free = through_waypoints(W, JointLimits([100.0], [100.0]), smooth=True, durations=[1.0, 2.0, 4.0])
    assert dense(free)[1].max() > 3.05
    with pytest.raises(TrajectoryError, match="violates"):
        through_waypoints(W, JointLimits([100.0], [100.0], [-3.0], [3.0]), smooth=True, durations=[1.0, 2.0, 4.0])


pts = st.lists(st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3), min_size=2, max_size=5)


@settings(max_examples=25, deadline=None)
@given(W=pts, smooth=st.booleans(), dwell=st.sampled_from([0.0, 0.1]))
@example(W=[[0.0, 0.0, 0.0], [0.0, 0.0, 1.4e-174]], smooth=False, dwell=0.0)  # T⁵ underflow, found by hypothesis
@example(W=[[0.0, 0.0, 0.0], [1e-10, 0.0, 0.0], [1.0, 1e-10, 0.0], [1.0, 1.0, 1.0]], smooth=True, dwell=0.0)
def test_random_waypoints_respect_limits_and_pass_through(W, smooth, dwell):
    lim = JointLimits([1.0, 1.5, 2.0], [2.0, 3.0, 1.0])
    tr = through_waypoints(W, lim, smooth=smooth, dwell=dwell)
    assert_within(tr, lim)
    p, v, a = tr.state_at(tr.t_end + 1.0)
    np.testing.assert_allclose(p, W[-1], atol=1e-9)
    # every waypoint is visited at some knot
    visited = np.array([tr.state_at(t)[0] for t in tr.knots])
    for w in W:
        assert np.min(np.max(np.abs(visited - w), axis=1)) < 1e-9
