"""Tests for the trajectory mutants that survived the full mutation run with parts 1 and 2 in
place (88 of 1025; docs/mutation/trajectory.md says which are caught here, which are equivalent and which
only tune the duration search): input checks at their exact boundary, documented messages, the
sampler's documented end and knot behaviour, hand-computed extrema of simple polynomials and the
closed-form rest-to-rest time."""
import re
from types import SimpleNamespace

import numpy as np
import pytest

from rtctl.errors import TrajectoryError
from rtctl.trajectory import JointLimits, JointTrajectory, point_to_point, retarget, through_waypoints
from rtctl.trajectory.quintic import extrema, fits, shortest_duration


def r2r(delta, v_max, a_max):
    """The documented shortest rest-to-rest time, by hand (max over joints, at least 1 ms)."""
    d = np.abs(np.asarray(delta, float))
    t = max(np.max(15 / 8 * d / v_max), np.max(np.sqrt(10 / np.sqrt(3) * d / a_max)))
    return max(float(t), 1e-3)


LIM1 = JointLimits([1.0], [2.0])


# ---- piecewise ---------------------------------------------------------------------------

def test_after_the_end_velocity_and_acceleration_are_zero_even_if_the_last_segment_moves():
    """The module docstring — after the end the sampler holds the last point with zero
    velocity and acceleration; the hand-built segment q = τ ends moving at 1 rad/s."""
    traj = JointTrajectory([0.0, 1.0], np.array([[[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]]]))
    q, qd, qdd = traj.state_at(2.0)
    assert q[0] == 1.0 and qd[0] == 0.0 and qdd[0] == 0.0


def test_at_the_end_and_at_a_stop_knot_the_state_is_exactly_the_rest_state():
    """A stop-mode trajectory is at rest at each waypoint (the boundary conditions
    q̇ = q̈ = 0); at the end time the sampler holds (zero exactly) and at an interior knot
    segment k starts (``knots[k]`` belongs to segment k: its c0 is the waypoint, c1 = c2 = 0
    exactly). Evaluating the previous segment's polynomial at its end instead leaves rounding."""
    lim = JointLimits([1.3, 0.7], [2.9, 1.7])
    W = [[0.3, -0.7], [1.1, 0.2], [-0.4, 0.9]]
    traj = through_waypoints(W, lim, start=[0.0, 0.0])
    for k in (1, 2):
        q, qd, qdd = traj.state_at(traj.knots[k])
        assert np.array_equal(q, W[k - 1]) and not np.any(qd) and not np.any(qdd)
    q, qd, qdd = traj.state_at(traj.t_end)
    assert not np.any(qd) and not np.any(qdd)


def test_non_finite_coefficients_with_finite_knots_are_refused():
    """The documented refusal — "trajectory has non-finite knots or coefficients"."""
    c = np.zeros((1, 1, 6))
    c[0, 0, 3] = np.nan
    with pytest.raises(TrajectoryError, match="non-finite knots or coefficients"):
        JointTrajectory([0.0, 1.0], c)


# ---- JointLimits ---------------------------------------------------------------------------

@pytest.mark.parametrize("a_max", [0.0, -0.5])
def test_acceleration_limit_zero_or_negative_is_refused(a_max):
    """The docstring — velocity and acceleration limits > 0; 0 is the boundary."""
    with pytest.raises(TrajectoryError, match="must be positive"):
        JointLimits([1.0], [a_max])


def test_equal_position_limits_are_refused():
    """The documented check q_min < q_max, at equality (shapes all right)."""
    with pytest.raises(TrajectoryError, match="q_min < q_max"):
        JointLimits([1.0, 1.0], [1.0, 1.0], q_min=[-1.0, 0.5], q_max=[1.0, 0.5])


def test_from_model_without_a_scale_takes_the_models_velocity_limits():
    """No velocity_scale given → the model's own velocity limits (scale 1)."""
    model = SimpleNamespace(nq=2, v_max=np.array([1.5, 2.5]), q_min=np.array([-1.0, -2.0]),
                            q_max=np.array([1.0, 2.0]))
    lim = JointLimits.from_model(model, 3.0)
    assert np.array_equal(lim.v_max, [1.5, 2.5]) and np.array_equal(lim.a_max, [3.0, 3.0])


# ---- through_waypoints / point_to_point ----------------------------------------------------

def test_through_waypoints_takes_its_options_by_keyword_only():
    """The signature's ``*`` — start, smooth, dwell, durations, t0 are keyword-only, and
    waypoints and limits can be named."""
    traj = through_waypoints(waypoints=[[1.0]], limits=LIM1, start=[0.0])
    assert traj.duration == pytest.approx(r2r(1.0, 1.0, 2.0), rel=1e-12)
    with pytest.raises(TypeError):
        through_waypoints([[1.0]], LIM1, [0.0])


def test_no_waypoints_are_refused_even_with_a_start():
    """The documented check "waypoints must be (m, n)" for m = 0 (with a start the mutant
    returns a hold at the start instead)."""
    for start in (None, [0.0, 0.0]):
        with pytest.raises(TrajectoryError, match=re.escape("waypoints must be (m, 2), got (0, 2)")):
            through_waypoints(np.zeros((0, 2)), JointLimits([1.0, 1.0], [1.0, 1.0]), start=start)


def test_a_duration_between_a_repeated_point_and_itself_is_a_wait_even_below_one_second():
    """The docstring — a duration between a repeated point and itself is a wait."""
    traj = through_waypoints([[0.5], [0.5]], LIM1, durations=[0.25])
    assert traj.duration == 0.25
    assert traj.state_at(0.1)[0][0] == 0.5


@pytest.mark.parametrize("bad", [0.0, -0.5])
def test_a_zero_or_negative_requested_duration_gets_the_documented_message(bad):
    """`_check_durations` — a duration must be positive (0 is the boundary); the
    message says so, not that the limits need more."""
    with pytest.raises(TrajectoryError, match=r"duration 0: .* must be positive and at most 1e\+06 s"):
        point_to_point([0.0], [1.0], LIM1, duration=bad)
    with pytest.raises(TrajectoryError, match="must be positive"):
        retarget(0.0, [0.0], [0.0], [0.0], [[1.0]], LIM1, duration=bad)


def test_a_duration_just_above_the_maximum_is_refused():
    """MAX_DURATION_S = 1e6 s (the docstring: at most 1e6); 1e6 + 0.5 is refused."""
    with pytest.raises(TrajectoryError, match="at most"):
        point_to_point([0.0], [1.0], LIM1, duration=1e6 + 0.5)


# ---- retarget ------------------------------------------------------------------------------

def test_retarget_message_gives_the_peak_velocity_ratio():
    """From rest, Δ = 1 in 1 s: the min-jerk peak speed is 15/8 rad/s, so against
    v_max = 0.5 the message's "peak |q̇|/v_max" is 3.75 (a_max large: not the limit)."""
    lim = JointLimits([0.5], [100.0])
    with pytest.raises(TrajectoryError, match=r"peak \|q̇\|/v_max 3\.75,"):
        retarget(0.0, [0.0], [0.0], [0.0], [[1.0]], lim, duration=1.0)


def test_retarget_takes_its_options_by_keyword_only():
    """The signature's ``*`` — duration, durations, smooth, dwell are keyword-only."""
    with pytest.raises(TypeError):
        retarget(0.0, [0.0], [0.0], [0.0], [[1.0]], LIM1, 5.0)
    traj = retarget(t=0.0, q=[0.0], qd=[0.0], qdd=[0.0], waypoints=[[1.0]], limits=LIM1)
    assert traj.duration == pytest.approx(r2r(1.0, 1.0, 2.0), rel=1e-12)


def test_retarget_from_rest_goes_to_the_first_waypoint_in_its_closed_form_time_and_stops_there():
    """From rest the first move is the rest-to-rest quintic to waypoint 0 in the
    closed-form time; by default (smooth=False, as through_waypoints) it then stops at every
    waypoint — zero velocity at waypoint 1 too."""
    W = [[0.2], [0.6], [1.4]]
    traj = retarget(3.0, [0.0], [0.0], [0.0], W, LIM1)
    t1 = r2r(0.2, 1.0, 2.0)
    assert traj.knots[1] - traj.knots[0] == pytest.approx(t1, rel=1e-12)
    t2 = 3.0 + t1 + r2r(0.4, 1.0, 2.0)
    assert traj.knots[2] == pytest.approx(t2, rel=1e-12)
    for t, w in ((3.0 + t1, 0.2), (t2, 0.6)):
        q, qd, qdd = traj.state_at(t)
        assert q[0] == pytest.approx(w, abs=1e-12) and abs(qd[0]) < 1e-12


def test_retarget_with_a_duration_that_one_quintic_meets_is_that_one_quintic():
    """Moving at v0 = 0.5 with duration 2 to waypoint 0 at the braking target
    q0 + v0·T/2 = 0.5: one quintic (velocity v0(1−s)²(1+2s) ≤ 0.5, |q̈| ≤ 1.5·v0/T = 0.375,
    by hand within 1 and 2) — so no braking segment, waypoint 0 reached at t + 2 whatever the
    later (far) waypoint."""
    W = [[0.5], [2.5]]
    traj = retarget(1.0, [0.0], [0.5], [0.0], W, LIM1, duration=2.0)
    assert traj.knots[1] == 3.0
    q, qd, _ = traj.state_at(3.0)
    assert q[0] == pytest.approx(0.5, abs=1e-12) and abs(qd[0]) < 1e-12
    ts = np.linspace(1.0, 3.0, 401)
    assert max(abs(traj.state_at(t)[1][0]) for t in ts) <= 0.5 + 1e-12


def test_retarget_duration_exactly_the_braking_time_is_refused_with_the_documented_reason():
    """When braking takes the whole requested duration nothing is left for the move
    (``_brake_then_move``: "when nothing is left, the requested time cannot be met") — the
    message names the time the current motion needs to come to rest."""
    lim = JointLimits([1.0], [2.0])
    q, qd, qdd = [0.0], [0.9], [0.0]
    T = shortest_duration(np.array(q), np.array(qd), np.array(qdd), None, lim.v_max, lim.a_max)
    with pytest.raises(TrajectoryError, match="to come to rest within them"):
        retarget(0.0, q, qd, qdd, [[-3.0]], lim, duration=T)


# ---- quintic: extrema and fits -------------------------------------------------------------

def test_extrema_of_a_tiny_move_are_its_closed_form_peaks():
    """Δ = 1e-9 in T = 1: |q̇| peaks at 15/8·Δ, |q̈| at 10/√3·Δ (the module docstring) —
    a relative, not absolute, threshold for negligible coefficients."""
    c = np.array([[0.0, 0.0, 0.0, 10e-9, -15e-9, 6e-9]])
    e = extrema(c, 1.0)
    assert e[2, 0] == pytest.approx(15 / 8 * 1e-9, rel=1e-9, abs=0.0)
    assert e[3, 0] == pytest.approx(10 / np.sqrt(3) * 1e-9, rel=1e-9, abs=0.0)


def test_extrema_per_joint_whatever_the_other_joints_scale():
    """Two joints, Δ = 1 and 1e-15, T = 1: each has its own closed-form peaks (no
    absolute tolerance: pytest's default 1e-12 would accept 0 for the small joint)."""
    d = np.array([1.0, 1e-15])
    c = np.zeros((2, 6))
    c[:, 3], c[:, 4], c[:, 5] = 10 * d, -15 * d, 6 * d
    e = extrema(c, 1.0)
    assert e[2] == pytest.approx(15 / 8 * d, rel=1e-9, abs=0.0)
    assert e[3] == pytest.approx(10 / np.sqrt(3) * d, rel=1e-9, abs=0.0)


def test_extrema_of_a_cubic_has_the_interior_velocity_peak():
    """Q = 3τ² − 2τ³ on [0, 1]: q̇ = 6τ(1 − τ) peaks at 1.5 (τ = ½, where the linear q̈
    vanishes); |q̈| = |6 − 12τ| peaks at 6 at the ends; q runs 0 … 1."""
    e = extrema(np.array([[0.0, 0.0, 3.0, -2.0, 0.0, 0.0]]), 1.0)
    assert e[:, 0] == pytest.approx([0.0, 1.0, 1.5, 6.0], abs=1e-12)


def test_extrema_ignore_critical_points_before_the_start():
    """Q = −(τ + ½)² on [0, 1]: q̇ = 0 only at τ = −½ (outside), so q runs −2.25 … −0.25
    and |q̇| = |2τ + 1| peaks at 3, |q̈| = 2."""
    e = extrema(np.array([[-0.25, -1.0, -1.0, 0.0, 0.0, 0.0]]), 1.0)
    assert e[:, 0] == pytest.approx([-2.25, -0.25, 3.0, 2.0], abs=1e-12)


def test_a_segment_exactly_at_its_limits_fits():
    """Q = τ on [0, 1] has |q̇| = 1 exactly and spans exactly [0, 1]: with v_max = 1,
    q_max = 1 and no tolerance (rtol = 0) it stays within the limits (limits are inclusive: a
    planned segment "just meets" them)."""
    c = np.array([[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]])
    assert fits(c, 1.0, np.array([1.0]), np.array([1.0]), rtol=0.0)
    assert fits(c, 1.0, np.array([2.0]), np.array([1.0]), np.array([0.0]), np.array([1.0]), rtol=0.0)


@pytest.mark.parametrize("end", ["q_max", "q_min"])
def test_shortest_duration_to_a_position_limit_is_the_closed_form_time(end):
    """From rest to a target exactly at a position limit (the rest-to-rest quintic
    is monotone, so it touches the limit only at its end): the closed-form time within the
    documented ≈ 2 % — not None."""
    lo, hi = np.array([-1.0]), np.array([1.0])
    q1 = hi if end == "q_max" else lo
    T = shortest_duration(np.array([0.0]), np.array([0.0]), np.array([0.0]), q1, np.array([1.0]),
                          np.array([2.0]), lo, hi)
    t_star = r2r(1.0, 1.0, 2.0)
    assert T is not None and t_star * (1 - 1e-9) <= T <= t_star * 1.03


def test_points_exactly_the_same_point_tolerance_apart_are_one_point():
    """``_SAME_POINT`` (1e-12): points at most that far apart count as one, so a move of
    exactly 1e-12 is no move — a hold, not a 1 ms segment (the comment said "closer", which
    left the boundary open; it now says "at most", as the code has always done)."""
    traj = point_to_point([0.0], [1e-12], LIM1)
    assert traj.duration == 0.0
