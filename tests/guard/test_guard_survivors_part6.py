"""Tests for guard mutants that survived the full run's fast pass after part5 (docs/mutation/guard.md),
each against the documentation or a value worked out by hand: the clamp's wall on a slanted
face (its force along the face's unit normal, damped by the inward speed along it), the smooth
route's certificate at half the margin, the fallback trajectory starting at the route's start,
``plan_route``'s keyword-only options, joint limits with a NaN on one side only, clamp mode
exactly on the inner band's edge, a negative stiffness, a v_max of 0 for the trajectory
certificate, the first out-of-range joint of a zone named, the first time a trajectory comes
too close (not a later one), a point exactly on a face (in the margin, not inside), a guarded
move's duration on a clear route, the plan's resolution, ``prepare`` skipping the groups it
builds no graph for, a vanishing margin that must not empty a zone's shape, the per-tick
check's first face of each piece (a face of another piece let the first tick skip a zone), a
route of just its start, a route's length, a plan from a start inside a zone, a trajectory
exactly on its limits, the first joint named past two limits at once, a route's trajectory
starting at t = 0 by default, the per-tick report's zone, face and piece, a zone and a limit
band entered at the same point (the zone is named), the first of two equally close zones, the
grid's heuristic, and a polygon's size along the axes."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.guard import Box, Polygon, Scene, Zone
from rtctl.guard.kernels import DAMPING, N_PARAMS, STIFFNESS, _push_out
from rtctl.trajectory import JointLimits
from rtctl.trajectory.planning import hold

LIMITS = JointLimits([1.0, 1.0], [2.0, 2.0])


def test_the_wall_on_a_slanted_face_pushes_along_its_normal_and_damps_the_inward_speed():
    """``_push_out``'s docstring: a wall force stiffness × depth + damping × inward speed along
    the outward unit normal w. For w = (0.6, 0.8), depth 0.01, stiffness 1000, damping 50 and
    q̇ = (−1, −0.5) the inward speed is 0.6 + 0.4 = 1 rad/s, so the wall is 10 + 50 = 60 N·m
    along w: τ = (36, 48) on a command of zero."""
    par = np.zeros(N_PARAMS)
    par[STIFFNESS], par[DAMPING] = 1000.0, 50.0
    q, qd = np.array([0.5, 0.5]), np.array([-1.0, -0.5])
    q_des, qd_des, tau = q.copy(), np.zeros(2), np.zeros(2)
    _push_out(0, 1, 0.6, 0.8, 0.01, q, qd, q_des, qd_des, tau, 0, par)
    np.testing.assert_allclose(tau, [36.0, 48.0], rtol=1e-12)


def _route_past_a_box(monkeypatch, gap: float):
    """A clear route (0, 0) → (3, 0) under the box [1, 2]² (margin 0.2), with the smooth
    trajectory replaced by one that stops at (1.5, 1 − gap): ``gap`` from the box's lower face."""
    from rtctl.guard import motion
    from rtctl.guard.motion import plan_route, route_trajectory

    scene = Scene([Zone("box", [Box((0, 1), [1.0, 1.0], [2.0, 2.0])])], [-8.0, -8.0], [8.0, 8.0], margin=0.2)
    route = plan_route(scene, [0.0, 0.0], [[3.0, 0.0]])
    assert not route.bypassed
    real = motion.through_waypoints

    def smooth_one_comes_close(points, limits, *, smooth=False, **options):
        if smooth:
            return real([[1.5, 1.0 - gap], [3.0, 0.0]], limits, **options)
        return real(points, limits, **options)

    monkeypatch.setattr(motion, "through_waypoints", smooth_one_comes_close)
    return route_trajectory(scene, route, LIMITS, smooth=True)


def test_a_smooth_trajectory_closer_than_half_the_margin_falls_back_to_the_straight_one_from_the_start(monkeypatch):
    """rtctl.guard.motion: a smooth trajectory is kept only when it stays half the margin
    (0.1 here) from every zone. One that passes 0.07 from the box is replaced by the
    stop-at-each-point trajectory, which starts at the route's start (0, 0) and ends at (3, 0)."""
    trajectory, smooth = _route_past_a_box(monkeypatch, 0.07)
    assert smooth is False
    q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
    trajectory.sample(float(trajectory.knots[0]), q, qd, qdd)
    np.testing.assert_allclose(q, [0.0, 0.0], atol=1e-12)
    trajectory.sample(float(trajectory.knots[-1]), q, qd, qdd)
    np.testing.assert_allclose(q, [3.0, 0.0], atol=1e-12)
    times = np.linspace(trajectory.knots[0], trajectory.knots[-1], 501)
    for t in times:  # the straight one: y stays 0
        trajectory.sample(float(t), q, qd, qdd)
        assert abs(q[1]) < 1e-12


def test_a_smooth_trajectory_beyond_half_the_margin_is_kept(monkeypatch):
    """The same with a gap of 0.13 (more than half the margin, less than the margin): kept."""
    trajectory, smooth = _route_past_a_box(monkeypatch, 0.13)
    assert smooth is True
    q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
    trajectory.sample(float(trajectory.knots[1]), q, qd, qdd)
    np.testing.assert_allclose(q, [1.5, 0.87], atol=1e-12)


def test_plan_route_takes_its_options_by_keyword_only():
    """``plan_route(scene, start, waypoints, *, resolution=…, …)``: the options are keyword-only
    (a resolution passed by position is refused), and the three points may be named."""
    from rtctl.guard.motion import plan_route

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(TypeError):
        plan_route(scene, [0.0, 0.0], [[0.5, 0.0]], 0.05)
    route = plan_route(scene=scene, start=[0.0, 0.0], waypoints=[[0.5, 0.0]])
    np.testing.assert_array_equal(route.points[-1], [0.5, 0.0])


@pytest.mark.parametrize("q_min, q_max", [([np.nan, 0.0], [1.0, 1.0]), ([0.0, 0.0], [1.0, np.nan])])
def test_limits_with_a_nan_on_one_side_only_are_refused(q_min, q_max):
    """A Scene needs q_min < q_max for every joint; NaN compares false with everything, so a
    NaN in q_min alone or in q_max alone must be refused as well."""
    with pytest.raises(ValueError, match="q_min < q_max"):
        Scene([], q_min, q_max)


def test_clamp_at_rest_exactly_on_the_inner_bands_edge_pushes_along_that_face():
    """guard_tick: with CLAMP the command is pushed out along every face that separates q from
    the inner band (zone ⊕ g/2) — q on that band's boundary is not inside it, so the face counts.
    Box [−0.5, 0.5]², g = 0.5, at rest at x = −0.75 (exactly g/2 from the face x = −0.5): the
    stopping path is in the outer half, not the inner one, so the verdict is MODIFIED with a wall
    of stiffness × depth = 1000 × (0.5 + 0.5 − 0.75) = 250 N·m along the face's normal (−1, 0)."""
    from rtctl.guard import RuntimeGuard
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0])
    g = RuntimeGuard(scene, np.array([10.0, 10.0]), 0.001, margin=0.5, action="clamp", damping=0.0, stiffness=1000.0)
    state, command = JointState(2), JointCommand(2)
    state.position[:] = [-0.75, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.MODIFIED
    np.testing.assert_array_equal(command.tau_ff, [-250.0, 0.0])


def test_a_negative_stiffness_is_refused():
    """RuntimeGuard: damping and stiffness "finite and >= 0" — a stiffness just below 0 is not."""
    from rtctl.guard import RuntimeGuard

    with pytest.raises(ValueError, match="finite and >= 0"):
        RuntimeGuard(Scene([], [-1.0], [1.0]), 10.0, 0.001, stiffness=-1e-9)


@pytest.mark.parametrize("v_max", [[0.0, 1.0], [1.0, -0.5]])
def test_the_trajectory_certificate_refuses_a_v_max_that_is_not_positive(v_max):
    """``trajectory_violation``: v_max must be n finite positive values (it bounds the motion
    between samples; 0 or a negative value would make the certificate vacuous)."""
    from rtctl.guard.feasibility import trajectory_violation

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="finite positive"):
        trajectory_violation(scene, hold(np.zeros(2), 0.0), 0.1, v_max)


def test_a_zone_on_joints_the_robot_lacks_names_the_first_of_them():
    """Every fault names its cause: a zone over joints (5, 7) of a 2-joint robot names joint
    index 5, the first one out of range."""
    with pytest.raises(ValueError, match=r"joint index 5 out of range \(the robot has 2 joints\)"):
        Scene([Zone("far", [Box((5, 7), [0.0, 0.0], [1.0, 1.0])])], [-1.0, -1.0], [1.0, 1.0])


def test_the_certificate_reports_the_first_time_the_trajectory_comes_too_close():
    """``trajectory_violation``: "the first time the trajectory comes closer than clearance".
    Along y = 0 from x = −2 to 2 through the box [−0.5, 0.5]² with clearance 0.1, samples are
    flagged below 0.1 + ½·step = 0.125 (step = 0.05), i.e. at x > −0.625, and they lie at most
    0.05 apart: the report is the first of them, at x ∈ (−0.625, −0.575], not one on the far side."""
    from rtctl.guard.feasibility import trajectory_violation
    from rtctl.trajectory import through_waypoints

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0])
    trajectory = through_waypoints([[2.0, 0.0]], LIMITS, start=[-2.0, 0.0])
    hit = trajectory_violation(scene, trajectory, 0.1, [1.0, 1.0])
    assert hit is not None and hit.what == "box"
    assert -0.625 < hit.q[0] <= -0.575, hit


def test_a_point_exactly_on_a_zones_face_is_in_its_margin_not_inside_it():
    """``Violation.inside``: False when only the margin is entered. Zones are open: a trajectory
    resting exactly on the face x = −0.5 of the box [−0.5, 0.5]² (depth 0) comes too close but
    is not inside."""
    from rtctl.guard.feasibility import trajectory_violation

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0])
    hit = trajectory_violation(scene, hold([-0.5, 0.0]), 0.1, [1.0, 1.0])
    assert hit is not None and hit.what == "box" and not hit.inside


def test_a_guarded_move_with_a_duration_on_a_clear_route_keeps_the_duration():
    """``retarget_around``: only a move that has to go around a zone refuses a duration; on a
    clear route the trajectory from rest ends at t + duration at the target."""
    from rtctl.guard.motion import retarget_around

    scene = Scene([Zone("box", [Box((0, 1), [2.0, 2.0], [3.0, 3.0])])], [-8.0, -8.0], [8.0, 8.0], margin=0.1)
    trajectory, route = retarget_around(scene, 1.0, np.zeros(2), np.zeros(2), np.zeros(2), [[1.0, 0.0]], LIMITS,
                                        duration=4.0)
    assert not route.bypassed
    assert trajectory.knots[-1] == pytest.approx(5.0, abs=1e-12)
    q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
    trajectory.sample(5.0, q, qd, qdd)
    np.testing.assert_allclose(q, [1.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("resolution", [0.0, -0.5, np.inf, np.nan])
def test_a_plan_needs_a_finite_positive_resolution(resolution):
    """``plan_path``: the grid's resolution must be finite and > 0 (ValueError otherwise)."""
    from rtctl.guard.planner import plan_path

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="resolution must be > 0"):
        plan_path(scene, [0.0, 0.0], [0.5, 0.0], resolution=resolution)


def test_prepare_skips_groups_that_are_not_two_joints_within_finite_limits():
    """``prepare``: visibility graphs only for two-joint groups within finite limits — a zone over
    three joints (searched on a grid) and one in a plane with an unbounded joint get none, and
    preparing such a scene works."""
    from rtctl.guard import planner

    inf = np.inf
    scene = Scene([Zone("cube", [Box((0, 1, 2), [-0.5, -0.5, -0.5], [0.5, 0.5, 0.5])]),
                   Zone("slab", [Box((3, 4), [-0.5, -0.5], [0.5, 0.5])])],
                  [-3.0, -3.0, -3.0, -inf, -3.0], [3.0, 3.0, 3.0, inf, 3.0], margin=0.1)
    planner.prepare(scene)
    assert not planner._MAPS.get(scene)


@pytest.mark.parametrize("margin", [1e-300, 5e-324])
def test_a_vanishing_margin_does_not_empty_a_zones_shape(margin):
    """``inflated_shape`` (planning and plots): the piece grown by the margin. GEOS returns an
    empty polygon when buffering by a tiny distance (1e-300 here): a margin that small must still
    give the piece itself — the triangle of area ½ and the unit box."""
    scene = Scene([Zone("tri", [Polygon((0, 1), [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])]),
                   Zone("box", [Box((0, 1), [2.0, 2.0], [3.0, 3.0])])], [-5.0, -5.0], [5.0, 5.0])
    bounds = (-5.0, -5.0, 5.0, 5.0)
    assert scene.inflated_shape(0, (0, 1), margin, bounds).area == pytest.approx(0.5, abs=1e-9)
    assert scene.inflated_shape(1, (0, 1), margin, bounds).area == pytest.approx(1.0, abs=1e-9)


A = Zone("A", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])


@pytest.mark.parametrize("zones", [
    [A, Zone("B", [Box((0, 1), [-3.0, -1.0], [-2.0, 1.0])])],  # B's first face: q₀ ≥ −2
    [Zone("B", [Box((0, 1), [-3.0, -3.0], [-2.0, -1.0])]),  # B's third face: q₁ ≥ −1
     Zone("C", [Box((0, 1), [3.0, 3.0], [4.0, 4.0])]), A],
])
def test_the_first_tick_checks_every_piece_not_a_face_of_another_one(zones):
    """The per-tick check skips a piece when the stopping path lies outside the face it
    remembers for it — ``pack``: initially each piece's own first row. A = [−0.5, 0.5]² among
    boxes with a face the robot lies outside of (the row just after A's, or row 2, A's zone
    index). At rest at (−0.51, 0), inside A's guard margin of 0.02, the very first check stops."""
    from rtctl.guard import RuntimeGuard
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    scene = Scene(zones, [-5.0, -5.0], [5.0, 5.0])
    g = RuntimeGuard(scene, np.array([10.0, 10.0]), 0.001, margin=0.02)
    state, command = JointState(2), JointCommand(2)
    state.position[:] = [-0.51, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.STOP
    assert g.event()["zone"] == "A"


def test_a_route_of_just_its_start_holds_the_start():
    """``route_trajectory``: the trajectory through the route from its start — a route with no
    waypoint is the start alone, held from t0."""
    from rtctl.guard.motion import plan_route, route_trajectory

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    route = plan_route(scene, [0.3, -0.2], np.empty((0, 2)))
    for smooth in (False, True):
        trajectory, _ = route_trajectory(scene, route, LIMITS, smooth=smooth, t0=1.5)
        q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
        trajectory.sample(7.0, q, qd, qdd)
        np.testing.assert_array_equal(q, [0.3, -0.2])
        assert trajectory.knots[0] == 1.5


def test_the_length_of_a_route_is_the_sum_of_its_segments():
    """``Route.length``: (0, 0) → (3, 4) → (3, 0) is 5 + 4 = 9."""
    from rtctl.guard.motion import plan_route

    scene = Scene([], [-9.0, -9.0], [9.0, 9.0])
    assert plan_route(scene, [0.0, 0.0], [[3.0, 4.0], [3.0, 0.0]]).length == pytest.approx(9.0, rel=1e-15)


def test_a_plan_from_a_start_inside_a_zone_is_not_found_and_says_why():
    """``plan_path``: a start inside a zone gives no path (``found`` False), the reason naming
    the start; ``plan_route`` turns it into a GuardError naming the first waypoint."""
    from rtctl.errors import GuardError
    from rtctl.guard.motion import plan_route
    from rtctl.guard.planner import plan_path

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0])
    plan = plan_path(scene, [0.0, 0.0], [2.0, 0.0])
    assert not plan.found and plan.path is None and plan.reason.startswith("the start is")
    with pytest.raises(GuardError, match="waypoint 0: cannot go there from the start: the start is"):
        plan_route(scene, [0.0, 0.0], [[2.0, 0.0]])


@pytest.mark.parametrize("q", [[-3.0, 0.0], [3.0, 0.0], [-3.0, 3.0]])
def test_a_trajectory_exactly_on_its_limits_keeps_them(q):
    """The limits are inclusive (q_min ≤ q ≤ q_max): a trajectory resting exactly on one, far
    from every zone, has no violation."""
    from rtctl.guard.feasibility import trajectory_violation

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0])
    assert trajectory_violation(scene, hold(q), 0.1, [1.0, 1.0]) is None


def test_a_trajectory_past_two_limits_at_once_names_the_first_joint():
    """A violation names its cause: past both joints' limits at the same sample, the report names
    the first joint's limit, as every other check of the limits does."""
    from rtctl.guard.feasibility import trajectory_violation

    scene = Scene([], [-3.0, -3.0], [3.0, 3.0], joint_names=("shoulder", "elbow"))
    hit = trajectory_violation(scene, hold([3.5, -3.5]), 0.1, [1.0, 1.0])
    assert hit is not None and hit.what == "shoulder limit"


def test_a_routes_trajectory_starts_at_time_zero_unless_told():
    """``route_trajectory(…, t0=0.0)``: without t0 the trajectory starts at t = 0 at the route's start."""
    from rtctl.guard.motion import plan_route, route_trajectory

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    trajectory, _ = route_trajectory(scene, plan_route(scene, [0.0, 0.0], [[0.5, 0.0]]), LIMITS)
    assert trajectory.knots[0] == 0.0


def test_the_report_names_the_zone_face_and_piece_the_stopping_path_enters():
    """guard_tick's ``report``: KIND, and for a zone the zone's index (WHICH), the face row
    (FACE) and the piece (PIECE). A = [−0.5, 0.5]² is piece 0 (rows 0–3), B = [2, 3] × [−1, 1]
    piece 1 (rows 4–7: q₀ ≥ 3, q₀ ≤ 2, q₁ ≥ 1, q₁ ≤ −1). From 1.95 at 1 rad/s, braking at
    10 rad/s², the stop point is 1.95 + 0.051 = 2.001: the path enters B through row 5."""
    from rtctl.guard import RuntimeGuard
    from rtctl.guard import kernels as k
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    scene = Scene([A, Zone("B", [Box((0, 1), [2.0, -1.0], [3.0, 1.0])])], [-5.0, -5.0], [5.0, 5.0])
    g = RuntimeGuard(scene, np.array([10.0, 10.0]), 0.001, margin=0.02)
    state, command = JointState(2), JointCommand(2)
    state.position[:], state.velocity[:] = [1.95, 0.0], [1.0, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.STOP
    assert [int(g.report[i]) for i in (k.KIND, k.WHICH, k.FACE, k.PIECE)] == [k.ZONE, 1, 5, 1]


def test_a_zone_and_a_limit_band_both_entered_at_the_start_report_the_zone():
    """guard_tick: the first violation met along q→p is reported, and a limit only when it is met
    *before* the zone. Clamp mode, guard margin 0.02: at q₀ = 2.995 the robot is already inside the
    upper limit's band (from 2.99) and 0.015 from the box [2, 2.98] × [−1, 1] (inside its outer
    band); moving on at 0.1 rad/s both are met at s = 0 — a tie, so the zone is named."""
    from rtctl.guard import RuntimeGuard
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    scene = Scene([Zone("box", [Box((0, 1), [2.0, -1.0], [2.98, 1.0])])], [-3.0, -3.0], [3.0, 3.0])
    g = RuntimeGuard(scene, np.array([10.0, 10.0]), 0.001, margin=0.02, action="clamp")
    state, command = JointState(2), JointCommand(2)
    state.position[:], state.velocity[:] = [2.995, 0.0], [0.1, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.MODIFIED
    assert g.event()["zone"] == "box", g.event()


def test_a_point_as_close_to_two_zones_names_the_first_declared():
    """``clearance``: the smallest depth and the first piece with it — (1, 0) is 0.5 from both
    A = [−0.5, 0.5]² and C = [1.5, 2.5] × [−0.5, 0.5]: piece 0, and a trajectory resting there
    that must keep 0.6 names zone A."""
    from rtctl.guard.feasibility import trajectory_violation
    from rtctl.guard.kernels import clearance

    scene = Scene([A, Zone("C", [Box((0, 1), [1.5, -0.5], [2.5, 0.5])])], [-5.0, -5.0], [5.0, 5.0])
    assert clearance(*scene.tables(), np.array([1.0, 0.0])) == (0.5, 0)
    hit = trajectory_violation(scene, hold([1.0, 0.0]), 0.6, [1.0, 1.0])
    assert hit is not None and hit.what == "A"


def test_the_grids_heuristic_is_the_documented_sum_and_zero_near_the_goal():
    """``Grid.heuristic``: max(0, Σ|x − goal|/h − |J|) over the searched joints. Start 0, goal
    (0.95, 0.3, 0) with h = 0.1 over joints (0, 1, 2): at the start 9.5 + 3 − 3 = 9.5; at key
    (9, 3, 0), 0.05 from the goal, the sum is 0.5 − 3 < 0: the heuristic is 0, not less."""
    from rtctl.guard.grid import Grid

    scene = Scene([Zone("cube", [Box((0, 1, 2), [0.4, -1.0, -1.0], [0.5, 1.0, 1.0])])], [-2.0] * 3, [2.0] * 3)
    grid = Grid(scene.tables(), np.zeros(3), [0.95, 0.3, 0.0], (0, 1, 2), 0.1, 0.0, [-2.0] * 3, [2.0] * 3)
    assert grid.heuristic((0, 0, 0)) == pytest.approx(9.5, abs=1e-12)
    assert grid.heuristic((9, 3, 0)) == 0.0


def test_a_polygon_along_the_diagonal_is_measured_by_its_extent_along_the_axes():
    """The degeneracy test's size is max|v| plus the polygon's largest extent along an axis: for
    (0, 0), (1, 1), (1, 1 + 4·10⁻¹²) that is ≈ 2, and the area 2·10⁻¹² is below 10⁻¹²·2²: refused
    as flat, though each vertex's two coordinates are within 4·10⁻¹² of each other."""
    with pytest.raises(ValueError, match="no area"):
        Polygon((0, 1), [[0.0, 0.0], [1.0, 1.0], [1.0, 1.0 + 4e-12]])
