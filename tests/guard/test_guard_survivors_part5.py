"""Tests for guard mutants that survived the full run's fast pass (docs/mutation/guard.md), each against
the documentation or a value worked out by hand: impedance mode's desired velocity (only its
inward component is removed), the trajectory certificate exactly at its documented bound, the
smooth route's fallback reported as not smooth, a scene without joints or with limits of
unequal lengths, a polygon's shape in its plane with the joints in the other order and a box's
with a joint outside the plane, the visibility route's direct edge far from the origin, a
route's legs chained from waypoint to waypoint, ``retarget_around``'s keyword-only options, an
episode's end after exactly QUIET_TICKS clear ticks, a stop's own reason within a clamp episode,
the shortcut keeping the start, ``clearance`` without pieces, ``prepare`` building the visibility
graph, plan bounds around unbounded joints' zones, a limit violation naming its joint, frozen
zones and plans, a polygon flat for its size, A* from a blocked start, a smooth route that
keeps half the margin staying smooth, a guarded move from a moving state, the clamp's default
wall, the grid's extent from the start, clamp mode exactly on a limit, a zone before a limit on
the stopping path, a wall of zero damping and stiffness, the exact check of every segment
of a visibility route, the feasibility checks' margin, "inside" and polyline, a trajectory's
later segments, a violation in degrees, a route's first-leg message and waypoint flags, a
visibility plan's grid count, the unbounded joints' pad, a small deceleration, and the
visibility graph's inflation."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from rtctl.guard import Box, Polygon, Scene, Zone
from rtctl.guard.feasibility import trajectory_violation
from rtctl.guard.kernels import IMPEDANCE, N_PARAMS, _push_out
from rtctl.trajectory import JointLimits
from rtctl.trajectory.planning import hold


@pytest.mark.parametrize("qd_des, expected", [
    ([0.3, 0.4], [0.3, 0.4]),  # outward along the normal (0.6, 0.8), 0.5 rad/s: kept
    ([-0.3, -0.4], [0.0, 0.0]),  # inward, 0.5 rad/s: removed
    ([0.5, -0.3], [0.5, -0.3]),  # along the face (0.6·0.5 − 0.8·0.3 = 0.06 outward): kept
    ([-0.8 + 0.6, 0.6 + 0.8], [-0.8 + 0.6, 0.6 + 0.8]),  # tangent + 1 rad/s outward: kept
    ([-0.8 - 0.6, 0.6 - 0.8], [-0.8, 0.6]),  # tangent + 1 rad/s inward: the tangent is left
])
def test_impedance_mode_removes_only_the_inward_part_of_the_desired_velocity(qd_des, expected):
    """``_push_out``'s docstring: in impedance mode the drive holds the joints' current position
    and "gets no inward velocity" — the component along the outward normal w = (0.6, 0.8) is
    removed when it points inward (w·q̇_des < 0) and nothing else changes; an outward or
    tangential desired velocity, however small, is the controller's and passes."""
    q, qd = np.array([0.25, -0.5]), np.zeros(2)
    q_des, qd_des_arr, tau = np.array([9.0, 9.0]), np.array(qd_des, float), np.zeros(2)
    _push_out(0, 1, 0.6, 0.8, 0.0, q, qd, q_des, qd_des_arr, tau, IMPEDANCE, np.zeros(N_PARAMS))
    np.testing.assert_allclose(qd_des_arr, expected, atol=1e-15)
    assert np.array_equal(q_des, q)  # it holds where it is


def test_a_trajectory_exactly_at_the_certified_depth_passes_and_just_inside_it_does_not():
    """``trajectory_violation``'s docstring: samples with depth ≥ clearance + ½|v_max|Δt prove the
    clearance, Δt chosen so that the bound is a quarter of it: for clearance 0.5 the samples
    need depth ≥ 0.5 + 0.125 = 0.625 (all dyadic: exact). A hold 0.625 from the face x0 = 1 of
    the box [1, 2]² (beside it: x1 = 1.5) is certified; 0.624 from it is not."""
    scene = Scene([Zone("box", [Box((0, 1), [1.0, 1.0], [2.0, 2.0])])], [-3.0, -3.0], [3.0, 3.0])
    v_max = [1.0, 1.0]
    assert trajectory_violation(scene, hold([1.0 - 0.625, 1.5]), 0.5, v_max) is None
    bad = trajectory_violation(scene, hold([1.0 - 0.624, 1.5]), 0.5, v_max)
    assert bad is not None and bad.what == "box" and not bad.inside


def test_a_smooth_route_that_comes_too_close_falls_back_to_stops_and_says_it_is_not_smooth(monkeypatch):
    """``route_trajectory(smooth=True)`` returns (trajectory, whether it is smooth): when the
    smooth trajectory is not certified, the stop-at-each-point one comes back, reported False —
    at rest at its via point. (The smooth kind is made to fail its check here: in 700 random
    scenes of one to three boxes it never did.)"""
    from rtctl.guard import motion
    from rtctl.guard.motion import plan_route, route_trajectory

    scene = Scene([Zone("far", [Box((0, 1), [5.0, 5.0], [6.0, 6.0])])], [-8.0, -8.0], [8.0, 8.0])
    route = plan_route(scene, [0.0, 0.0], [[1.0, 0.5], [2.0, 0.0]])
    monkeypatch.setattr(motion, "trajectory_violation", lambda *a: "too close")
    trajectory, smooth = route_trajectory(scene, route, JointLimits([1.0, 1.0], [2.0, 2.0]), smooth=True)
    assert smooth is False
    q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
    trajectory.sample(float(trajectory.knots[1]), q, qd, qdd)
    np.testing.assert_allclose(q, [1.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(qd, 0.0, atol=1e-12)  # it stops there


@pytest.mark.parametrize("q_min, q_max", [([], []), (0.0, 1.0)], ids=["no joint", "scalars"])
def test_a_scene_needs_limits_for_at_least_one_joint(q_min, q_max):
    """The documented check "q_min < q_max, one per joint": a scene without any joint (empty
    limits) or with scalar limits is refused, not a zero-joint scene."""
    with pytest.raises(ValueError, match="q_min < q_max, one per joint"):
        Scene([], q_min, q_max)


def test_a_polygons_shape_in_its_plane_with_the_joints_swapped_is_its_mirror_image():
    """A triangle given in the plane (q0, q1); its shape in the plane (q1, q0) has every vertex
    with its two coordinates swapped (no margin: the polygon itself)."""
    triangle = [[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]]
    scene = Scene([Zone("t", [Polygon((0, 1), triangle)])], [-3.0, -3.0], [3.0, 3.0])
    bounds = (-3.0, -3.0, 3.0, 3.0)
    same = scene.inflated_shape(0, (0, 1), 0.0, bounds)
    swapped = scene.inflated_shape(0, (1, 0), 0.0, bounds)
    assert same.equals(shapely.Polygon(triangle))
    assert swapped.equals(shapely.Polygon([[y, x] for x, y in triangle]))


def test_the_visibility_route_beside_an_obstacle_is_the_segment_wherever_the_points_are():
    """Two points right of the box [2, 3]² that see each other, far from the origin: the straight
    segment (0.8 long) beats any way round the corners (about 3), so the path is [a, b] — the
    direct edge weighs |b − a|, the points' distance, not a length that grows with where they are."""
    from rtctl.guard.visibility import VisibilityMap

    m = VisibilityMap([shapely.box(2.0, 2.0, 3.0, 3.0)], (0.0, 0.0, 10.0, 10.0))
    a, b = np.array([4.0, 2.1]), np.array([4.0, 2.9])
    path = m.shortest_path(a, b, lambda p, q: True)
    assert path is not None and np.array_equal(path, [a, b]), path


def test_each_leg_of_a_route_starts_where_the_previous_one_ended():
    """``plan_route``: start → waypoints[0] → waypoints[1], each leg from the previous point. By
    hand: the box [−0.5, 0.5]² blocks the line from the start (−2, 0) to the second waypoint
    (2, 0), but not the legs (−2, 0) → (0, 2) (on y = x + 2, the nearest corner (−0.5, 0.5) is
    0.71 away) and (0, 2) → (2, 0) (on x + y = 2, the corner (0.5, 0.5) is 0.71 away), both
    more than the margin 0.1: the route is the three points, straight legs."""
    from rtctl.guard.motion import plan_route

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    route = plan_route(scene, [-2.0, 0.0], [[0.0, 2.0], [2.0, 0.0]])
    assert [leg.path[0].tolist() for leg in route.legs] == [[-2.0, 0.0], [0.0, 2.0]]
    assert route.points.tolist() == [[-2.0, 0.0], [0.0, 2.0], [2.0, 0.0]]


def test_a_box_on_a_joint_outside_the_plane_has_no_shape_there():
    """``inflated_shape`` of a box over joints (0, 2) asked in the plane (0, 1): joint 2 is not
    in it, which is refused naming the joint — not drawn as some band."""
    scene = Scene([Zone("b", [Box((0, 2), [1.0, 1.0], [2.0, 2.0])])], [-3.0] * 3, [3.0] * 3)
    with pytest.raises(ValueError, match="joint 2 outside the plane"):
        scene.inflated_shape(0, (0, 1), 0.0, (-3.0, -3.0, 3.0, 3.0))


def test_a_scene_with_as_many_upper_as_lower_limits_only():
    """"q_min < q_max, one per joint": two lower limits and one upper limit is refused with that
    message (broadcasting the one upper limit to both joints would accept it)."""
    with pytest.raises(ValueError, match="q_min < q_max, one per joint"):
        Scene([], [0.0, 0.0], [1.0])


def test_retarget_arounds_options_are_keyword_only():
    """The signature's ``*``: duration, resolution and the rest are named, never positional
    (a positional 8th argument is a TypeError, not a duration)."""
    import inspect

    from rtctl.guard.motion import retarget_around

    params = inspect.signature(retarget_around).parameters
    assert [p for p in params if params[p].kind is inspect.Parameter.KEYWORD_ONLY] == \
        ["duration", "resolution", "max_nodes", "deg"]


def _box_guard(**kw):
    from rtctl.guard import RuntimeGuard
    from rtctl.hal.joints import JointCommand, JointState

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    return RuntimeGuard(scene, np.array([10.0, 20.0]), 0.001, margin=0.02, **kw), JointState(2), JointCommand(2)


@pytest.mark.parametrize("quiet, new_episode", [(100, True), (99, False)])
def test_an_episode_ends_after_exactly_quiet_ticks_without_a_violation(quiet, new_episode):
    """rtctl.guard.runtime's doc: "an episode ends after QUIET_TICKS (100) ticks without a
    violation" — a violation after 100 clear ticks starts a new one (its event is due), after
    99 it is the same episode."""
    from rtctl.guard.runtime import QUIET_TICKS

    assert QUIET_TICKS == 100  # (docs/interference_guard.md says 100)
    g, state, command = _box_guard()
    state.position[:] = [-0.51, 0.0]  # at rest inside the band: a violation
    g.check(0.0, state, command)
    assert g.event_due
    state.position[:] = [-2.0, 0.0]
    for k in range(quiet):
        g.check(0.001 * (k + 1), state, command)
    state.position[:] = [-0.51, 0.0]
    g.check(0.001 * (quiet + 1), state, command)
    assert g.event_due == new_episode


def test_a_stop_within_a_clamp_episode_gives_its_own_reason():
    """Clamp mode: a stopping path in the outer half of the guard margin (0.02) is clamped, one in
    the inner half stops. At rest at x0 = −0.515 (0.005 into the band): clamped, the episode's
    event. Next tick at −0.505 (0.015 in): a stop — within the same episode, yet the reason the
    safety stage latches names where the robot is now."""
    from rtctl.safety import GuardVerdict

    g, state, command = _box_guard(action="clamp")
    state.position[:] = [-0.515, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.MODIFIED and g.event_due
    state.position[:] = [-0.505, 0.0]
    assert g.check(0.001, state, command) == GuardVerdict.STOP and not g.event_due
    assert "q = [-0.505, 0]" in g.reason, g.reason


def test_shortcut_keeps_the_start():
    """``shortcut``: "from each kept point, jump to the farthest later point in sight" — starting
    at the first point, which is always kept: with every segment free, [p0, p1, p2] → [p0, p2]."""
    from rtctl.guard.grid import shortcut

    points = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
    assert shortcut(points, lambda a, b: True).tolist() == [[0.0, 0.0], [1.0, 1.0]]


def test_clearance_without_pieces_is_infinite_and_names_no_piece():
    """The kernel's docstring: "+inf and -1 without pieces"."""
    from rtctl.guard.kernels import clearance

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    assert clearance(*scene.tables(), np.zeros(2)) == (np.inf, -1)


def test_prepare_builds_the_visibility_graph_of_a_two_joint_group_ahead_of_the_first_move():
    """``prepare``'s docstring: it builds the visibility graphs a plan will need — two-joint
    groups within finite limits — so that a first ``move`` does not build one on the loop."""
    from rtctl.guard import planner

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    planner.prepare(scene)
    assert len(planner._MAPS.get(scene, {})) == 1


def test_unbounded_joints_get_plan_bounds_around_the_points_and_the_zones():
    """``_bounds``' docstring: limits made finite "around the points and zones". By hand, joint 0
    with q0 = 0, q1 = 1 and a box over [3, 4]: values 0, 1, 3, 4 span 4, padded by 4 → [−4, 8];
    joint 1, box over [−1, 1] and points at 0: span 2 → [−3, 3]."""
    from rtctl.guard.planner import _bounds

    scene = Scene([Zone("box", [Box((0, 1), [3.0, -1.0], [4.0, 1.0])])], [-np.inf, -np.inf], [np.inf, np.inf])
    lo, hi = _bounds(scene, np.array([0, 1]), np.array([0.0, 0.0]), np.array([1.0, 0.0]))
    assert lo.tolist() == [-4.0, -3.0] and hi.tolist() == [8.0, 3.0]


def test_a_trajectory_leaving_one_joints_limit_names_that_joint():
    """``trajectory_violation``: the first sample past a limit is reported as "<joint> limit"."""
    from rtctl.trajectory import JointLimits
    from rtctl.trajectory.planning import point_to_point

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0], joint_names=("waist", "shoulder"))
    trajectory = point_to_point([0.0, 0.0], [0.0, 1.5], JointLimits([1.0, 1.0], [2.0, 2.0]))
    bad = trajectory_violation(scene, trajectory, 0.0, [1.0, 1.0])
    assert bad is not None and bad.what == "shoulder limit"


def test_a_zone_is_immutable():
    """A zone is shared by the scene's tables and the plans made from them: frozen, as declared."""
    import dataclasses

    zone = Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])
    with pytest.raises(dataclasses.FrozenInstanceError):
        zone.name = "other"


def test_a_triangle_flat_for_its_size_has_no_area():
    """The polygon's degeneracy test is relative to its size (area against scale²): a triangle
    1000 rad long and 10⁻⁹ high (area 5·10⁻⁷, scale 2000: below 10⁻¹²·scale² = 4·10⁻⁶) is
    refused; the same shape 1000 times smaller in both directions — not flat — is accepted."""
    with pytest.raises(ValueError, match="no area"):
        Polygon((0, 1), [[0.0, 0.0], [1000.0, 0.0], [500.0, 1e-9]])
    Polygon((0, 1), [[0.0, 0.0], [1.0, 0.0], [0.5, 1e-3]])


def test_astar_from_a_blocked_start_expands_nothing():
    """``astar``: (None, expansions) when there is no path; from a start inside a zone no node
    is expanded at all."""
    from rtctl.guard.grid import Grid, astar

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    grid = Grid(scene.tables(), np.array([0.0, 0.0]), np.array([2.0, 2.0]), np.array([0, 1]), 0.1, scene.margin,
                [-3.0, -3.0], [3.0, 3.0])
    assert astar(grid) == (None, 0)


def _min_depth(scene, trajectory, samples=20001):
    from rtctl.guard.feasibility import positions
    from rtctl.guard.kernels import clearances

    Q = positions(trajectory, np.linspace(trajectory.t_start, trajectory.t_end, samples))
    depth = np.empty(len(Q))
    clearances(*scene.tables(), Q, depth)
    return depth.min()


def test_a_smooth_route_that_keeps_half_the_margin_stays_smooth():
    """rtctl.guard.motion's doc: a smooth trajectory is kept when it stays at least half the
    margin from every zone. Around the box [−0.5, 0.5]² with margin 0.1 the smooth trajectory
    keeps at least 0.05 (checked here by sampling it 20 001 times): it is kept, smooth."""
    from rtctl.guard.motion import plan_route, route_trajectory

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    route = plan_route(scene, [-2.0, 0.1], [[2.0, -0.1]])
    assert route.bypassed
    trajectory, smooth = route_trajectory(scene, route, JointLimits([1.0, 1.0], [2.0, 2.0]), smooth=True)
    depth = _min_depth(scene, trajectory)
    assert depth >= 0.05, depth
    assert smooth


def test_a_guarded_move_from_a_moving_state_heads_for_the_target_without_turning_back():
    """``retarget_around``'s docstring: from the current reference state along the route
    [q, target] — from q on, not back to q. Moving at 0.5 rad/s towards a target 4 rad ahead on
    a clear line, joint 0's velocity never turns negative (sampled every ms); a move that first
    went to rest at q would have to turn back to it."""
    from rtctl.guard.motion import retarget_around

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    q, qd = np.array([-2.0, 1.0]), np.array([0.5, 0.0])
    trajectory, route = retarget_around(scene, 0.0, q, qd, np.zeros(2), [[2.0, 1.0]],
                                        JointLimits([1.0, 1.0], [2.0, 2.0]))
    assert route.points.tolist() == [[-2.0, 1.0], [2.0, 1.0]]
    pos, vel, acc = np.zeros(2), np.zeros(2), np.zeros(2)
    for t in np.arange(trajectory.t_start, trajectory.t_end, 1e-3):
        trajectory.sample(float(t), pos, vel, acc)
        assert vel[0] >= -1e-9, (t, vel)


def test_a_plan_is_immutable():
    """A plan is kept and shared (a route's legs): frozen, as declared."""
    import dataclasses

    from rtctl.guard.planner import plan_path

    scene = Scene([], [-3.0, -3.0], [3.0, 3.0])
    plan = plan_path(scene, [0.0, 0.0], [1.0, 1.0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.found = False


def test_the_clamps_default_wall_is_the_safety_stages_default_hold():
    """RuntimeGuard's docstring: damping and stiffness are "the safety stage's hold gains, in a
    run" — built alone, it has the same defaults as the stage's configuration."""
    from rtctl.config import SafetyConfig
    from rtctl.guard import RuntimeGuard
    from rtctl.guard.kernels import DAMPING, STIFFNESS

    scene = Scene([], [-1.0], [1.0])
    g = RuntimeGuard(scene, 10.0, 0.001)
    defaults = SafetyConfig()
    assert (g.par[STIFFNESS], g.par[DAMPING]) == (defaults.hold_stiffness, defaults.damping)


def test_the_grid_spans_the_multiples_of_h_from_the_start_within_the_limits():
    """The grid's nodes are the start plus whole multiples of h, within [lo, hi] (a limit that
    is a multiple away is a node, rounding aside). By hand: start 0.5, h = 0.3, limits ±1:
    down 5 steps to −1.0, up 1 step to 0.8 (two would be 1.1); start 0, h = 0.1, limits ±0.7:
    7 steps each way, though 0.7 / 0.1 is 6.999… in floating point."""
    from rtctl.guard.grid import Grid

    scene = Scene([], [-1.0], [1.0])
    g = Grid(scene.tables(), [0.5], [0.0], [0], 0.3, 0.0, [-1.0], [1.0])
    assert (g.k_lo.tolist(), g.k_hi.tolist()) == ([-5], [1])
    g = Grid(scene.tables(), [0.0], [0.5], [0], 0.1, 0.0, [-0.7], [0.7])
    assert (g.k_lo.tolist(), g.k_hi.tolist()) == ([-7], [7])


@pytest.mark.parametrize("at", ["q_min", "q_max"])
def test_clamp_mode_at_rest_exactly_on_a_limit_clamps_rather_than_stops(at):
    """Clamp mode stops only for a stopping path *past* a limit; one that ends in the limit's
    band — here exactly on the limit, at rest — is clamped (the limit itself is allowed)."""
    from rtctl.safety import GuardVerdict

    g, state, command = _box_guard(action="clamp")
    state.position[:] = [getattr(g.scene, at)[0], 2.5]
    assert g.check(0.0, state, command) == GuardVerdict.MODIFIED


def test_a_zone_on_the_stopping_path_before_a_limit_is_the_one_reported():
    """guard_tick: "a limit met before the zone counts first" — and so a zone met before the
    limit does. Joint 0 at 0 moving at 2 rad/s, braking at 2 rad/s²: the stop point is at
    2·(0.001 + 0.5) = 1.002, past the upper limit 0.5; the box over joint 0 ∈ [0.2, 0.3] lies
    on the way, at 0.2 — the event names the box."""
    from rtctl.guard import RuntimeGuard
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    scene = Scene([Zone("box", [Box((0, 1), [0.2, -1.0], [0.3, 1.0])])], [-0.5, -2.0], [0.5, 2.0])
    g = RuntimeGuard(scene, np.array([2.0, 2.0]), 0.001, margin=0.02)
    state, command = JointState(2), JointCommand(2)
    state.velocity[:] = [2.0, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.STOP
    assert g.event()["zone"] == "box", g.event()


def test_a_clamp_wall_without_damping_or_stiffness_is_accepted():
    """RuntimeGuard's check: damping and stiffness "finite and >= 0" — 0 is allowed."""
    from rtctl.guard import RuntimeGuard

    scene = Scene([], [-1.0], [1.0])
    RuntimeGuard(scene, 10.0, 0.001, damping=0.0, stiffness=0.0)
    with pytest.raises(ValueError, match="finite and >= 0"):
        RuntimeGuard(scene, 10.0, 0.001, damping=-1e-9)


def test_every_segment_of_a_visibility_route_passes_the_exact_check():
    """``shortest_path``'s docstring: ``segment_free(p, q)`` is "the exact check each segment of
    the answer must pass". Two points right of the box [2, 3]² see each other, but the check
    refuses their direct segment: the answer goes round by corners, and each of its segments
    passes the check."""
    from rtctl.guard.visibility import VisibilityMap

    m = VisibilityMap([shapely.box(2.0, 2.0, 3.0, 3.0)], (0.0, 0.0, 10.0, 10.0))
    a, b = np.array([4.0, 2.1]), np.array([4.0, 2.9])
    direct = {(tuple(a), tuple(b)), (tuple(b), tuple(a))}
    check = lambda p, q: (tuple(p), tuple(q)) not in direct  # noqa: E731
    path = m.shortest_path(a, b, check)
    assert path is not None and len(path) > 2, path
    assert all(check(p, q) for p, q in zip(path, path[1:]))


def _box_scene(margin=0.1):
    return Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=margin)


def test_a_negative_check_margin_is_refused():
    """``point_violation``'s margin: "finite and >= 0" — −0.5 is refused."""
    from rtctl.guard.feasibility import point_violation

    with pytest.raises(ValueError, match="margin must be finite and >= 0"):
        point_violation(_box_scene(), [2.0, 2.0], margin=-0.5)


def test_a_point_exactly_on_a_face_is_within_the_margin_not_inside():
    """Zones are open: a point exactly on the face x0 = −0.5 is not inside the box, only within
    its margin (0.1)."""
    from rtctl.guard.feasibility import point_violation

    bad = point_violation(_box_scene(), [-0.5, 0.0])
    assert bad is not None and bad.what == "box" and not bad.inside
    assert point_violation(_box_scene(), [-0.4, 0.0]).inside


def test_a_polyline_is_checked_segment_by_segment():
    """``path_violation``: the square of half-width 2 round the box is clear, side by side;
    [(−2, 2), (−2, 0), (2, 0)] is not — its segment 1, along x1 = 0, enters the box."""
    from rtctl.guard.feasibility import path_violation

    assert path_violation(_box_scene(), [[-2.0, 0.0], [-2.0, 2.0], [2.0, 2.0], [2.0, -2.0], [-2.0, -2.0]]) is None
    i, bad = path_violation(_box_scene(), [[-2.0, 2.0], [-2.0, 0.0], [2.0, 0.0]])
    assert i == 1 and bad.what == "box" and bad.inside


def test_a_trajectory_near_a_zone_is_found_in_its_later_segments_and_says_whether_inside():
    """``trajectory_violation`` samples the whole trajectory: through (−2, 2) → (−2, 0) → (2, 0)
    only the second segment comes near the box — found there; one that only grazes the margin
    (x1 = 0.55) comes within it but not inside; a hold in the box's middle is inside."""
    from rtctl.trajectory import through_waypoints

    limits = JointLimits([1.0, 1.0], [2.0, 2.0])
    crossing = through_waypoints(np.array([[-2.0, 0.0], [2.0, 0.0]]), limits, start=np.array([-2.0, 2.0]))
    bad = trajectory_violation(_box_scene(), crossing, 0.05, [1.0, 1.0])
    assert bad is not None and bad.what == "box" and bad.at > crossing.knots[1]
    grazing = through_waypoints(np.array([[-2.0, 0.55], [2.0, 0.55]]), limits, start=np.array([-2.0, 2.0]))
    bad = trajectory_violation(_box_scene(), grazing, 0.1, [1.0, 1.0])
    assert bad is not None and not bad.inside
    assert trajectory_violation(_box_scene(), hold([0.0, 0.0]), 0.1, [1.0, 1.0]).inside


def test_a_violation_described_in_degrees_says_so():
    """``describe(deg)``: joints of the mask shown in degrees, and the unit said: "… deg"."""
    from rtctl.guard.feasibility import point_violation

    bad = point_violation(_box_scene(), [-0.4, 0.0])
    assert bad.describe(np.array([True, True])).endswith("at q = [-22.92, 0] deg")
    assert bad.describe().endswith("at q = [-0.4, 0]")


def test_a_route_names_the_start_when_its_first_leg_fails_and_flags_its_waypoints():
    """``plan_route``: a first target inside a zone fails "from the start"; a route round the box
    flags the asked points (start and waypoint) and not the corners, one flag per point."""
    from rtctl.errors import GuardError
    from rtctl.guard.motion import plan_route

    with pytest.raises(GuardError, match="waypoint 0: cannot go there from the start"):
        plan_route(_box_scene(), [-2.0, 0.0], [[0.0, 0.0]])
    route = plan_route(_box_scene(), [-2.0, 0.1], [[2.0, -0.1]])
    assert len(route.points) > 2 and route.waypoint.tolist() == [True] + [False] * (len(route.points) - 2) + [True]


def test_a_visibility_plan_expands_no_grid_node():
    """``Plan.expanded`` counts grid nodes: a plan found on the visibility graph (two joints
    within finite limits) expands none."""
    from rtctl.guard.planner import plan_path

    plan = plan_path(_box_scene(), [-2.0, 0.1], [2.0, -0.1])
    assert plan.found and plan.method == "visibility" and plan.expanded == 0


def test_unbounded_joints_are_padded_by_at_least_one():
    """``_bounds``: the pad is the span of the points and zones, at least 1: a joint whose values
    span 0.5 (points at 0 and 0.5, no zone on it) gets [−1, 1.5]."""
    from rtctl.guard.planner import _bounds

    scene = Scene([], [-np.inf], [np.inf])
    lo, hi = _bounds(scene, np.array([0]), np.array([0.0]), np.array([0.5]))
    assert lo.tolist() == [-1.0] and hi.tolist() == [1.5]


def test_a_small_deceleration_is_accepted():
    """RuntimeGuard: deceleration "finite and > 0" — 0.5 rad/s² is a deceleration."""
    from rtctl.guard import RuntimeGuard

    RuntimeGuard(Scene([], [-1.0], [1.0]), 0.5, 0.001)


def test_the_visibility_graph_is_inflated_by_a_hair_only_when_there_is_a_margin():
    """``plan_inflation``: the checked margin plus a relative hair and 1 nm; no margin, none."""
    from rtctl.guard.visibility import _INFLATE, plan_inflation

    assert plan_inflation(0.0) == 0.0
    assert plan_inflation(0.1) == 0.1 * (1.0 + _INFLATE) + 1e-9
    assert plan_inflation(0.1) > 0.1
