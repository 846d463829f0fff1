"""Online retarget: the new trajectory continues the old one's position, velocity and
acceleration at the switch time and then meets the limits."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from rtctl.errors import TrajectoryError
from rtctl.trajectory import JointLimits, JointTrajectory, point_to_point, retarget, through_waypoints
from rtctl.trajectory.quintic import coefficients, fits, shortest_duration

from trajectory_checks import assert_continuous, assert_within


def _spliced(old, new):
    """One trajectory: ``old`` up to ``new.t_start``, then ``new`` — to check the switch by finite differences."""
    k = int(np.searchsorted(old.knots, new.t_start, side="right"))  # old segments started before the switch
    T = np.diff(np.concatenate((old.knots[:k], [new.t_start])))
    return JointTrajectory.from_segments(old.t_start, np.concatenate((T, np.diff(new.knots))),
                                         np.concatenate((old.coeffs[:k], new.coeffs)))


@pytest.mark.parametrize("frac", [0.2, 0.5, 0.8])
def test_retarget_mid_motion_is_continuous_and_within_limits(limits3, frac):
    old = point_to_point([0.0, 0.0, 0.0], [2.0, -1.5, 1.0], limits3)
    t = old.t_start + frac * old.duration
    new = retarget(t, *old.state_at(t), [[-1.0, 1.0, 0.0]], limits3)
    for a, b in zip(new.state_at(t), old.state_at(t)):
        np.testing.assert_allclose(a, b, atol=1e-12)
    assert new.t_start == t
    p, v, a = new.state_at(new.t_end)
    np.testing.assert_allclose(p, [-1.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(v, 0.0, atol=1e-9)
    assert_within(new, limits3)
    assert_continuous(_spliced(old, new))


def test_retarget_through_several_waypoints_smooth(limits3):
    old = through_waypoints([[0, 0, 0], [1, 1, 1], [2, 0, 0]], limits3, smooth=True)
    t = old.t_start + 0.4 * old.duration
    new = retarget(t, *old.state_at(t), [[0.5, 0.5, 0.5], [1.0, 1.2, 0.8], [0.0, 0.0, 0.0]], limits3,
                   smooth=True, dwell=0.1)
    assert_within(new, limits3)
    assert_continuous(_spliced(old, new))
    np.testing.assert_allclose(new.state_at(new.t_end + 1)[0], 0.0, atol=1e-12)


def test_retarget_from_rest_is_the_point_to_point(limits3):
    q = np.array([0.1, 0.2, 0.3])
    new = retarget(1.0, q, np.zeros(3), np.zeros(3), [[1.0, 0.0, 0.0]], limits3)
    ref = point_to_point(q, [1.0, 0.0, 0.0], limits3, t0=1.0)
    np.testing.assert_allclose(new.knots, ref.knots)
    np.testing.assert_allclose(new.coeffs, ref.coeffs)


def test_retarget_to_where_it_is_going_now_stops_smoothly(limits3):
    old = point_to_point([0.0, 0.0, 0.0], [2.0, 2.0, 2.0], limits3)
    t = old.t_start + 0.5 * old.duration
    q, v, a = old.state_at(t)
    new = retarget(t, q, v, a, [q], limits3)  # "stop here": it has to overshoot and come back
    assert_within(new, limits3)
    assert_continuous(_spliced(old, new))


def test_retarget_brakes_first_when_no_single_quintic_fits():
    # joint 0 accelerating at 0.8 rad/s towards v_max = 1 must still travel 2 rad: one quintic
    # would overshoot the speed limit, so it brakes and then moves from rest
    lim = JointLimits([1.0, 1.0], [2.0, 2.0], [-3.0, -3.0], [3.0, 3.0])
    q, v, a = np.zeros(2), np.array([0.8, 0.0]), np.array([1.0, 0.0])
    assert shortest_duration(q, v, a, [2.0, 0.0], lim.v_max, lim.a_max, lim.q_min, lim.q_max) is None
    new = retarget(0.5, q, v, a, [[2.0, 0.0]], lim)
    assert len(new.knots) == 3
    p, pv, pa = new.state_at(0.5)
    np.testing.assert_allclose(np.concatenate((p, pv, pa)), np.concatenate((q, v, a)), atol=1e-12)
    np.testing.assert_allclose(new.state_at(new.knots[1])[1], 0.0, atol=1e-12)  # at rest between the two
    np.testing.assert_allclose(new.state_at(new.t_end)[0], [2.0, 0.0], atol=1e-12)
    assert_within(new, lim)
    assert_continuous(new)


def test_a_long_requested_duration_from_motion_brakes_first_and_arrives_on_time(limits3):
    # mid-motion, one quintic stretched over 30 s swings far past the joint range; the move
    # brakes first and then takes the rest of the 30 s from rest
    old = point_to_point([0.0, 0.0, 0.0], [2.0, -1.5, 1.0], limits3)
    t = old.t_start + 0.5 * old.duration
    q, v, a = old.state_at(t)
    target = [[0.5, 0.5, 0.5]]
    lim = (limits3.v_max, limits3.a_max, limits3.q_min, limits3.q_max)
    assert not fits(coefficients(q, v, a, np.array(target[0]), 0.0, 0.0, 30.0), 30.0, *lim)
    new = retarget(t, q, v, a, target, limits3, duration=30.0)
    assert len(new.knots) == 3
    assert new.t_end == pytest.approx(t + 30.0, abs=1e-12)
    np.testing.assert_allclose(new.state_at(new.knots[1])[1], 0.0, atol=1e-12)
    np.testing.assert_allclose(new.state_at(new.t_end)[0], target[0], atol=1e-12)
    assert_within(new, limits3)
    assert_continuous(_spliced(old, new))


def test_retarget_refusals(limits3):
    old = point_to_point([0.0, 0.0, 0.0], [2.0, -1.5, 1.0], limits3)
    t = old.t_start + 0.5 * old.duration
    with pytest.raises(TrajectoryError, match="violates"):
        retarget(t, *old.state_at(t), [[-1.0, 1.0, 0.0]], limits3, duration=0.2)
    with pytest.raises(TrajectoryError, match="waypoint 0"):
        retarget(t, *old.state_at(t), [[-1.0, 9.0, 0.0]], limits3)
    # moving at full speed towards q_max from close by: nothing stops it inside the range
    lim = JointLimits([1.0], [1.0], [-1.0], [1.0])
    with pytest.raises(TrajectoryError, match="no duration"):
        retarget(0.0, [0.9], [1.0], [0.0], [[0.95]], lim)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-2.5, 2.5), min_size=3, max_size=3), st.lists(st.floats(-2.5, 2.5), min_size=3, max_size=3),
       st.floats(0.0, 1.0))
def test_random_retargets_are_continuous_and_within_limits(via, target, frac):
    lim = JointLimits([1.0, 2.0, 3.0], [2.0, 4.0, 5.0], [-3.0] * 3, [3.0] * 3)
    old = through_waypoints([[0.0, 0.0, 0.0], via, [0.5, 0.5, 0.5]], lim, smooth=True)
    t = old.t_start + frac * old.duration
    try:
        new = retarget(t, *old.state_at(t), [target], lim)
    except TrajectoryError as e:  # only a stop that cannot stay inside the range may be refused
        assert "no duration" in str(e)
        q, v, _ = old.state_at(t)
        assert np.any(np.abs(q + v * np.abs(v) / (2 * lim.a_max)) > 2.9)  # that close to a limit
        return
    for a, b in zip(new.state_at(t), old.state_at(t)):
        np.testing.assert_allclose(a, b, atol=1e-12)
    np.testing.assert_allclose(new.state_at(new.t_end + 1.0)[0], target, atol=1e-12)
    assert_within(new, lim)
