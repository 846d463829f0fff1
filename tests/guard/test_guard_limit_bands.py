"""The run-time guard's two bands at the joint limits, for the lower limit as for the upper
(docs/interference_guard.md, "Run-time guard"): with ``clamp``, a stop point within g/2 of a
limit is clamped, one past the limit is a STOP. The two limits are mirror images of each other:
a state and its mirror (q → −q, q̇ → −q̇ about limits ±3) get the same verdict."""
import numpy as np
import pytest

from rtctl.guard import Polygon, RuntimeGuard, Scene, Zone
from rtctl.hal.joints import JointCommand, JointState
from rtctl.safety import GuardVerdict
from test_zones import SQUARE

DT, DECEL, MARGIN = 0.001, np.array([10.0, 20.0]), 0.04
SCENE = Scene([Zone("box", [Polygon((0, 1), SQUARE)])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)


def stop_point(q, qd):
    """p = q + q̇ (dt + T/2), T = max |q̇ⱼ|/aⱼ (the guard's stopping path, docs)."""
    T = np.max(np.abs(qd) / DECEL)
    return np.asarray(q) + np.asarray(qd) * (DT + T / 2)


def verdict(q, qd, tau):
    guard = RuntimeGuard(SCENE, DECEL, DT, margin=MARGIN, action="clamp", damping=10.0, stiffness=100.0)
    state, command = JointState(2), JointCommand(2)
    state.position[:], state.velocity[:], command.tau_ff[:] = q, qd, tau
    return guard.check(0.0, state, command), command.tau_ff.copy()


@pytest.mark.parametrize("side", [+1.0, -1.0], ids=["upper", "lower"])
def test_a_stop_point_just_past_either_limit_is_a_stop_in_clamp_mode(side):
    q, qd = np.array([2.99, 0.0]) * side, np.array([0.6, 0.0]) * side
    p = stop_point(q, qd)[0]
    assert 3.0 < side * p < 3.0 + MARGIN / 2  # past the limit, by less than the band (0.0086 here)
    assert verdict(q, qd, [0.0, 0.0])[0] == GuardVerdict.STOP


@pytest.mark.parametrize("side", [+1.0, -1.0], ids=["upper", "lower"])
def test_a_stop_point_in_the_outer_half_of_either_limit_band_is_clamped_away_from_it(side):
    q, qd = np.array([2.97, 0.0]) * side, np.array([0.5, 0.0]) * side
    p = stop_point(q, qd)[0]
    assert 3.0 - MARGIN / 2 < side * p < 3.0  # inside the band's outer half, not past the limit
    result, tau = verdict(q, qd, np.array([5.0, 0.0]) * side)  # pushing towards the limit
    assert result == GuardVerdict.MODIFIED
    depth = side * p - (3.0 - MARGIN / 2)
    assert tau[0] == pytest.approx(-side * (100.0 * depth + 10.0 * abs(qd[0])))  # the wall, away from the limit
