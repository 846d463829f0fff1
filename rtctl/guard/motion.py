"""Guarded motions: waypoints → bypass paths → a time-parameterised trajectory that keeps clear.

Each leg between consecutive points is planned with :func:`~rtctl.guard.planner.plan_path`;
the trajectory module then times the whole route within the velocity and acceleration
limits. Legs that stop at every point move along straight joint-space segments, so they
keep the planned margin exactly. A smooth trajectory (through the points without stopping)
bends between them; it is kept only when sampling certifies that it stays at least half the
margin from every zone (:func:`~rtctl.guard.feasibility.trajectory_violation`), otherwise the
route stops at every point. A request that cannot be met raises :class:`GuardError` with the
reason; nothing is half-applied.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rtctl.errors import GuardError
from rtctl.guard.feasibility import trajectory_violation
from rtctl.guard.planner import DEFAULT_RESOLUTION, Plan, plan_path
from rtctl.guard.zones import Scene
from rtctl.trajectory import JointLimits, retarget, through_waypoints


@dataclass(frozen=True, eq=False)
class Route:
    """The planned legs and the points a trajectory passes (``waypoint[k]``: point k was asked
    for, not inserted by a bypass)."""

    legs: tuple
    points: np.ndarray  # (k, n), the start first
    waypoint: np.ndarray  # (k,) bool

    @property
    def bypassed(self) -> bool:
        return not bool(np.all(self.waypoint))

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum())


def plan_route(scene: Scene, start, waypoints, *, resolution: float = DEFAULT_RESOLUTION,
               max_nodes: int | None = None, what: str = "waypoint", deg=None) -> Route:
    """Plan every leg start → waypoints[0] → …; :class:`GuardError` naming the first leg that
    has no path (``what`` names the points in the message; ``deg`` as :func:`plan_path` takes it)."""
    W = np.atleast_2d(np.asarray(waypoints, dtype=float))
    points, flags, legs = [np.asarray(start, dtype=float)], [True], []
    for i, target in enumerate(W):
        plan: Plan = plan_path(scene, points[-1], target, resolution=resolution, max_nodes=max_nodes, deg=deg)
        if not plan.found:
            origin = "the start" if i == 0 else f"{what} {i - 1}"
            raise GuardError(f"{what} {i}: cannot go there from {origin}: {plan.reason}")
        legs.append(plan)
        points.extend(plan.path[1:])
        flags.extend([False] * (len(plan.path) - 2) + [True])
    return Route(tuple(legs), np.array(points), np.array(flags))


def route_trajectory(scene: Scene, route: Route, limits: JointLimits, *, smooth: bool = False, dwell=0.0,
                     durations=None, t0: float = 0.0):
    """(trajectory through the route from its start, whether it is smooth); ``dwell`` per asked
    waypoint; ``durations`` (s per asked segment, as ``through_waypoints`` takes them) only for a
    route without bypasses — a bypass adds segments nobody asked a time for (GuardError)."""
    if durations is not None and route.bypassed:
        raise GuardError("the trajectory's durations cannot be kept: a leg goes around a zone (give its corners "
                         "as waypoints with their own durations, or drop durations)")
    asked = int(route.waypoint[1:].sum())
    dwell_at = np.zeros(len(route.points) - 1)
    dwell_at[route.waypoint[1:]] = np.broadcast_to(np.asarray(dwell, float), (asked,))
    if len(route.points) == 1:
        return through_waypoints(route.points, limits, start=route.points[0], t0=t0), smooth
    args = (route.points[1:], limits)
    if smooth:
        trajectory = through_waypoints(*args, start=route.points[0], smooth=True, dwell=dwell_at, durations=durations,
                                       t0=t0)
        if trajectory_violation(scene, trajectory, 0.5 * _clearance(route, scene), limits.v_max) is None:
            return trajectory, True
    return through_waypoints(*args, start=route.points[0], smooth=False, dwell=dwell_at, durations=durations,
                             t0=t0), False


def _clearance(route: Route, scene: Scene) -> float:
    return min((leg.margin for leg in route.legs), default=scene.margin)


def retarget_around(scene: Scene, t: float, q, qd, qdd, waypoints, limits: JointLimits, *,
                    duration: float | None = None, resolution: float = DEFAULT_RESOLUTION,
                    max_nodes: int | None = None, deg=None):
    """The control socket's ``move`` with zones: (trajectory from the current reference state,
    route). Plans around the zones from the reference position; a move that needs a bypass
    stops at its corners and takes the time the limits need (a ``duration`` is refused). The
    result is certified to keep half the margin — the first segment from a moving state is
    not straight — else the move is refused (the robot may still be moving: ask again at rest).
    ``deg``: a per-joint mask of the joints a refusal shows in degrees (a move asked in degrees)."""
    route = plan_route(scene, q, waypoints, resolution=resolution, max_nodes=max_nodes, what="target", deg=deg)
    if route.bypassed and duration is not None:
        raise GuardError("the move has to go around a zone: it takes the time the limits need (drop the duration)")
    trajectory = retarget(t, q, qd, qdd, route.points[1:], limits, duration=duration)
    hit = trajectory_violation(scene, trajectory, 0.5 * _clearance(route, scene), limits.v_max)
    if hit is not None:
        raise GuardError(f"from the current motion the move {hit.describe(deg)} at t = {hit.at:.3f} s: "
                         "wait until the robot is at rest")
    return trajectory, route
