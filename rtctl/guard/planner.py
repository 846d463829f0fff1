"""Bypass planning: a collision-free joint-space path from S_i to S_f, or the reason there is none.

The zones link joints into groups (:meth:`Scene.joint_groups`); the free space is the product
of the groups' free spaces and of the untouched joints' ranges, so each group is planned on
its own and the group paths are combined, each followed at the same fraction of its length
(a product of shortest paths, parameterised by arc length, is a shortest path of the product):

* a group whose straight segment is free keeps it;
* a two-joint group: the shortest path, by the visibility graph (:mod:`.visibility`);
* a one-joint group cut by a zone: no path (the segment is the only way along one joint);
* three or more joints: A* on the lazily checked grid, complete at the resolution, then
  shortcut (:mod:`.grid`).

Paths keep the scene's margin from every zone. A start already inside that margin (after a
guard stop, say) is planned with the margin it still has.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from rtctl.guard import kernels as k
from rtctl.guard.feasibility import Violation, path_violation, point_violation, segment_violation
from rtctl.guard.grid import BUDGET, Grid, astar, shortcut
from rtctl.guard.visibility import VisibilityMap, plan_inflation
from rtctl.guard.zones import DEFAULT_RESOLUTION, Box, Scene

_MAPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # scene → {(pieces, margin, bounds): map}


@dataclass(frozen=True, eq=False)
class Plan:
    """A planned path (k × n, start to goal) or why there is none (``found`` False, ``reason``)."""

    found: bool
    path: np.ndarray | None
    method: str  # "straight", "visibility", "grid" (several when groups differ), or "none"
    reason: str = ""
    crossing: Violation | None = None  # where the straight segment met a zone (None if it did not)
    margin: float = 0.0  # the clearance the path keeps
    expanded: int = 0  # grid nodes expanded

    @property
    def length(self) -> float:
        return 0.0 if self.path is None else float(np.linalg.norm(np.diff(self.path, axis=0), axis=1).sum())


def plan_path(scene: Scene, q0, q1, *, resolution: float = DEFAULT_RESOLUTION, max_nodes: int | None = None,
              deg=None) -> Plan:
    """Plan from ``q0`` to ``q1`` around the zones (see the module doc). ``max_nodes``: the grid
    search's budget (None: unbounded); ``deg``: a per-joint mask of the joints the reason shows in
    degrees (see :meth:`Violation.describe`)."""
    q0, q1 = (np.asarray(q, dtype=float) for q in (q0, q1))
    for name, q in (("q0", q0), ("q1", q1)):
        if q.shape != (scene.n,) or not np.all(np.isfinite(q)):
            raise ValueError(f"{name} must be {scene.n} finite joint values, got shape {q.shape}")
    if not (np.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be > 0, got {resolution!r}")
    bad = point_violation(scene, q0, margin=0.0)
    if bad is not None:
        return Plan(False, None, "none", f"the start is {bad.describe(deg)}")
    bad = point_violation(scene, q1)
    if bad is not None:
        return Plan(False, None, "none", f"the target is {bad.describe(deg)}")
    margin = min(scene.margin, max(0.0, 0.99 * k.clearance(*scene.tables(), q0)[0] - 2e-9))  # see plan_inflation
    crossing = segment_violation(scene, q0, q1, margin)
    if crossing is None:
        return Plan(True, np.array([q0, q1]), "straight", margin=margin)
    paths, methods, expanded = [], [], 0
    for joints, pieces in scene.joint_groups():
        tables = scene.tables(pieces)
        J = np.array(joints)

        def free(a, b, tables=tables):
            return k.segment_entry(*tables, a, b, margin)[0] >= k.NO_ENTRY

        if free(q0, q1):
            continue
        zone = scene.zone_of_piece(pieces[0]).name if len(pieces) == 1 else "the zones"
        lo, hi = _bounds(scene, J, q0, q1)
        if len(J) == 1:
            return Plan(False, None, "none", f"no path: {zone} separates start and target along "
                        f"{scene.joint_names[J[0]]}", crossing, margin)
        if len(J) == 2:
            route = _visibility_map(scene, pieces, joints, margin, (*lo, *hi)).shortest_path(
                q0[J], q1[J], lambda a, b: free(_lift(q0, J, a), _lift(q0, J, b)))
            method = "visibility"
        else:
            grid = Grid(tables, q0, q1, J, resolution, margin, lo, hi)
            keys, n = astar(grid, max_nodes)
            expanded += n
            if keys is BUDGET:
                return Plan(False, None, "none", f"no path found within the search budget ({n} grid nodes) in "
                            f"{_names(scene, J)}", crossing, margin, expanded)
            route = None if keys is None else np.array([q0[J]] + [grid.point(x)[J] for x in keys] + [q1[J]])
            if route is not None:
                route = shortcut(route, lambda a, b: free(_lift(q0, J, a), _lift(q0, J, b)))
            method = "grid"
        if route is None:
            how = "" if method == "visibility" else f" at resolution {resolution:g}"
            return Plan(False, None, "none", f"no path{how}: {zone} cut {_names(scene, J)} between start and "
                        f"target", crossing, margin, expanded)
        paths.append((J, route))
        methods.append(method)
    path = _combine(q0, q1, paths)
    wrong = path_violation(scene, path, margin)
    if wrong is not None:
        raise AssertionError(f"planned segment {wrong[0]} is infeasible ({wrong[1]}): a planner bug")
    return Plan(True, path, "+".join(sorted(set(methods))), crossing=crossing, margin=margin, expanded=expanded)


def prepare(scene: Scene) -> None:
    """Load the compiled checks and build the visibility graphs a plan will need (two-joint
    groups within finite limits), so that a first `move` does not stall the loop for them."""
    q = np.clip(np.zeros(scene.n), scene.q_min, scene.q_max)
    k.segment_entry(*scene.tables(), q, q, scene.margin)
    k.clearances(*scene.tables(), q[None], np.empty(1))
    for joints, pieces in scene.joint_groups():
        J = np.array(joints)
        if len(J) == 2 and np.all(np.isfinite(scene.q_min[J])) and np.all(np.isfinite(scene.q_max[J])):
            _visibility_map(scene, pieces, joints, scene.margin, (*scene.q_min[J], *scene.q_max[J]))


def _visibility_map(scene, pieces, plane, margin, bounds) -> VisibilityMap:
    """The group's visibility graph, built once per scene, margin and bounds."""
    maps = _MAPS.setdefault(scene, {})
    key = (pieces, margin, bounds)
    if key not in maps:
        shapes = [scene.inflated_shape(p, plane, plan_inflation(margin), bounds) for p in pieces]
        maps[key] = VisibilityMap(shapes, bounds)
    return maps[key]


def _lift(template, J, x):
    out = template.copy()
    out[J] = x
    return out


def _names(scene, J) -> str:
    return "(" + ", ".join(scene.joint_names[j] for j in J) + ")"


def _bounds(scene: Scene, J, q0, q1):
    """The joint limits over J, made finite around the points and zones where they are not."""
    lo, hi = scene.q_min[J].copy(), scene.q_max[J].copy()
    for d, j in enumerate(J):
        vals = [q0[j], q1[j]]
        for part in scene.parts:
            if j in part.joints:
                c = part.joints.index(j)
                vals += [part.lo[c], part.hi[c]] if isinstance(part, Box) else list(part.vertices[:, c])
        pad = max(1.0, np.ptp(vals))
        lo[d] = lo[d] if np.isfinite(lo[d]) else min(vals) - pad
        hi[d] = hi[d] if np.isfinite(hi[d]) else max(vals) + pad
    return lo, hi


def _combine(q0, q1, paths) -> np.ndarray:
    """The product path: every group moves along its own path at the same fraction of its
    length; the other joints move straight."""
    fractions = [np.array([0.0, 1.0])]
    profiles = []
    for J, route in paths:
        seg = np.linalg.norm(np.diff(route, axis=0), axis=1)
        f = np.concatenate(([0.0], np.cumsum(seg))) / max(seg.sum(), 1e-300)
        profiles.append((J, route, f))
        fractions.append(f)
    s = np.unique(np.concatenate(fractions))
    path = q0 + s[:, None] * (q1 - q0)
    for J, route, f in profiles:
        for d, j in enumerate(J):
            path[:, j] = np.interp(s, f, route[:, d])
    keep = np.concatenate(([True], np.any(np.abs(np.diff(path, axis=0)) > 1e-12, axis=1)))
    path = path[keep]
    path[0], path[-1] = q0, q1
    return path
