"""The guard's part of ``rtctl check`` and the ``rtctl plan`` subcommand."""
from __future__ import annotations

import time

import numpy as np

from rtctl.errors import ConfigError, GuardError
from rtctl.guard.feasibility import point_violation
from rtctl.guard.motion import plan_route, route_trajectory
from rtctl.guard.planner import plan_path


def sim_start(cfg):
    """Where the embedded simulator starts (its ``initial_q``, else mid-range clipped to 0), or
    None when the start is only known by measuring it."""
    if cfg.sim is None:
        return None
    q0 = cfg.sim.data.get("initial_q")
    return np.clip(np.zeros(cfg.model.nq), cfg.model.q_min, cfg.model.q_max) if q0 is None else np.asarray(q0, float)


def _fmt(q, deg) -> str:
    return "[" + ", ".join(f"{x:.4g}" for x in (np.degrees(q) if deg else q)) + "]"


def check_lines(cfg, limits) -> list[str]:
    """What ``rtctl check`` says about the guard; GuardError (exit 2) for a start inside a zone
    or a trajectory leg without a path."""
    g = cfg.guard
    if g is None:
        return ["guard: no interference zones"]
    scene = g.scene
    lines = [f"guard: {len(scene.zones)} zone(s) ({', '.join(z.name for z in scene.zones)}), margin "
             f"{scene.margin:.4g} rad, guard margin {g.guard_margin:.4g} rad, action {g.action}"]
    start = sim_start(cfg)
    if start is not None:
        bad = point_violation(scene, start, margin=0.0)
        if bad is not None:
            raise ConfigError(cfg.file, "sim.initial_q", f"a start outside every zone and limit, but it is {bad}")
    if cfg.trajectory is None:
        return lines
    waypoints = cfg.trajectory.waypoints
    origin = start if start is not None else waypoints[0]
    if start is None:
        lines.append("guard: the start is measured at run time; legs from waypoint 0 on:")
        waypoints = waypoints[1:]
    route = plan_route(scene, origin, waypoints, resolution=g.resolution, what="waypoint")
    first = 0 if start is not None else 1
    for i, leg in enumerate(route.legs):
        name = f"leg {'start' if i + first == 0 else i + first - 1} → {i + first}"
        if leg.crossing is None:
            lines.append(f"  {name}: straight, clear")
            continue
        corners = "; ".join(_fmt(p, False) for p in leg.path[1:-1])
        lines.append(f"  {name}: the straight path {leg.crossing}; bypass ({leg.method}, "
                     f"{leg.length:.4g} rad instead of {np.linalg.norm(leg.path[-1] - leg.path[0]):.4g}) via {corners}")
    if len(route.points) > 1:
        trajectory, smooth = route_trajectory(scene, route, limits, smooth=cfg.trajectory.smooth,
                                              dwell=cfg.trajectory.dwell)
        lines.append(f"  trajectory: {trajectory.duration:.3f} s, {'smooth' if smooth else 'stopping at every point'}")
    return lines


def plan(args) -> int:
    """``rtctl plan CONFIG --to …``: print the path around the zones, optionally draw it."""
    from rtctl.config import load_config
    from rtctl.daemon import _trajectory_limits

    cfg = load_config(args.config, sim=args.sim)
    if cfg.guard is None:
        raise ConfigError(cfg.file, "guard", "interference zones (in the robot file or [[guard.zones]]) to plan around")
    n, scale = cfg.model.nq, (np.where(cfg.model.joint_types == 0, np.pi / 180.0, 1.0) if args.deg else 1.0)
    points = {}
    for name, values in (("--to", args.to), ("--from", args.start)):
        if values is not None:
            if len(values) != n or not np.all(np.isfinite(values)):
                raise ConfigError("<command line>", name, f"{n} finite joint values, got {len(values)}")
            points[name] = np.asarray(values, float) * scale
    start = points.get("--from", sim_start(cfg))
    if start is None:
        raise ConfigError("<command line>", "--from", "the start (this configuration has no [sim] initial_q)")
    t0 = time.perf_counter()
    result = plan_path(cfg.guard.scene, start, points["--to"], resolution=cfg.guard.resolution)
    ms = (time.perf_counter() - t0) * 1e3
    unit = "deg" if args.deg else "rad"
    print(f"start  {_fmt(start, args.deg)} {unit}\ntarget {_fmt(points['--to'], args.deg)} {unit}")
    if not result.found:
        print(f"no path: {result.reason} (searched in {ms:.1f} ms)")
        if args.plot:
            _plot(cfg, start, points["--to"], None, args.plot)
        raise GuardError(result.reason)
    limits = _trajectory_limits(cfg)
    route = plan_route(cfg.guard.scene, start, points["--to"], resolution=cfg.guard.resolution)
    trajectory, _ = route_trajectory(cfg.guard.scene, route, limits)
    straight = float(np.linalg.norm(points["--to"] - start))
    print(f"{'straight: clear' if result.crossing is None else 'the straight path ' + str(result.crossing)}")
    print(f"path ({result.method}, {len(result.path)} points, {result.length:.4g} rad; straight "
          f"{straight:.4g} rad), planned in {ms:.1f} ms, moves in {trajectory.duration:.3f} s:")
    for p in result.path:
        print(f"  {_fmt(p, args.deg)}")
    if args.plot:
        _plot(cfg, start, points["--to"], result.path, args.plot)
    return 0


def _plot(cfg, start, target, path, out) -> None:
    from rtctl.guard.plot import plot_plan

    plot_plan(cfg.guard.scene, start, target, path, out, revolute=cfg.model.joint_types == 0)
    print(out)
