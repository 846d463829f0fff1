"""Tests for the guard mutants that survived wider samples (49, then 111 mutants; docs/mutation/guard.md):
the planner's and the runtime guard's documented input checks, each half of an ``or`` on its own,
``clip`` on a segment that slides along a face of the open piece (the boundary is outside), the
clamp's outward command, the visibility route's direct segment, the guard protocol's
``event_due``, a one-joint band across the plane and a smooth route's trajectory."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.guard import Box, RuntimeGuard, Scene, Zone
from rtctl.guard.kernels import NO_ENTRY, clip
from rtctl.guard.planner import plan_path


def _scene():
    return Scene([Zone("far", [Box((0, 1), [5.0, 5.0], [6.0, 6.0])])], [-2.0, -2.0], [2.0, 2.0])


@pytest.mark.parametrize("q0", [[0.0, np.nan], [0.0, 0.0, 0.0], [[0.0, 0.0]]],
                         ids=["a NaN of the right shape", "finite, one joint too many", "finite, 2-D"])
def test_plan_path_refuses_a_start_that_is_not_n_finite_joint_values(q0):
    """The docstring's check "q0 must be n finite joint values": a wrong shape and a non-finite
    value are each refused on their own (``or``: either one is enough)."""
    with pytest.raises(ValueError, match="q0 must be 2 finite joint values"):
        plan_path(_scene(), q0, [0.5, 0.5])


@pytest.mark.parametrize("margin", [-0.1, np.inf, np.nan])
def test_the_runtime_guard_refuses_a_negative_or_non_finite_margin(margin):
    """The documented "a finite guard margin >= 0": −0.1 is finite but negative, +∞ is ≥ 0 but
    not finite — each is refused by its own half of the check."""
    with pytest.raises(ValueError, match="finite guard margin >= 0"):
        RuntimeGuard(_scene(), 10.0, 0.001, margin=margin)


def test_clip_a_segment_sliding_along_a_face_of_the_open_piece_does_not_enter():
    """``clip`` works on the *open* piece: a point exactly on a face is outside it. The square
    |x0| < 1, |x1| < 1 as four faces w·q < c; a→b runs along x0 = 1 (room 0 on that face, rate
    0: it never reaches the inner side) — (NO_ENTRY, −1), where counting room 0 as inside would
    say "a is inside" (0, −1)."""
    rows = np.array([[1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [0.0, -1.0, 1.0]])
    cols = np.array([[0, 1]] * 4, dtype=np.int64)
    a, b = np.array([1.0, 0.0]), np.array([1.0, 0.5])
    assert clip(rows, cols, 0, 4, a, b, 0.0) == (NO_ENTRY, -1)
    # just inside the face, the same motion is inside from its start
    a_in, b_in = np.array([0.5, 0.0]), np.array([0.5, 0.5])
    assert clip(rows, cols, 0, 4, a_in, b_in, 0.0) == (0.0, -1)


def test_the_clamp_keeps_an_outward_command_however_small():
    """``_push_out``'s docstring: the clamp drops the command's *inward* component only. A torque
    of 0.5 along the outward normal (no depth, no speed: no wall force) passes unchanged; −0.5
    (inward) is dropped to 0."""
    from rtctl.guard.kernels import N_PARAMS, _push_out

    par = np.zeros(N_PARAMS)
    for tau0, expected in ((0.5, 0.5), (-0.5, 0.0)):
        q, qd, q_des, qd_des, tau = np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), np.array([tau0])
        _push_out(0, 0, 1.0, 0.0, 0.0, q, qd, q_des, qd_des, tau, 0, par)
        assert tau[0] == expected, (tau0, tau[0])


def test_the_visibility_route_between_two_points_that_see_each_other_is_the_segment():
    """With nothing between a and b the shortest path is the straight segment a → b (two
    points), not a detour by the corners of an obstacle elsewhere."""
    import shapely

    from rtctl.guard.visibility import VisibilityMap

    m = VisibilityMap([shapely.box(2.0, 2.0, 3.0, 3.0)], (0.0, 0.0, 10.0, 10.0))
    a, b = np.array([0.5, 0.5]), np.array([1.5, 0.5])
    path = m.shortest_path(a, b, lambda p, q: True)
    assert path is not None and path.shape == (2, 2) and np.array_equal(path, [a, b]), path


def test_event_due_is_true_only_on_the_tick_an_episode_starts():
    """The guard protocol (rtctl/safety/faults.py): ``event_due`` is True on the tick a violation
    episode starts — not on the clear tick after it, which other wrappers (a cell's shared zones)
    read as they find it."""
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)
    g = RuntimeGuard(scene, np.array([10.0, 20.0]), 0.001, margin=0.02)
    state, command = JointState(2), JointCommand(2)
    state.position[:] = [-0.51, 0.0]  # at rest inside the band: a stop
    assert g.check(0.0, state, command) == GuardVerdict.STOP and g.event_due
    state.position[:] = [-2.0, 0.0]  # far and at rest: clear
    assert g.check(0.001, state, command) == GuardVerdict.PASS
    assert not g.event_due


def test_a_one_joint_band_reaches_past_the_planes_bounds_on_both_axes():
    """``Scene.inflated_shape``: a one-joint piece is a band across the plane; it reaches past
    the plane's bounds (lo0, lo1, hi0, hi1) — here lo1 = −10 far from lo0 = 0, so a band built
    from the wrong corner would end exactly at the edge, where a route could slip round it."""
    import shapely

    scene = Scene([Zone("band", [Box((0,), [0.4], [0.6])])], [-20.0, -20.0], [20.0, 20.0])
    shape = scene.inflated_shape(0, (0, 1), 0.0, (0.0, -10.0, 1.0, 10.0))
    for y in (-10.5, 0.0, 10.5):
        assert shape.covers(shapely.Point(0.5, y)), y
    assert not shape.covers(shapely.Point(0.7, 0.0))  # and only the band


def test_a_smooth_route_trajectory_starts_at_the_route_start_and_passes_its_via_point_moving():
    """``route_trajectory(smooth=True)``, nothing in the way: the trajectory starts at the route's
    first point and is the smooth kind it reports — a via point passed with a velocity, not a stop
    (a stop-at-each-waypoint trajectory would be at rest there)."""
    from rtctl.guard.motion import plan_route, route_trajectory
    from rtctl.trajectory import JointLimits

    scene = Scene([Zone("far", [Box((0, 1), [5.0, 5.0], [6.0, 6.0])])], [-8.0, -8.0], [8.0, 8.0])
    route = plan_route(scene, [0.0, 0.0], [[1.0, 0.5], [2.0, 0.0]])
    assert len(route.points) == 3  # no bypass: start, via point, end
    trajectory, smooth = route_trajectory(scene, route, JointLimits([1.0, 1.0], [2.0, 2.0]), smooth=True)
    assert smooth
    q, qd, qdd = np.zeros(2), np.zeros(2), np.zeros(2)
    trajectory.sample(0.0, q, qd, qdd)
    assert np.array_equal(q, [0.0, 0.0])
    knots = trajectory.knots
    trajectory.sample(float(knots[1]), q, qd, qdd)
    np.testing.assert_allclose(q, [1.0, 0.5], atol=1e-12)
    assert abs(qd[0]) > 0.1, qd  # joint 0 goes on in the same direction: it passes moving


def _bfs_steps(grid) -> int | None:
    """Fewest unit steps from the grid's origin to a node that reaches the goal (brute force)."""
    from collections import deque

    if not grid.free(grid.origin):
        return None
    seen, todo = {grid.origin: 0}, deque([grid.origin])
    while todo:
        key = todo.popleft()
        if grid.reaches_goal(key):
            return seen[key]
        for nb in grid.neighbours(key):
            if nb not in seen:
                seen[nb] = seen[key] + 1
                todo.append(nb)
    return None


@pytest.mark.parametrize("start, goal", [([-1.5, 0.1], [1.5, -0.2]), ([-1.5, -1.5], [1.5, 1.5]),
                                         ([0.1, -1.6], [-0.2, 1.6])])
def test_astar_finds_a_shortest_grid_path_around_an_obstacle(start, goal):
    """A* with its consistent heuristic returns a path of the fewest unit steps — what a
    breadth-first search of the same grid finds — around a box in the way."""
    from rtctl.guard.grid import Grid, astar

    scene = Scene([Zone("box", [Box((0, 1), [-0.6, -0.9], [0.6, 0.9])])], [-2.0, -2.0], [2.0, 2.0])
    grid = Grid(scene.tables(), start, goal, [0, 1], 0.25, 0.05, [-2.0, -2.0], [2.0, 2.0])
    route, _ = astar(grid)
    assert route is not None
    assert len(route) - 1 == _bfs_steps(grid)
    assert all(sum(abs(p - q) for p, q in zip(a, b)) == 1 for a, b in zip(route, route[1:]))  # unit steps
