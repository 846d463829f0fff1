"""The guard's part of ``rtctl check`` and the ``rtctl plan`` subcommand."""
from __future__ import annotations

import time

import numpy as np

from rtctl.errors import ConfigError, GuardError
from rtctl.guard.feasibility import format_q, point_violation
from rtctl.guard.motion import plan_route, route_trajectory


def sim_start(cfg):
    """Where the embedded simulator starts (its ``initial_q``, else mid-range clipped to 0), or
    None when the start is only known by measuring it."""
    if cfg.sim is None:
        return None
    q0 = cfg.sim.data.get("initial_q")
    return np.clip(np.zeros(cfg.model.nq), cfg.model.q_min, cfg.model.q_max) if q0 is None else np.asarray(q0, float)


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
    route = plan_route(scene, origin, waypoints, resolution=g.resolution, max_nodes=g.plan_budget, what="waypoint")
    first = 0 if start is not None else 1
    for i, leg in enumerate(route.legs):
        name = f"leg {'start' if i + first == 0 else i + first - 1} → {i + first}"
        if leg.crossing is None:
            lines.append(f"  {name}: straight, clear")
            continue
        corners = "; ".join(format_q(p) for p in leg.path[1:-1])
        lines.append(f"  {name}: the straight path {leg.crossing}; bypass ({leg.method}, "
                     f"{leg.length:.4g} rad instead of {np.linalg.norm(leg.path[-1] - leg.path[0]):.4g}) via {corners}")
    durations = cfg.trajectory.durations
    if durations is not None and start is None:
        durations = durations[1:]  # (the first is the move from the start, not known here)
    if len(route.points) > 1:
        trajectory, smooth = route_trajectory(scene, route, limits, smooth=cfg.trajectory.smooth,
                                              dwell=cfg.trajectory.dwell, durations=durations)
        lines.append(f"  trajectory: {trajectory.duration:.3f} s, {'smooth' if smooth else 'stopping at every point'}")
    return lines


def plan(args) -> int:
    """``rtctl plan CONFIG [--to …]``: print the path around the zones (to the target, or along the
    configuration's trajectory), optionally draw it."""
    from rtctl.config import load_config
    from rtctl.trajectory import JointLimits

    if args.plot:
        from rtctl.outputs import output_path

        args.plot = output_path(args.plot, "--plot", suffixes=(".png", ".pdf", ".svg"), default_suffix=".png")
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
    if "--to" in points:
        targets = points["--to"][None]
    elif cfg.trajectory is not None:
        targets = cfg.trajectory.waypoints
    else:
        raise ConfigError("<command line>", "--to", "a target (this configuration has no [trajectory])")
    scene, unit = cfg.guard.scene, "deg" if args.deg else "rad"
    deg = cfg.model.joint_types == 0 if args.deg else None  # the joints every position is shown in degrees

    def show(q) -> str:
        return f"{format_q(q, deg)} {unit}"

    def length(path) -> float:  # in the unit shown
        shown = path if deg is None else np.where(deg, np.degrees(path), path)
        return float(np.linalg.norm(np.diff(shown, axis=0), axis=1).sum())

    print(f"start  {show(start)}")
    t0 = time.perf_counter()
    try:
        route = plan_route(scene, start, targets, resolution=cfg.guard.resolution, max_nodes=cfg.guard.plan_budget,
                           what="target", deg=deg)
    except GuardError as e:
        print(f"no path: {e} (searched in {(time.perf_counter() - t0) * 1e3:.1f} ms)")
        if args.plot:
            _plot(cfg, start, targets[-1], None, args.plot)
        raise
    ms = (time.perf_counter() - t0) * 1e3
    trajectory, smooth = route_trajectory(scene, route, JointLimits.for_run(cfg.model, cfg.trajectory),
                                          smooth=cfg.trajectory.smooth if "--to" not in points else False)
    for i, leg in enumerate(route.legs):
        straight = length(leg.path[[0, -1]])
        print(f"target {show(leg.path[-1])}: " +
              ("straight, clear" if leg.crossing is None else f"the straight path {leg.crossing.describe(deg)}") +
              f"\n  path ({leg.method}, {len(leg.path)} points, {length(leg.path):.4g} {unit}; "
              f"straight {straight:.4g} {unit}):")
        for p in leg.path[1:]:
            print(f"    {format_q(p, deg)}")
    print(f"planned in {ms:.1f} ms; {length(route.points):.4g} {unit} in all, moves in {trajectory.duration:.3f} s "
          f"({'smooth' if smooth else 'stopping at every point'})")
    if args.plot:
        _plot(cfg, start, targets[-1], route.points, args.plot, asked=np.vstack([start, targets]))
    return 0


def _plot(cfg, start, target, path, out, asked=None) -> None:
    from rtctl.guard.plot import plot_plan

    plot_plan(cfg.guard.scene, start, target, path, out, revolute=cfg.model.joint_types == 0, asked=asked)
    print(out)
