"""Issue 27 part 3, a first sample of the `guard` mutation target (35 of 1561 plausible mutants):
a test for each survivor that changes behaviour, each against the definition it breaks. Two are
equivalent: ``reshape(-1, 3)`` → ``reshape(-2, 3)`` (numpy takes any negative size as the one it
infers), and ``clip`` returning face 1 instead of −1 with ``NO_ENTRY`` (a face is read only when
the segment enters, s < NO_ENTRY)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from rtctl.guard import Box, Scene, Zone
from rtctl.guard.feasibility import point_violation
from rtctl.guard.grid import Grid
from rtctl.guard.planner import _combine


@pytest.mark.parametrize("lo, hi", [([-0.3, 0.1], [0.2, 0.9]), ([0.1, -0.8], [0.7, -0.2])])
def test_a_box_zones_obstacle_in_its_plane_is_that_box_and_its_margin(lo, hi):
    """zones.py: the box's x and y bounds each in their own place (a box with unequal sides)."""
    m = 0.05
    scene = Scene([Zone("b", [Box((0, 1), lo, hi)])], [-2, -2], [2, 2], margin=m)
    shape = scene.inflated_shape(0, (0, 1), m, (-2, -2, 2, 2))
    np.testing.assert_allclose(shape.bounds, [lo[0] - m, lo[1] - m, hi[0] + m, hi[1] + m], atol=1e-12)
    assert shapely.symmetric_difference(shape, shapely.box(*np.subtract(lo, m), *np.add(hi, m))).area < 1e-12


def test_a_position_exactly_at_a_joint_limit_is_within_the_range():
    """feasibility.py: the joint range is closed — q_min and q_max themselves are allowed, the
    next number past them is not (as for the lower limit)."""
    scene = Scene([Zone("far", [Box((0,), [5.0], [6.0])])], [-1.0, -2.0], [1.0, 2.0])
    for q in ([1.0, 0.0], [-1.0, 0.0], [0.0, 2.0], [0.0, -2.0]):
        assert point_violation(scene, np.array(q)) is None, q
    assert point_violation(scene, np.array([np.nextafter(1.0, 2.0), 0.0])) is not None
    assert point_violation(scene, np.array([0.0, np.nextafter(-2.0, -3.0)])) is not None


def test_the_grid_reaches_the_last_node_inside_the_upper_limit():
    """grid.py: nodes k_lo … k_hi are inside the limits, both ends included."""
    scene = Scene([Zone("far", [Box((0, 1), [5.0, 5.0], [6.0, 6.0])])], [-1.0, -1.0], [1.0, 1.0])
    grid = Grid(scene.tables(), [0.0, 0.0], [0.5, 0.5], [0, 1], 0.25, 0.0, [-1.0, -1.0], [1.0, 1.0])
    assert tuple(grid.k_hi) == (4, 4) and tuple(grid.k_lo) == (-4, -4)
    assert grid.free((4, 4)) and grid.free((-4, -4))
    assert not grid.free((5, 0)) and not grid.free((0, -5))


def test_a_short_group_route_is_followed_to_its_end_at_the_same_fraction_as_the_others():
    """planner.py: each group moves along its own route at the same fraction of its length
    as every other joint along its straight line — also when the route is shorter than 1 rad."""
    q0, q1 = np.zeros(3), np.array([0.3, 0.4, 0.6])
    route = np.array([[0.0, 0.0], [0.3, 0.0], [0.3, 0.4]])  # joints 0, 1: an L of length 0.7
    path = _combine(q0, q1, [(np.array([0, 1]), route)])
    np.testing.assert_allclose(path[0], q0)
    np.testing.assert_allclose(path[-1], q1)
    length = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(route, axis=0), axis=1))))
    for p in path:  # joint 2 runs straight: its fraction s is the fraction of the L's length done
        s = p[2] / q1[2]
        along = np.array([np.interp(s * length[-1], length, route[:, d]) for d in range(2)])
        np.testing.assert_allclose(p[:2], along, atol=1e-12)


def test_with_several_joints_past_their_limits_the_first_in_joint_order_is_named():
    """feasibility.py: the reason names a joint that is past its limit — the first one, so the
    message does not depend on how many others are."""
    scene = Scene([Zone("far", [Box((0,), [5.0], [6.0])])], [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0],
                  joint_names=("waist", "shoulder", "elbow"))
    v = point_violation(scene, np.array([0.0, 1.5, 1.5]))
    assert v is not None and v.what == "shoulder limit"


def test_a_scene_cannot_be_changed_after_its_tables_are_built():
    """zones.py: the compiled tables are built from the zones and limits once; a scene that let
    its limits be rebound afterwards would check against tables that no longer match them."""
    import dataclasses

    scene = Scene([Zone("far", [Box((0,), [5.0], [6.0])])], [-1.0], [1.0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.q_max = np.array([10.0])


@pytest.mark.parametrize("dt", [-0.001, 0.0, np.inf, np.nan])
def test_the_runtime_guard_refuses_a_period_that_is_not_finite_and_positive(dt):
    """runtime.py: the stopping distance is predicted over dt; a negative or infinite one is refused."""
    from rtctl.guard.runtime import RuntimeGuard

    scene = Scene([Zone("far", [Box((0,), [5.0], [6.0])])], [-1.0], [1.0])
    with pytest.raises(ValueError, match="dt > 0"):
        RuntimeGuard(scene, 10.0, dt)


def test_a_segment_with_an_end_past_a_limit_names_that_joint_and_that_end():
    """feasibility.py: the limits are a box, so an endpoint decides — the first joint past its
    limit, at s = 0 for the start and s = 1 for the end. (Equivalent survivors of the same
    sample: trajectory_violation's sampling step made 2 µrad — only slower — and a Scene given
    non-vector limits refused with n = −1 instead of 0, the same error.)"""
    from rtctl.guard.feasibility import segment_violation

    scene = Scene([Zone("far", [Box((0,), [5.0], [6.0])])], [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0],
                  joint_names=("waist", "shoulder", "elbow"))
    v = segment_violation(scene, np.zeros(3), np.array([0.0, 1.2, 0.0]))
    assert v.what == "shoulder limit" and v.at == 1.0
    v = segment_violation(scene, np.array([0.0, 0.0, -1.5]), np.zeros(3))
    assert v.what == "elbow limit" and v.at == 0.0
    v = segment_violation(scene, np.array([0.0, 1.5, 1.5]), np.zeros(3))
    assert v.what == "shoulder limit"
