"""Interference zones in joint space: feasibility, bypass planning, and the per-tick guard.

* :mod:`.zones` — :class:`Box`, :class:`Polygon`, :class:`Zone` (a union of parts) and the
  compiled :class:`Scene` (zones + joint limits + margin);
* :mod:`.feasibility` — is a target, a segment, a polyline or a trajectory feasible, and
  if not, which zone and where the path first enters it;
* :mod:`.planner` — :func:`plan_path`: the shortest path in a two-joint plane (visibility
  graph), a resolution-complete grid search in n-D, combined per group of linked joints;
* :mod:`.motion` — routes through waypoints and their trajectories within the limits;
* :mod:`.runtime` — :class:`RuntimeGuard`, the safety stage's per-tick check (compiled);
* :mod:`.config` — ``[guard]`` and ``[[guard.zones]]`` from the robot and run configuration.
"""
from rtctl.guard.feasibility import Violation, path_violation, point_violation, segment_violation, trajectory_violation
from rtctl.guard.motion import Route, plan_route, retarget_around, route_trajectory
from rtctl.guard.planner import Plan, plan_path
from rtctl.guard.runtime import RuntimeGuard
from rtctl.guard.zones import Box, Polygon, Scene, Zone

__all__ = ["Box", "Polygon", "Zone", "Scene", "Violation", "point_violation", "segment_violation",
           "path_violation", "trajectory_violation", "Plan", "plan_path", "Route", "plan_route",
           "route_trajectory", "retarget_around", "RuntimeGuard"]
