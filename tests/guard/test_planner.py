"""plan_path: the answers (straight, around, no path, refused ends) and the product of groups."""
import math

import numpy as np
import pytest

from rtctl.guard import Box, Polygon, Scene, Zone, path_violation, plan_path, plan_route
from rtctl.errors import GuardError
from test_zones import SQUARE

LIMITS = ([-2.0] * 4, [2.0] * 4)


def square(name, plane):
    return Zone(name, [Polygon(plane, SQUARE)])


def test_groups_are_planned_apart_and_combined_as_a_product_of_shortest_paths():
    scene = Scene([square("a", (0, 1)), square("b", (2, 3))], *LIMITS, margin=0.1)
    q0, q1 = np.array([-1.0, 0.1, 0.0, -1.0]), np.array([1.0, -0.1, 0.0, 1.2])
    plan = plan_path(scene, q0, q1)
    assert plan.found and plan.method == "visibility" and path_violation(scene, plan.path) is None
    # each plane alone (the other joints held) …
    alone = [plan_path(scene, q0, np.where(np.isin(range(4), J), q1, q0)).length for J in ((0, 1), (2, 3))]
    # … and together: the length of a product path followed in proportion is the root sum of squares
    assert plan.length == pytest.approx(math.hypot(*alone), rel=1e-9)


def test_straight_when_clear_and_the_crossing_when_not():
    scene = Scene([square("a", (0, 1))], *LIMITS, margin=0.1)
    clear = plan_path(scene, [-1.0, 1.0, 0, 0], [1.0, 1.0, 0, 0])
    assert clear.method == "straight" and clear.crossing is None and len(clear.path) == 2
    around = plan_path(scene, [-1.0, 0.0, 0, 0], [1.0, 0.0, 0, 0])
    assert around.crossing.what == "a" and np.allclose(around.crossing.q, [-0.5, 0, 0, 0])


def test_no_path_is_an_answer_with_the_reason():
    band = Scene([Zone("cable carrier", [Box((1,), [-0.2], [0.2])])], *LIMITS, margin=0.05)
    plan = plan_path(band, [0.0, -1.0, 0, 0], [0.0, 1.0, 0, 0])
    assert not plan.found and plan.path is None
    assert "cable carrier separates start and target along joint 1" in plan.reason
    wall = Scene([Zone("wall", [Polygon((0, 1), [[-0.2, -3], [0.2, -3], [0.2, 3], [-0.2, 3]])])], *LIMITS)
    plan = plan_path(wall, [-1.0, 0, 0, 0], [1.0, 0, 0, 0])
    assert not plan.found and "no path: wall cut (joint 0, joint 1)" in plan.reason


def test_targets_inside_a_zone_or_its_margin_are_refused_and_a_start_in_the_margin_is_left():
    scene = Scene([square("a", (0, 1))], *LIMITS, margin=0.1)
    assert "the target is inside zone 'a'" in plan_path(scene, [-1.0, 0, 0, 0], [0.0, 0, 0, 0]).reason
    assert "within the margin of zone 'a'" in plan_path(scene, [-1.0, 0, 0, 0], [0.55, 0, 0, 0]).reason
    assert "the start is inside zone 'a'" in plan_path(scene, [0.0, 0, 0, 0], [1.0, 1, 0, 0]).reason
    assert "past the joint 2 limit" in plan_path(scene, [-1.0, 0, 0, 0], [1.0, 1, 3, 0]).reason
    # a start 0.05 from the zone (after a guard stop): planned with the clearance it has
    plan = plan_path(scene, [-0.55, 0.0, 0, 0], [1.0, 0.0, 0, 0])
    assert plan.found and 0.049 < plan.margin < 0.05 and path_violation(scene, plan.path, plan.margin) is None


def test_a_route_names_the_leg_without_a_path():
    band = Scene([Zone("cable carrier", [Box((1,), [-0.2], [0.2])])], *LIMITS, margin=0.05)
    route = plan_route(band, [0.0, -1.0, 0, 0], [[1.0, -1.0, 0, 0], [1.0, -0.5, 0, 0]])
    assert not route.bypassed and len(route.points) == 3
    with pytest.raises(GuardError, match="waypoint 1: cannot go there from waypoint 0: no path"):
        plan_route(band, [0.0, -1.0, 0, 0], [[1.0, -1.0, 0, 0], [1.0, 1.0, 0, 0]])


def test_durations_are_kept_on_a_clear_route_and_refused_around_a_zone():
    from rtctl.guard import route_trajectory
    from rtctl.trajectory import JointLimits

    scene = Scene([square("a", (0, 1))], *LIMITS, margin=0.1)
    limits = JointLimits([1.0] * 4, [2.0] * 4)
    clear = plan_route(scene, [-1.0, 1.0, 0, 0], [[1.0, 1.0, 0, 0]])
    trajectory, _ = route_trajectory(scene, clear, limits, durations=[5.0])
    assert trajectory.duration == pytest.approx(5.0)
    around = plan_route(scene, [-1.0, 0.0, 0, 0], [[1.0, 0.0, 0, 0]])
    with pytest.raises(GuardError, match="durations cannot be kept"):
        route_trajectory(scene, around, limits, durations=[5.0])
