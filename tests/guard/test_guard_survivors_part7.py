"""Tests for guard mutants that survived the full run's fast pass after part6 (docs/mutation/guard.md),
each against the documentation or a value worked out by hand: the grid search ends at a node
within one step of the goal, the clamp pushes along the faces of the piece it found — not
along another zone's —, a move from a moving state that would come within half the margin is
refused (and says so in words), a trajectory "goes past" a limit, the shortcut from the start,
limits that are not vectors, the depth of a scene without zones, a zone without a name or
without a part, a straight plan's expansions, a box's bounds per joint, a large polygon's
repeated vertex, and grid nodes that rounding would put past a limit."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.guard import Box, Scene, Zone


def test_the_grid_search_ends_at_a_node_within_one_step_of_the_goal():
    """rtctl.guard.grid: the goal is reached from a free node within h of it (∞-norm over J).
    With nothing in the way, start 0 and goal (1, 0, 0) at h = 0.1, the route runs along the
    first axis and ends at the node 0.9 — not 0.8, two steps away."""
    from rtctl.guard.grid import Grid, astar

    scene = Scene([], [-2.0] * 3, [2.0] * 3)
    grid = Grid(scene.tables(), np.zeros(3), [1.0, 0.0, 0.0], (0, 1, 2), 0.1, 0.0, [-2.0] * 3, [2.0] * 3)
    keys, _ = astar(grid)
    assert keys[-1] == (9, 0, 0)
    assert np.max(np.abs(grid.point(keys[-1]) - [1.0, 0.0, 0.0])) <= 0.1 * (1 + 1e-9)


def test_the_clamp_pushes_along_the_faces_of_the_zone_it_found_only():
    """guard_tick's clamp: "pushed out along every face that separates q from the zone" — the
    zone met, B = [2, 3] × [−1, 1] (the third zone; rows 8–11). At rest at x = 1.7 (0.3 from B:
    in the outer half of g = 0.5), with a command of −50 N·m (away from B): B's face x = 2 keeps
    it and adds the wall 1000 × (0.5 − 0.3) = 200 N·m along (−1, 0): τ = (−250, 0). The face
    q₀ ≥ −2 of C = [−3, −2] × [−1, 1] also has q outside, but C is not the zone met."""
    from rtctl.guard import RuntimeGuard
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.safety import GuardVerdict

    zones = [Zone("A", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])]), Zone("C", [Box((0, 1), [-3.0, -1.0], [-2.0, 1.0])]),
             Zone("B", [Box((0, 1), [2.0, -1.0], [3.0, 1.0])])]
    scene = Scene(zones, [-5.0, -5.0], [5.0, 5.0])
    g = RuntimeGuard(scene, np.array([10.0, 10.0]), 0.001, margin=0.5, action="clamp", damping=0.0, stiffness=1000.0)
    state, command = JointState(2), JointCommand(2)
    state.position[:] = [1.7, 0.0]
    command.tau_ff[:] = [-50.0, 0.0]
    assert g.check(0.0, state, command) == GuardVerdict.MODIFIED
    np.testing.assert_allclose(command.tau_ff, [-250.0, 0.0], rtol=1e-12)


def test_a_move_from_a_moving_state_that_would_come_within_half_the_margin_is_refused():
    """``retarget_around``: the trajectory from the current motion must keep half the margin
    (0.1 here), else the move is refused, saying so. From (0, −0.8) moving at 0.4 rad/s towards
    the box [−0.5, 0.5]² and asked to (1.5, −0.8), the retarget swings up to 0.067 from the box
    (measured by sampling it 200 001 times) — outside the box, inside half the margin."""
    from rtctl.errors import GuardError
    from rtctl.guard.motion import retarget_around
    from rtctl.trajectory import JointLimits

    scene = Scene([Zone("box", [Box((0, 1), [-0.5, -0.5], [0.5, 0.5])])], [-3.0, -3.0], [3.0, 3.0], margin=0.2)
    with pytest.raises(GuardError) as e:
        retarget_around(scene, 0.0, np.array([0.0, -0.8]), np.array([0.0, 0.4]), np.zeros(2), [[1.5, -0.8]],
                        JointLimits([1.0, 1.0], [1.0, 1.0]))
    assert str(e.value).startswith("from the current motion the move comes within the margin of zone 'box' at q = ")
    assert str(e.value).endswith("wait until the robot is at rest")


def test_a_trajectory_goes_past_a_limit_and_a_point_is_past_it():
    """``Violation.describe``: a point is "past the … limit", a trajectory or a segment "goes past" it."""
    from rtctl.guard.feasibility import Violation

    assert Violation("elbow limit", np.array([3.5, 0.0])).describe() == "past the elbow limit at q = [3.5, 0]"
    assert Violation("elbow limit", np.array([3.5, 0.0]), 0.25).describe() == "goes past the elbow limit at q = [3.5, 0]"


def test_shortcut_jumps_from_the_start_only_as_far_as_it_sees():
    """``shortcut``: from each kept point, jump to the farthest later point in sight. p0 sees
    only p1, p1 sees p3: [p0, p1, p3] — every kept segment in sight."""
    from rtctl.guard.grid import shortcut

    points = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    blocked = {(0, 2), (0, 3)}

    def free(a, b):
        return (int(a[0]), int(b[0])) not in blocked

    np.testing.assert_array_equal(shortcut(points, free), points[[0, 1, 3]])


def test_limits_that_are_not_one_row_of_joint_values_are_refused():
    """A Scene's q_min and q_max: one value per joint each (a 1 × 1 array is not a vector)."""
    with pytest.raises(ValueError, match="q_min < q_max, one per joint"):
        Scene([], [[0.0]], [1.0])


def test_the_depth_of_a_scene_without_zones_is_infinite():
    """``Scene.depth``: (smallest piece depth, that piece) — with no pieces (+∞, −1), as the
    compiled ``clearance`` says."""
    from rtctl.guard.kernels import clearance

    scene = Scene([], [-1.0, -1.0], [1.0, 1.0])
    assert scene.depth(np.zeros(2)) == (np.inf, -1) == clearance(*scene.tables(), np.zeros(2))


@pytest.mark.parametrize("name, parts", [("", "box"), ("z", ())])
def test_a_zone_needs_both_a_name_and_a_part(name, parts):
    """``Zone``: a name and at least one Box or Polygon part — either missing is refused."""
    parts = (Box((0, 1), [0.0, 0.0], [1.0, 1.0]),) if parts == "box" else parts
    with pytest.raises(ValueError, match="a zone needs a name and at least one Box or Polygon part"):
        Zone(name, parts)


def test_a_straight_plan_expands_no_grid_node():
    """``Plan.expanded``: grid nodes expanded — a plan whose straight segment is clear expands none."""
    from rtctl.guard.planner import plan_path

    plan = plan_path(Scene([], [-1.0, -1.0], [1.0, 1.0]), [0.0, 0.0], [0.5, 0.0])
    assert plan.method == "straight" and plan.expanded == 0


@pytest.mark.parametrize("lo, hi", [([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]), ([0.0], [1.0])])
def test_a_box_needs_one_lower_and_one_upper_bound_per_joint(lo, hi):
    """``Box`` over two joints: two lower and two upper bounds — three (or one) of each is refused."""
    with pytest.raises(ValueError, match="a box over 2 joints needs 2 lower and upper bounds"):
        Box((0, 1), lo, hi)


def test_a_large_polygon_with_a_vertex_repeated_within_its_rounding_is_refused():
    """The repeated-vertex test is relative to the polygon's size (edge ≤ 10⁻¹²·scale): a square
    1000 rad wide (scale 2000) with a vertex repeated 10⁻¹⁰ away (below 2·10⁻⁹) is refused."""
    from rtctl.guard import Polygon

    with pytest.raises(ValueError, match="repeated vertex"):
        Polygon((0, 1), [[0.0, 0.0], [1000.0, 0.0], [1000.0, 1000.0], [1000.0 - 1e-10, 1000.0], [0.0, 1000.0]])


def test_every_grid_node_lies_within_the_limits_even_when_rounding_would_put_one_past():
    """The grid's nodes are start + k·h within the limits, a node a whole number of steps from a
    limit on it. From q₁ = 10⁻¹⁵ with h = 0.2 and |q₁| ≤ 1, node 5 computed to 1 + 10⁻¹⁵ — past
    the limit (property testing found a plan through it refused by the planner's own check): it
    is the limit itself, and so at the lower limit from −10⁻¹⁵ and on both from 0."""
    from rtctl.guard.grid import Grid

    scene = Scene([], [-1.0] * 3, [1.0] * 3)
    for q1, ends in ((1e-15, (-1.0 + 1e-15, 1.0)), (-1e-15, (-1.0, 1.0 - 1e-15)), (0.0, (-1.0, 1.0))):
        grid = Grid(scene.tables(), [0.0, q1, 0.0], [1.0, 1.0, 0.0], (0, 1, 2), 0.2, 0.0, [-1.0] * 3, [1.0] * 3)
        assert (grid.k_lo[1], grid.k_hi[1]) == (-5, 5)
        nodes = [grid.point((0, k, 0))[1] for k in range(-5, 6)]
        assert all(-1.0 <= x <= 1.0 for x in nodes), nodes
        assert (nodes[0], nodes[-1]) == pytest.approx(ends, abs=1e-15)
        assert (1.0 in nodes, -1.0 in nodes) == (q1 >= 0, q1 <= 0)  # on a limit exactly, not past it
