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
from importlib import import_module

# imported on first use (PEP 562): a configuration with zones must not pay for the planners,
# shapely and the compiled kernels just to be loaded (every `rtctl status` loads one)
_HOME = {"Box": "zones", "Polygon": "zones", "Zone": "zones", "Scene": "zones", "Violation": "feasibility",
         "point_violation": "feasibility", "segment_violation": "feasibility", "path_violation": "feasibility",
         "trajectory_violation": "feasibility", "Plan": "planner", "plan_path": "planner", "Route": "motion",
         "plan_route": "motion", "route_trajectory": "motion", "retarget_around": "motion",
         "RuntimeGuard": "runtime"}
__all__ = list(_HOME)


def __getattr__(name):
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"rtctl.guard.{_HOME[name]}"), name)
