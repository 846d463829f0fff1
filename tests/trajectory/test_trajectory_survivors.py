"""Tests for the trajectory mutants that survived the suite (issue 27, part 3; docs/mutation/trajectory.md):
the limits' shape checks, and a retarget that must brake first on the way through several
waypoints (continuity by dense sampling, each waypoint reached at rest in order)."""
import numpy as np
import pytest

from rtctl.errors import TrajectoryError
from rtctl.trajectory import JointLimits, retarget
from rtctl.trajectory.quintic import shortest_duration

from trajectory_checks import assert_continuous, assert_within


@pytest.mark.parametrize(("v_max", "a_max"), [
    ([1.0, 1.0], [2.0, 2.0, 2.0]),  # one acceleration limit too many
    ([1.0, 1.0, 1.0], [2.0, 2.0]),
    ([[1.0, 1.0]], [[2.0, 2.0]]),  # not one per joint: a matrix
    (1.0, 2.0),  # a scalar
])
def test_limits_must_be_one_vector_per_joint(v_max, a_max):
    with pytest.raises(TrajectoryError, match="one per joint"):
        JointLimits(v_max, a_max)


def test_retarget_that_brakes_first_goes_on_through_the_waypoints_in_order():
    # as tests/trajectory/test_retarget.py's braking case (joint 0 at 0.8 rad/s, accelerating,
    # must still travel 2 rad: no single quintic fits), but with a second waypoint after it
    lim = JointLimits([1.0, 1.0], [2.0, 2.0], [-3.0, -3.0], [3.0, 3.0])
    q, v, a = np.zeros(2), np.array([0.8, 0.0]), np.array([1.0, 0.0])
    waypoints = np.array([[2.0, 0.0], [0.5, 1.0]])
    assert shortest_duration(q, v, a, waypoints[0], lim.v_max, lim.a_max, lim.q_min, lim.q_max) is None
    new = retarget(0.5, q, v, a, waypoints, lim)
    assert len(new.knots) == 4  # braking, to waypoint 0, to waypoint 1
    for knot, want in ((new.knots[2], waypoints[0]), (new.t_end, waypoints[1])):
        p, pv, pa = new.state_at(knot)
        np.testing.assert_allclose(p, want, atol=1e-12)
        np.testing.assert_allclose(pv, 0.0, atol=1e-9)
    assert_continuous(new)  # no jump anywhere, the knots included
    assert_within(new, lim)
