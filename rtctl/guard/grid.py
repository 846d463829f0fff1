"""A planner complete at a stated resolution, for zones that span more than one joint plane.

The grid over joints J is anchored at the start: nodes start_J + k·h (k ∈ ℤ^|J|) within the
joint limits. A node is free when it is outside every zone inflated by the margin; an edge
joins two nodes one step apart along one axis and is free when its segment is (exact
Cyrus–Beck test); the goal is reached from a free node within h of it (∞-norm over J) whose
segment to the goal is free. Only the joints J are searched: the others stay at the start's
values on the grid (the group's zones do not involve them), so the goal test and the last
segment compare J alone — the start's values elsewhere never equal the goal's. Nodes and edges are checked lazily, when the search reaches them.

**Completeness at resolution h**: :func:`astar` searches this finite graph exhaustively, so it
returns a path whenever the graph holds one (the tests compare it with breadth-first search
over the same graph) and None only when it holds none — or ``"budget"`` when ``max_nodes``
expansions were not enough to tell. :func:`shortcut` then replaces runs of grid steps by the
longest free straight segments.
"""
from __future__ import annotations

import heapq
import itertools

import numpy as np

from rtctl.guard import kernels as k

BUDGET = "budget"


class Grid:
    """The lazily checked grid graph (see the module doc)."""

    def __init__(self, tables, start, goal, joints, h: float, margin: float, lo, hi):
        self.tables = tables
        self.start, self.goal = np.array(start, float), np.array(goal, float)
        self.joints = np.asarray(joints, dtype=np.int64)
        self.h, self.margin = float(h), float(margin)
        origin, self.lo, self.hi = self.start[self.joints], np.asarray(lo, float), np.asarray(hi, float)
        self.k_lo = np.ceil((self.lo - origin) / self.h - 1e-9).astype(int)
        self.k_hi = np.floor((self.hi - origin) / self.h + 1e-9).astype(int)
        self._free: dict[tuple, bool] = {}
        self._goal_here = self.start.copy()  # the goal's J values on the grid's plane through the start
        self._goal_here[self.joints] = self.goal[self.joints]

    @property
    def origin(self) -> tuple:
        return (0,) * len(self.joints)

    def point(self, key) -> np.ndarray:
        """start + key·h over J — a node that the tolerance of k_lo/k_hi keeps on a limit lies on
        it, not a rounding past it (start 1e-15, h = 0.2: node 5 is 1, not 1 + 1e-15)."""
        x = self.start.copy()
        x[self.joints] = np.clip(x[self.joints] + np.asarray(key) * self.h, self.lo, self.hi)
        return x

    def _segment_free(self, a, b) -> bool:
        return k.segment_entry(*self.tables, a, b, self.margin)[0] >= k.NO_ENTRY

    def free(self, key) -> bool:
        hit = self._free.get(key)
        if hit is None:
            inside = any(key[d] < self.k_lo[d] or key[d] > self.k_hi[d] for d in range(len(key)))
            hit = not inside and k.clearance(*self.tables, self.point(key))[0] >= self.margin
            self._free[key] = hit
        return hit

    def neighbours(self, key):
        """Free nodes joined to ``key`` by a free edge."""
        here = self.point(key)
        for d in range(len(key)):
            for step in (-1, 1):
                nb = key[:d] + (key[d] + step,) + key[d + 1:]
                if self.free(nb) and self._segment_free(here, self.point(nb)):
                    yield nb

    def reaches_goal(self, key) -> bool:
        x = self.point(key)
        near = np.max(np.abs(x[self.joints] - self.goal[self.joints])) <= self.h * (1 + 1e-9)
        return bool(near) and self._segment_free(x, self._goal_here)

    def heuristic(self, key) -> float:
        """max(0, Σ_J |x − goal|/h − |J|): admissible and consistent for unit steps (goal nodes lie
        within h of the goal per axis, and a step changes the sum by at most 1); 0 on a goal node."""
        gap = np.abs(self.point(key)[self.joints] - self.goal[self.joints]) / self.h
        return max(0.0, float(gap.sum()) - len(key))


def astar(grid: Grid, max_nodes: int | None = None):
    """(list of grid keys from the start to a node that reaches the goal, expansions), or
    (None, expansions) when the graph holds no path, or (BUDGET, expansions)."""
    start = grid.origin
    if not grid.free(start):
        return None, 0
    tie = itertools.count()
    heap = [(grid.heuristic(start), 0, next(tie), start)]
    cost, parent, closed = {start: 0}, {}, set()
    while heap:
        _, g, _, key = heapq.heappop(heap)
        if key in closed:
            continue
        closed.add(key)
        if grid.reaches_goal(key):
            route = [key]
            while route[-1] in parent:
                route.append(parent[route[-1]])
            return route[::-1], len(closed)
        if max_nodes is not None and len(closed) >= max_nodes:
            return BUDGET, len(closed)
        for nb in grid.neighbours(key):
            if nb not in closed and g + 1 < cost.get(nb, np.inf):
                cost[nb], parent[nb] = g + 1, key
                heapq.heappush(heap, (g + 1 + grid.heuristic(nb), g + 1, next(tie), nb))
    return None, len(closed)


def shortcut(points, segment_free) -> np.ndarray:
    """Greedy shortcutting: from each kept point, jump to the farthest later point in sight."""
    points = np.asarray(points, float)
    kept, i = [0], 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not segment_free(points[i], points[j]):
            j -= 1
        kept.append(j)
        i = j
    return points[kept]
