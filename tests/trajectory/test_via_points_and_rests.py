"""Via points, resting joints and a start at a turning point, against closed forms.

* Points sampled from a parabola q(t) = c t² + b t at equal intervals: Craig's via velocity (the
  mean of the two slopes) and the central-difference acceleration 2(s_k − s_{k−1})/(T_{k−1} + T_k)
  are exact there (docs: rtctl/trajectory/smooth.py), so the smooth trajectory passes each via
  point with the parabola's velocity 2c t_k + b and acceleration 2c.
* A joint with the same value at two consecutive waypoints does not move between them.
* A retarget from a turning point (q̇ = 0, q̈ ≠ 0 — the top of a swing) continues q, q̇ and q̈
  and arrives at rest within the limits, in both directions.
"""
import numpy as np
import pytest

from rtctl.trajectory import JointLimits, retarget, through_waypoints
from trajectory_checks import assert_within, dense

WIDE = JointLimits(v_max=[50.0, 50.0], a_max=[200.0, 200.0])


def test_via_points_of_a_parabola_get_its_velocity_and_acceleration():
    c, b, T = np.array([1.5, 0.4]), np.array([0.2, 1.0]), 0.5
    times = T * np.arange(6)
    points = c * times[:, None] ** 2 + b * times[:, None]  # increasing: every via slope pair has one sign
    traj = through_waypoints(points, WIDE, smooth=True, durations=[T] * 5)
    q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
    for k in range(1, 5):
        traj.sample(traj.t_start + times[k], q, qd, qdd)
        np.testing.assert_allclose(q, points[k], atol=1e-12)
        np.testing.assert_allclose(qd, 2 * c * times[k] + b, rtol=1e-12)
        np.testing.assert_allclose(qdd, 2 * c, rtol=1e-9)


def test_a_joint_resting_between_two_waypoints_stays_still_there():
    limits = JointLimits(v_max=[1.0, 1.0], a_max=[2.0, 2.0])
    points = np.array([[0.0, 0.0], [0.5, 0.4], [1.0, 0.4], [1.5, 0.0]])  # joint 1 rests from point 1 to 2
    traj = through_waypoints(points, limits, smooth=True)
    t1, t2 = traj.knots[1], traj.knots[2]
    ts, q, qd, _ = dense(traj, dt=1e-3, pad=0.0)
    resting = (ts >= t1) & (ts <= t2)
    assert resting.sum() > 100
    np.testing.assert_allclose(q[resting, 1], 0.4, atol=1e-12)
    np.testing.assert_allclose(qd[resting, 1], 0.0, atol=1e-12)
    assert np.ptp(q[resting, 0]) > 0.4  # (while joint 0 moves)


@pytest.mark.parametrize("target", [[1.5, 0.2, 0.0], [-0.5, 0.2, 0.0], [0.5, -1.0, 1.0]])
def test_a_retarget_from_a_turning_point_continues_its_acceleration(limits3, target):
    t0 = 2.0
    q, qd, qdd = np.array([0.5, 0.2, 0.0]), np.zeros(3), np.array([-1.8, 3.0, 0.0])  # a_max = 2, 4, 5
    new = retarget(t0, q, qd, qdd, [target], limits3)
    for got, want in zip(new.state_at(t0), (q, qd, qdd)):
        np.testing.assert_allclose(got, want, atol=1e-12)
    end = new.state_at(new.t_end)
    np.testing.assert_allclose(end[0], target, atol=1e-12)
    np.testing.assert_allclose(end[1], 0.0, atol=1e-9)
    np.testing.assert_allclose(end[2], 0.0, atol=1e-9)
    assert_within(new, limits3)
