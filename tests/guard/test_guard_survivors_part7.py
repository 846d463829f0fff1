"""Tests for guard mutants that survived the full run's fast pass after part6 (docs/testing.md),
each against the documentation or a value worked out by hand: the grid search ends at a node
within one step of the goal, and the clamp pushes along the faces of the piece it found — not
along another zone's."""
from __future__ import annotations

import numpy as np

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
