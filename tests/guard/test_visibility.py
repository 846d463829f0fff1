"""The 2-D shortest path: never longer than a fine-grid Dijkstra path in the same free space,
at most the grid's resolution bound shorter; no segment touches an inflated zone (exact test)."""
import heapq
import math

import numpy as np
import pytest
from numba import njit
from hypothesis import given, settings, strategies as st

from exact import mitred_offset, segment_meets_polygon
from guard_helpers import ROOT
from rtctl.config import load_config
from rtctl.guard import Polygon, Scene, Zone, plan_path
from rtctl.guard.kernels import NO_ENTRY, clearance, clearances, segment_entry
from test_zones import convex

# 16-connected grid: the neighbour directions are at most atan(1/2) ≈ 26.6° apart, so a grid path
# along a straight line is at most 1/cos(13.3°) longer (and it cannot hug a corner closer than a step)
STEPS = [(1, 0), (1, 1), (0, 1), (1, 2), (2, 1)]
STEPS = sorted({(sx * a, sy * b) for a, b in STEPS for sx in (1, -1) for sy in (1, -1)})
STRETCH = 1.0 / math.cos(math.atan(0.5) / 2)


@njit
def _free_edges(rows, cols, pieces, X, free, steps, nx, ny, margin, out):
    """out[node, s]: step s from node stays outside every inflated zone (both ends free)."""
    for k in range(nx):
        for l in range(ny):
            u = k * ny + l
            for s in range(steps.shape[0]):
                k2, l2 = k + steps[s, 0], l + steps[s, 1]
                if 0 <= k2 < nx and 0 <= l2 < ny and free[u] and free[k2 * ny + l2]:
                    out[u, s] = segment_entry(rows, cols, pieces, X[u], X[k2 * ny + l2], margin)[0] >= NO_ENTRY


def grid_dijkstra(tables, template, plane, a, b, margin, lo, hi, h):
    """Length of the shortest path on the 16-connected grid of step h over [lo, hi] (the plane
    of two joints) from a to b, through free nodes and free edges (start and goal joined to the
    nodes within 2h they see)."""
    i, j = plane
    nx, ny = int((hi[0] - lo[0]) / h) + 1, int((hi[1] - lo[1]) / h) + 1
    xs, ys = lo[0] + h * np.arange(nx), lo[1] + h * np.arange(ny)
    X = np.tile(template, (nx * ny, 1))
    X[:, i] = np.repeat(xs, ny)
    X[:, j] = np.tile(ys, nx)
    depth = np.empty(nx * ny)
    clearances(*tables, X, depth)
    free = depth >= margin
    steps = np.array(STEPS, dtype=np.int64)
    edge = np.zeros((nx * ny, len(steps)), dtype=np.bool_)
    _free_edges(*tables, X, free, steps, nx, ny, margin, edge)
    length = h * np.hypot(*steps.T)

    def point(p):
        x = template.copy()
        x[i], x[j] = p
        return x

    def near(p):
        k0, l0 = int(round((p[0] - lo[0]) / h)), int(round((p[1] - lo[1]) / h))
        for k in range(max(k0 - 2, 0), min(k0 + 3, nx)):
            for l in range(max(l0 - 2, 0), min(l0 + 3, ny)):
                u = k * ny + l
                if free[u] and math.dist(p, X[u, [i, j]]) <= 2.3 * h and \
                        segment_entry(*tables, point(p), X[u], margin)[0] >= NO_ENTRY:
                    yield u, math.dist(p, X[u, [i, j]])

    goal_links = dict(near(b))
    dist = np.full(nx * ny, np.inf)
    heap = [(w, u) for u, w in near(a)]
    for w, u in heap:
        dist[u] = min(dist[u], w)
    heapq.heapify(heap)
    best = math.inf
    while heap:
        d, u = heapq.heappop(heap)
        if d >= best:
            return best
        if d > dist[u]:
            continue
        if u in goal_links:
            best = min(best, d + goal_links[u])
        for s in np.flatnonzero(edge[u]).tolist():
            v = u + steps[s, 0] * ny + steps[s, 1]
            if d + length[s] < dist[v]:
                dist[v] = d + length[s]
                heapq.heappush(heap, (d + length[s], v))
    return best


def check_against_grid(scene, a, b, plane, h):
    plan = plan_path(scene, a, b)
    assert plan.found, plan.reason
    i, j = plane
    lo, hi = scene.q_min[[i, j]], scene.q_max[[i, j]]
    grid = grid_dijkstra(scene.tables(), np.asarray(a, float), plane, a[[i, j]], b[[i, j]], scene.margin, lo, hi, h)
    L = plan.length
    bends = len(plan.path) - 2
    assert L <= grid + 1e-9, (L, grid)  # the visibility path is never longer
    assert grid <= STRETCH * L + 3 * h * (bends + 1), (L, grid, bends)  # and the grid's bound holds
    # exact: no segment of the path touches any inflated zone
    for p, q in zip(plan.path, plan.path[1:]):
        for part in scene.parts:
            v = part.vertices if part.joints == (i, j) else part.vertices[:, ::-1]
            assert not segment_meets_polygon(p[[i, j]], q[[i, j]], mitred_offset(v, scene.margin))
    return plan, grid


def test_shipped_scene_against_a_fine_grid():
    cfg = load_config(ROOT / "configs" / "puma560_guard_sim.toml")
    w = cfg.trajectory.waypoints
    for a, b in ((w[0], w[1]), (w[1], w[2])):
        a2, b2 = a.copy(), b.copy()
        a2[[0, 3, 4, 5]] = b2[[0, 3, 4, 5]] = 0.0  # the zones' plane only: the grid is 2-D
        plan, grid = check_against_grid(cfg.guard.scene, a2, b2, (1, 2), h=0.01)
        print(f"shipped leg: visibility {plan.length:.4f} rad, grid (h = 0.01) {grid:.4f} rad")
        assert plan.method == "visibility" and len(plan.path) > 2


@settings(max_examples=8, deadline=None)
@given(st.lists(convex, min_size=1, max_size=3), st.integers(0, 2**31 - 1))
def test_random_scenes_against_a_fine_grid(polygons, seed):
    zones = [Zone(f"z{k}", [Polygon((0, 1), v)]) for k, v in enumerate(polygons)]
    scene = Scene(zones, [-2.0, -2.0], [2.0, 2.0], margin=0.05)
    rng = np.random.default_rng(seed)
    a, b = rng.uniform(-2, 2, (2, 2))
    if min(clearance(*scene.tables(), q)[0] for q in (a, b)) < scene.margin:
        return  # an end within the margin: the planner leaves it with a shrunk margin, the grid cannot
    plan = plan_path(scene, a, b)
    if not plan.found:
        return  # no way around: the other tests cover that answer
    check_against_grid(scene, a, b, (0, 1), h=0.02)


def test_the_square_has_its_analytic_shortest_path():
    m = 0.1
    scene = Scene([Zone("sq", [Polygon((0, 1), [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])])],
                  [-2, -2], [2, 2], margin=m)
    plan = plan_path(scene, [-1.0, 0.0], [1.0, 0.0])
    assert plan.length == pytest.approx(2 * math.hypot(0.5 - m, 0.5 + m) + 1 + 2 * m, rel=1e-6)
