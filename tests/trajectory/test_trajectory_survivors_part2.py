"""Tests for the trajectory mutants that survived the suite (cosmic-ray run trajectory-s30):
each checks the code against an independent expectation — the closed-form rest-to-rest time
(15/8·|Δ|/v_max, √(10/√3·|Δ|/a_max), at least T_MIN), a hand-computed polynomial or via-point
state, dense sampling, or the documented wording of an error."""
import dataclasses
import re
from types import SimpleNamespace

import numpy as np
import pytest

from rtctl.errors import TrajectoryError
from rtctl.trajectory import JointLimits, JointTrajectory, hold, point_to_point, retarget, through_waypoints
from rtctl.trajectory.planning import MAX_DURATION_S
from rtctl.trajectory.quintic import extrema, fits, rest_to_rest_duration, shortest_duration
from rtctl.trajectory.smooth import fit_durations, via_states

from trajectory_checks import assert_continuous, assert_within


def r2r(delta, v_max, a_max):
    """The documented shortest rest-to-rest time, by hand (max over joints, at least 1 ms)."""
    d = np.abs(np.asarray(delta, float))
    t = max(np.max(15 / 8 * d / v_max), np.max(np.sqrt(10 / np.sqrt(3) * d / a_max)))
    return max(float(t), 1e-3)


# ---- piecewise ---------------------------------------------------------------------------

def test_sampling_at_the_start_gives_the_start_state_even_after_a_zero_length_segment():
    # segment 0 lasts no time (knots 0, 0) and starts at 5; segment 1 starts at 7
    c = np.zeros((2, 1, 6))
    c[0, 0, 0], c[1, 0, 0] = 5.0, 7.0
    traj = JointTrajectory([0.0, 0.0, 1.0], c)
    before, at = traj.state_at(-0.1)[0], traj.state_at(0.0)[0]
    assert before[0] == 5.0 and at[0] == 5.0


@pytest.mark.parametrize(("knots", "shape"), [
    ([0.0, 1.0], (1, 2, 5)),  # five coefficients, not six
    ([0.0], (0, 2, 6)),  # no segment at all
])
def test_coefficients_of_the_wrong_shape_are_refused(knots, shape):
    with pytest.raises(TrajectoryError, match="coefficients must be"):
        JointTrajectory(knots, np.zeros(shape))


@pytest.mark.parametrize(("knots", "segments"), [
    ([0.0, 1.0, 2.0], 1),  # one knot too many (non-decreasing)
    ([1.0, 0.0], 1),  # decreasing
    ([0.0, 0.5, 0.2], 2),  # decreasing by less than a second
])
def test_knots_must_be_non_decreasing_one_more_than_the_segments(knots, segments):
    with pytest.raises(TrajectoryError, match="knots must be non-decreasing"):
        JointTrajectory(knots, np.zeros((segments, 1, 6)))


def test_trajectory_coefficients_and_knots_are_read_only():
    traj = point_to_point([0.0], [1.0], JointLimits([1.0], [1.0]))
    with pytest.raises(ValueError):
        traj.coeffs[0, 0, 0] = 3.0
    with pytest.raises(ValueError):
        traj.knots[0] = 3.0


# ---- planning: limits ---------------------------------------------------------------------

def test_limits_compare_and_hash_by_identity():
    a, b = JointLimits([1.0, 2.0], [3.0, 4.0]), JointLimits([1.0, 2.0], [3.0, 4.0])
    assert a == a and (a == b) is False
    assert len({a, b}) == 2  # usable as a key (arrays themselves are not hashable)


def test_limits_are_frozen():
    lim = JointLimits([1.0], [1.0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        lim.v_max = np.array([2.0])


def test_position_limits_of_the_wrong_shape_are_refused():
    with pytest.raises(TrajectoryError, match="q_min < q_max, one per joint"):
        JointLimits([1.0, 1.0], [1.0, 1.0], [-1.0], [1.0, 1.0])  # q_min for one joint only


def test_from_model_scales_the_models_velocity_limits():
    model = SimpleNamespace(nq=2, v_max=np.array([2.0, 4.0]), q_min=np.array([-1.0, -2.0]), q_max=np.array([1.0, 2.0]))
    lim = JointLimits.from_model(model, 3.0, velocity_scale=0.5)
    np.testing.assert_array_equal(lim.v_max, [1.0, 2.0])
    np.testing.assert_array_equal(lim.a_max, [3.0, 3.0])


def _model():
    return SimpleNamespace(nq=2, v_max=np.array([2.0, np.inf]), q_min=np.array([-1.0, -2.0]),
                           q_max=np.array([1.0, 2.0]))


def test_for_run_defaults_without_a_trajectory_table():
    # documented: model limits (1 rad/s where none) × 0.5, 5 rad/s², the model's range
    lim = JointLimits.for_run(_model())
    np.testing.assert_array_equal(lim.v_max, [1.0, 0.5])
    np.testing.assert_array_equal(lim.a_max, [5.0, 5.0])
    np.testing.assert_array_equal(lim.q_min, [-1.0, -2.0])


def test_for_run_takes_the_tables_velocity_scale():
    table = SimpleNamespace(velocity_scale=0.25, max_acceleration=None)
    lim = JointLimits.for_run(_model(), table)
    np.testing.assert_array_equal(lim.v_max, [0.5, 0.25])
    np.testing.assert_array_equal(lim.a_max, [5.0, 5.0])


def test_a_position_exactly_at_a_limit_is_inside_the_range():
    lim = JointLimits([1.0, 1.0], [1.0, 1.0], [-1.0, -1.0], [1.0, 1.0])
    lim.check_position(np.array([-1.0, 1.0]), "start")
    traj = point_to_point([-1.0, -1.0], [1.0, 1.0], lim)
    np.testing.assert_allclose(traj.state_at(traj.t_end)[0], [1.0, 1.0])


def test_out_of_range_error_names_the_first_bad_joint():
    lim = JointLimits([1.0] * 3, [1.0] * 3, [-1.0] * 3, [1.0] * 3)
    with pytest.raises(TrajectoryError, match=r"^start: joint 1 at 5 is outside \[-1, 1\]$"):
        lim.check_position(np.array([0.0, 5.0, 7.0]), "start")


# ---- planning: defaults, dwell, waits, holds ------------------------------------------------

def test_trajectories_start_at_time_zero_by_default():
    lim = JointLimits([1.0], [1.0])
    assert hold([0.5]).t_start == 0.0
    assert point_to_point([0.0], [1.0], lim).t_start == 0.0
    assert through_waypoints([[0.0], [1.0]], lim).t_start == 0.0


def test_dwell_applies_at_the_last_waypoint_too():
    lim = JointLimits([1.0, 1.0], [2.0, 2.0])
    traj = through_waypoints([[0.0, 0.0], [1.0, 0.5]], lim, dwell=0.5)
    T = r2r([1.0, 0.5], lim.v_max, lim.a_max)
    np.testing.assert_allclose(np.diff(traj.knots), [0.5, T, 0.5], rtol=1e-12)
    q, qd, _ = traj.state_at(traj.t_end - 0.5)
    np.testing.assert_allclose(q, [1.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)


def test_dwell_at_a_single_waypoint():
    traj = through_waypoints([[0.3, 0.0]], JointLimits([1.0, 1.0], [2.0, 2.0]), dwell=0.5)
    assert traj.duration == 0.5
    np.testing.assert_array_equal(traj.state_at(0.25)[0], [0.3, 0.0])


def test_a_duration_between_a_repeated_point_and_itself_is_a_wait():
    traj = through_waypoints([[0.2, 0.1], [0.2, 0.1]], JointLimits([1.0, 1.0], [2.0, 2.0]), durations=[2.0])
    assert traj.duration == 2.0
    np.testing.assert_array_equal(traj.state_at(1.0)[0], [0.2, 0.1])


def test_without_motion_it_holds_the_last_waypoint_itself():
    # a start 5e-13 rad away counts as the same point: no segment, hold the waypoint as given
    traj = through_waypoints([[0.0, 1.0]], JointLimits([1.0, 1.0], [2.0, 2.0]), start=[5e-13, 1.0])
    assert traj.duration == 0.0
    np.testing.assert_array_equal(traj.state_at(1.0)[0], [0.0, 1.0])


# ---- planning: error messages ---------------------------------------------------------------

def test_segment_errors_are_labelled():
    lim = JointLimits([1.0, 1.0], [2.0, 2.0])
    with pytest.raises(TrajectoryError, match=r"^the move to waypoint 0: duration 0\.1 s violates"):
        retarget(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [[1.0, 1.0]], lim, duration=0.1)
    with pytest.raises(TrajectoryError, match=r"^segment 0: duration 0\.01 s violates"):
        through_waypoints([[1.0, 1.0], [2.0, 1.5]], lim, start=[0.0, 0.0], smooth=True, durations=[0.01, 0.01])


_DETAIL = re.compile(r"peak \|q̇\|/v_max (\S+), \|q̈\|/a_max ([^,)]+)(?:, range \[(.*)\] \.\. \[(.*)\])?\)$")


def _detail(limits):
    # from rest at (0, 0) to (1, -0.5) in 1 s: peaks 15/8·|Δ| and 10/√3·|Δ| (T = 1), range from the ends
    with pytest.raises(TrajectoryError) as err:
        retarget(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [[1.0, -0.5]], limits, duration=1.0)
    return _DETAIL.search(str(err.value))


def test_waypoint_errors_count_from_the_first_waypoint_after_the_start():
    lim = JointLimits([1.0], [1.0], [-1.0], [1.0])
    with pytest.raises(TrajectoryError, match=r"^waypoint 1: joint 0 at 5 is outside"):
        through_waypoints([[0.5], [5.0]], lim, start=[0.0])


def test_smooth_run_error_names_the_failing_segment():
    # 0 → 1 → 0.9: the joint reverses at the via point (zero via state), so segment 0 (1 rad
    # in 10 s) fits and segment 1 (0.1 rad in 10 ms) does not
    lim = JointLimits([1.0], [1.0])
    with pytest.raises(TrajectoryError, match=r"^segment 1: duration 0\.01 s violates"):
        through_waypoints([[1.0], [0.9]], lim, start=[0.0], smooth=True, durations=[10.0, 0.01])


def test_a_requested_duration_within_the_tolerance_below_the_minimum_is_accepted():
    # velocity-limited: 15/8 · 1 rad / 1 rad/s = 1.875 s; the documented tolerance is 1e-9 relative
    T = 1.875 * (1 - 1e-9)
    traj = point_to_point([0.0], [1.0], JointLimits([1.0], [100.0]), duration=T)
    assert traj.duration == T


def test_limit_violation_message_reports_the_peaks_and_range():
    lim = JointLimits([1.0, 1.0], [2.0, 2.0], [-3.0, -3.0], [3.0, 3.0])
    m = _detail(lim)
    assert m is not None
    assert float(m[1]) == pytest.approx(15 / 8, rel=1e-3)
    assert float(m[2]) == pytest.approx(10 / np.sqrt(3) / 2.0, rel=1e-3)
    lo = [float(x) for x in m[3].split(", ")]
    hi = [float(x) for x in m[4].split(", ")]
    np.testing.assert_allclose(lo, [0.0, -0.5], atol=1e-9)
    np.testing.assert_allclose(hi, [1.0, 0.0], atol=1e-9)


def test_limit_violation_message_has_no_range_without_position_limits():
    m = _detail(JointLimits([1.0, 1.0], [2.0, 2.0]))
    assert m is not None and m[3] is None


def test_retarget_duration_is_checked_first():
    lim = JointLimits([1.0, 1.0], [2.0, 2.0])
    with pytest.raises(TrajectoryError, match=r"^duration 0: -1 s must be positive and at most 1e\+06 s$"):
        retarget(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [[1.0, 1.0]], lim, duration=-1.0)


def test_a_segment_of_exactly_the_longest_duration_is_allowed():
    # documented: durations in (0, MAX_DURATION_S], the bound included
    lim = JointLimits([1.0, 1.0], [2.0, 2.0])
    new = retarget(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [[1.0, 1.0]], lim, duration=MAX_DURATION_S)
    assert new.t_end == MAX_DURATION_S


# ---- planning: retarget ----------------------------------------------------------------------

def test_retarget_brake_then_short_move_reaches_the_waypoint():
    # the braking case of test_retarget.py time-scaled by 4 (limits ×4, ×16): no single quintic
    # fits, and the move from rest after braking is well under a second
    lim = JointLimits([4.0, 4.0], [32.0, 32.0], [-3.0, -3.0], [3.0, 3.0])
    q, v, a, w = np.zeros(2), np.array([3.2, 0.0]), np.array([16.0, 0.0]), np.array([2.0, 0.0])
    assert shortest_duration(q, v, a, w, lim.v_max, lim.a_max, lim.q_min, lim.q_max) is None
    new = retarget(0.5, q, v, a, [w], lim)
    assert len(new.knots) == 3  # braking, then the move
    q_stop, v_stop, _ = new.state_at(new.knots[1])
    np.testing.assert_allclose(v_stop, 0.0, atol=1e-9)
    assert new.knots[2] - new.knots[1] == pytest.approx(r2r(w - q_stop, lim.v_max, lim.a_max), rel=1e-9)
    assert new.knots[2] - new.knots[1] < 1.0
    np.testing.assert_allclose(new.state_at(new.t_end)[0], w, atol=1e-12)
    assert_continuous(new)
    assert_within(new, lim)


def test_retarget_with_a_duration_that_must_brake_goes_to_the_first_waypoint():
    lim = JointLimits([1.0, 1.0], [2.0, 2.0], [-3.0, -3.0], [3.0, 3.0])
    q, v, a = np.zeros(2), np.array([0.8, 0.0]), np.array([1.0, 0.0])
    W = np.array([[2.0, 0.0], [0.5, 1.0]])
    new = retarget(0.5, q, v, a, W, lim, duration=5.0)
    assert len(new.knots) == 4  # braking, the rest of the 5 s to waypoint 0, to waypoint 1
    assert new.knots[2] == pytest.approx(5.5, rel=1e-12)
    p, pv, _ = new.state_at(new.knots[2])
    np.testing.assert_allclose(p, W[0], atol=1e-12)
    np.testing.assert_allclose(pv, 0.0, atol=1e-9)
    assert_continuous(new)
    assert_within(new, lim)


def test_retarget_with_a_duration_that_one_quintic_meets_does_not_brake():
    # slow motion, long duration: one quintic to rest at the waypoint stays within the limits
    lim = JointLimits([0.5, 0.5], [0.5, 0.5])
    new = retarget(0.0, [0.0, 0.0], [0.1, 0.0], [0.0, 0.0], [[1.0, 0.5]], lim, duration=6.0)
    assert len(new.knots) == 2 and new.t_end == 6.0
    np.testing.assert_allclose(new.state_at(6.0)[0], [1.0, 0.5], atol=1e-12)
    assert_within(new, lim)


# ---- quintic -------------------------------------------------------------------------------

def test_tiny_move_takes_at_least_the_minimum_segment_time():
    assert rest_to_rest_duration([1e-9], np.array([1.0]), np.array([1.0])) == 1e-3


def test_extrema_of_a_polynomial_of_lower_degree():
    # q = τ − τ³/3 on [0, 2]: q̇ = 1 − τ² (max of q 2/3 at τ = 1), q(2) = −2/3, |q̇| ≤ 3, |q̈| = 2τ ≤ 4
    e = extrema(np.array([[0.0, 1.0, 0.0, -1.0 / 3.0, 0.0, 0.0]]), 2.0)
    np.testing.assert_allclose(e[:, 0], [-2 / 3, 2 / 3, 3.0, 4.0], rtol=1e-12)


def _braking(v0, a0, v_max, a_max):
    T = shortest_duration(np.zeros(1), np.array([v0]), np.array([a0]), None, np.array([v_max]), np.array([a_max]))
    assert T is not None
    return T


def test_a_joint_at_its_velocity_limit_can_brake():
    # v = v0(1−s)²(1+2s) never exceeds v0; |q̈| peaks at 1.5·v0/T (s = ½): T ≥ 1.5·v0/a_max
    assert 0.75 <= _braking(1.0, 0.0, 1.0, 2.0) <= 0.75 * 1.03


def test_a_joint_at_its_acceleration_limit_can_brake():
    # v0 = 0: q̈ = a0(1−s)(1−3s) never exceeds a0, |q̇| ≤ a0·T·4/27 — so the shortest segment
    assert _braking(0.0, 2.0, 1.0, 2.0) == 1e-3


@pytest.mark.parametrize(("v0", "v_max", "a_max"), [
    (1e-3, 1.0, 1.0),  # a braking time (1.5 ms) far below a second
    (1.0, 2.0, 100.0),  # a large acceleration limit: 15 ms
])
def test_braking_takes_the_shortest_time_within_two_percent(v0, v_max, a_max):
    t = 1.5 * v0 / a_max
    assert t <= _braking(v0, 0.0, v_max, a_max) <= t * 1.03


def test_shortest_duration_from_rest_far_from_zero_is_the_closed_form():
    vm, am = np.array([1.0]), np.array([1.0])
    T = shortest_duration(np.array([100.0]), np.zeros(1), np.zeros(1), np.array([100.01]), vm, am)
    t = r2r([0.01], vm, am)
    assert t * (1 - 1e-9) <= T <= t * 1.03


def test_fits_includes_the_tolerance_bound():
    # constant acceleration 2 over 1 s: peak |q̈| = 2 = a_max·(1 + rtol) with a_max = 1, rtol = 1
    c = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
    assert fits(c, 1.0, np.array([10.0]), np.array([1.0]), rtol=1.0)
    # held exactly at q_min − rtol·span (span 1)
    assert fits(np.array([[-2.0, 0, 0, 0, 0, 0]]), 1.0, np.array([1.0]), np.array([1.0]),
                np.array([-1.0]), np.array([1.0]), rtol=1.0)


def test_fits_refuses_an_acceleration_over_the_limit():
    c = np.array([[0.0, 0.0, 0.75, 0.0, 0.0, 0.0]])  # q̈ = 1.5 throughout
    assert not fits(c, 1.0, np.array([10.0]), np.array([1.0]))


def test_fits_position_tolerance_is_relative_to_the_span():
    # span = max(|q_min|, |q_max|) = 2; with rtol = 1 positions down to −4 and up to 4 fit
    vm, am, lo, hi = np.array([1.0]), np.array([1.0]), np.array([-2.0]), np.array([2.0])
    for q in (-3.5, 3.5):
        assert fits(np.array([[q, 0, 0, 0, 0, 0]]), 1.0, vm, am, lo, hi, rtol=1.0)
    assert not fits(np.array([[4.5, 0, 0, 0, 0, 0]]), 1.0, vm, am, lo, hi, rtol=1.0)


def test_fits_at_the_position_limits_themselves():
    vm, am, lo, hi = np.array([1.0]), np.array([1.0]), np.array([-1.0]), np.array([1.0])
    assert fits(np.array([[-1.0, 0, 0, 0, 0, 0]]), 1.0, vm, am, lo, hi)
    assert fits(np.array([[1.0, 0, 0, 0, 0, 0]]), 1.0, vm, am, lo, hi)


def test_fits_compares_positions_not_speeds_with_the_range():
    vm, am, lo, hi = np.array([10.0]), np.array([10.0]), np.array([-1.0]), np.array([1.0])
    fast_inside = np.array([[0.0, 2.0, 0.0, 0.0, 0.0, 0.0]])  # q = 2τ over 0.25 s: up to 0.5, speed 2
    assert fits(fast_inside, 0.25, vm, am, lo, hi)
    slow_outside = np.array([[0.0, 0.5, 0.0, 0.0, 0.0, 0.0]])  # q = τ/2 over 4 s: up to 2, speed 0.5
    assert not fits(slow_outside, 4.0, vm, am, lo, hi)
    slow_below = np.array([[0.0, -0.5, 0.0, 0.0, 0.0, 0.0]])  # q = −τ/2 over 4 s: down to −2
    assert not fits(slow_below, 4.0, vm, am, lo, hi)


# ---- smooth --------------------------------------------------------------------------------

def test_via_accelerations_are_the_central_difference_of_the_slopes():
    # durations 1, 2, 4 and slopes 1, 1.5, 2: v = the means, a = 2·Δslope / (T_before + T_after)
    T = np.array([1.0, 2.0, 4.0])
    points = np.array([[0.0], [1.0], [4.0], [12.0]])
    v, a = via_states(points, T)
    np.testing.assert_allclose(v[:, 0], [0.0, 1.25, 1.75, 0.0])
    np.testing.assert_allclose(a[:, 0], [0.0, 2 * 0.5 / 3.0, 2 * 0.5 / 6.0, 0.0])


def test_a_run_symmetric_in_time_gets_equal_durations():
    # 0 → 1 → 2: the second half mirrors the first, so both segments take the same time
    points = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 1.0]])
    T = fit_durations(points, np.array([1.0, 1.0]), np.array([2.0, 2.0]))
    assert T[0] == pytest.approx(T[1], rel=1e-9)
