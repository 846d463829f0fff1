"""Shortest paths in the plane of two joints: the visibility graph of the margin-inflated zones.

Among the paths that stay in a polygonal free space, a shortest one is a polyline whose
inner vertices are vertices of the obstacles (Lozano-Pérez & Wesley, CACM 22(10), 1979), so
Dijkstra's algorithm over the graph of mutually visible obstacle vertices, start and goal
finds it. shapely does the geometry: the mitred offsets, their union, and which candidate
segments the free space covers. The graph among the obstacle vertices does not depend on
start and goal: a :class:`VisibilityMap` builds it once and each query only adds the
segments from its start and goal. Every segment of an answer is confirmed by the exact
Cyrus–Beck test of :mod:`rtctl.guard.kernels` (a rounding shapely did not see removes the
edge and the search runs again).
"""
from __future__ import annotations

import heapq

import numpy as np
import shapely

_INFLATE = 1e-6  # relative: the graph is built on a hair more margin than is checked


def plan_inflation(margin: float) -> float:
    """The margin the graph is built with: the checked one plus a relative hair, so that a path
    along an offset edge is not rejected by the exact check for a rounding."""
    return margin * (1.0 + _INFLATE) + 1e-9 if margin > 0 else 0.0


class VisibilityMap:
    """The free space inside ``bounds`` = (lo0, lo1, hi0, hi1) around ``shapes`` (shapely
    polygons, already inflated) and the visibility graph among their vertices."""

    def __init__(self, shapes, bounds):
        self.area = shapely.box(*bounds)
        blocked = shapely.union_all(shapes) if shapes else shapely.Polygon()
        self.free = self.area.difference(blocked)
        shapely.prepare(self.free)
        corners = np.unique(shapely.get_coordinates(blocked), axis=0).reshape(-1, 2)
        self.corners = corners[shapely.covers(self.area, shapely.points(corners))] if len(corners) else corners
        i, j = np.triu_indices(len(self.corners), k=1)
        i, j = self._visible(self.corners[i], self.corners[j], i, j)
        self.edges: dict[int, dict[int, float]] = {u: {} for u in range(len(self.corners))}
        for u, v, w in zip(i.tolist(), j.tolist(), np.hypot(*(self.corners[j] - self.corners[i]).T).tolist()):
            self.edges[u][v] = self.edges[v][u] = w

    def _visible(self, p, q, *labels):
        ok = shapely.covers(self.free, shapely.linestrings(np.stack([p, q], axis=1))) if len(p) else np.zeros(0, bool)
        return tuple(x[ok] for x in labels)

    def shortest_path(self, a, b, segment_free) -> np.ndarray | None:
        """Shortest path a → b, (k, 2) points; None when they are not connected (or not free).
        ``segment_free(p, q)``: the exact check each segment of the answer must pass."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        if not shapely.covers(self.free, shapely.multipoints([a, b])):
            return None
        start, goal = len(self.corners), len(self.corners) + 1
        nodes = np.vstack([self.corners, a, b])
        extra: dict[int, dict[int, float]] = {start: {}, goal: {}}
        c = np.arange(len(self.corners))
        for end, p in ((start, a), (goal, b)):
            (seen,) = self._visible(np.broadcast_to(p, self.corners.shape), self.corners, c)
            for v in seen.tolist():
                extra[end][v] = float(np.hypot(*(self.corners[v] - p)))
                extra.setdefault(v, {})[end] = extra[end][v]
        if self._visible(a[None], b[None], np.array([True]))[0].size:
            extra[start][goal] = extra[goal][start] = float(np.hypot(*(b - a)))
        while True:
            route = _dijkstra(self.edges, extra, start, goal)
            if route is None:
                return None
            bad = next(((u, v) for u, v in zip(route, route[1:]) if not segment_free(nodes[u], nodes[v])), None)
            if bad is None:
                return nodes[route]
            u, v = bad
            for graph in (self.edges, extra):
                graph.get(u, {}).pop(v, None)
                graph.get(v, {}).pop(u, None)


def _dijkstra(edges, extra, source: int, target: int):
    dist, previous, done = {source: 0.0}, {}, set()
    heap = [(0.0, source)]
    while heap:
        d, u = heapq.heappop(heap)
        if u in done:
            continue
        if u == target:
            route = [u]
            while route[-1] != source:
                route.append(previous[route[-1]])
            return route[::-1]
        done.add(u)
        for graph in (edges, extra):
            for v, w in graph.get(u, {}).items():
                if d + w < dist.get(v, np.inf):
                    dist[v], previous[v] = d + w, u
                    heapq.heappush(heap, (d + w, v))
    return None
