"""The n-D planner is complete at its resolution: on random small problems it finds a path if
and only if breadth-first search over the same grid graph does; its paths are feasible."""
from collections import deque

import numpy as np
from hypothesis import event, given, settings, strategies as st

from rtctl.guard import Box, Polygon, Scene, Zone, path_violation, plan_path
from rtctl.guard.grid import BUDGET, Grid, astar, shortcut
from rtctl.guard.kernels import NO_ENTRY, segment_entry


def bfs_reaches_goal(grid: Grid) -> bool:
    start = grid.origin
    if not grid.free(start):
        return False
    seen, queue = {start}, deque([start])
    while queue:
        key = queue.popleft()
        if grid.reaches_goal(key):
            return True
        for nb in grid.neighbours(key):
            if nb not in seen:
                seen.add(nb)
                queue.append(nb)
    return False


@st.composite
def scenes(draw):
    """2–4 random zones over three joints in [-1, 1]: boxes over one to three joints, triangles."""
    zones = []
    for k in range(draw(st.integers(2, 4))):
        if draw(st.booleans()):
            joints = tuple(draw(st.permutations([0, 1, 2]))[:draw(st.integers(1, 3))])
            lo = np.array([draw(st.floats(-1, 0.6)) for _ in joints])
            hi = lo + np.array([draw(st.floats(0.1, 1.2)) for _ in joints])
            zones.append(Zone(f"b{k}", [Box(joints, lo, hi)]))
        else:
            joints = tuple(draw(st.permutations([0, 1, 2]))[:2])
            v = np.array([[draw(st.floats(-1, 1)) for _ in range(2)] for _ in range(3)])
            (ux, uy), (wx, wy) = v[1] - v[0], v[2] - v[0]
            area = 0.5 * abs(ux * wy - uy * wx)
            if area < 0.05:
                continue
            zones.append(Zone(f"t{k}", [Polygon(joints, v)]))
    return Scene(zones, [-1.0] * 3, [1.0] * 3, margin=draw(st.sampled_from([0.0, 0.05])))


@settings(max_examples=60, deadline=None)
@given(scenes(), st.lists(st.floats(-1, 1), min_size=6, max_size=6), st.sampled_from([0.2, 0.25, 0.3]))
def test_astar_finds_a_path_iff_bfs_does(scene, ends, h):
    a, b = np.array(ends[:3]), np.array(ends[3:])
    tables = scene.tables()
    route, expanded = astar(Grid(tables, a, b, [0, 1, 2], h, scene.margin, scene.q_min, scene.q_max))
    assert route is not BUDGET
    event("path" if route is not None else "no path")
    assert (route is not None) == bfs_reaches_goal(Grid(tables, a, b, [0, 1, 2], h, scene.margin, scene.q_min,
                                                        scene.q_max))
    if route is None:
        return
    grid = Grid(tables, a, b, [0, 1, 2], h, scene.margin, scene.q_min, scene.q_max)
    points = np.array([a] + [grid.point(x) for x in route] + [b])
    assert path_violation(scene, points) is None
    short = shortcut(points, lambda p, q: segment_entry(*tables, p, q, scene.margin)[0] >= NO_ENTRY)
    assert path_violation(scene, short) is None and len(short) <= len(points)
    assert np.array_equal(short[0], a) and np.array_equal(short[-1], b)


def test_plan_path_uses_the_grid_across_planes_and_answers_no_path():
    # a wall in (0, 1) and a box over (1, 2): one group of three joints
    wall = Zone("wall", [Box((0, 1), [-0.2, -1.5], [0.2, 0.6])])
    shelf = Zone("shelf", [Box((1, 2), [0.4, -0.3], [1.5, 1.5])])
    scene = Scene([wall, shelf], [-1.0] * 3, [1.0] * 3, margin=0.05)
    plan = plan_path(scene, [-0.8, 0.0, 0.0], [0.8, 0.0, 0.0], resolution=0.1)
    assert plan.found and plan.method == "grid" and path_violation(scene, plan.path) is None
    assert plan.crossing.what == "wall"
    # closing the gap over the wall: at resolution 0.1 there is no way round
    closed = Scene([wall, Zone("lid", [Box((0, 1, 2), [-0.3, 0.55, -1.5], [0.3, 1.5, 1.5])])], [-1.0] * 3, [1.0] * 3,
                   margin=0.05)
    plan = plan_path(closed, [-0.8, 0.0, 0.0], [0.8, 0.0, 0.0], resolution=0.1)
    assert not plan.found and "no path at resolution 0.1" in plan.reason
    budget = plan_path(closed, [-0.8, 0.0, 0.0], [0.8, 0.0, 0.0], resolution=0.1, max_nodes=10)
    assert not budget.found and "search budget (10 grid nodes)" in budget.reason
