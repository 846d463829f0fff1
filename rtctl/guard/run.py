"""What the daemon asks of the guard: the per-tick hook, the start check, guarded trajectories."""
from __future__ import annotations

import numpy as np
import structlog

from rtctl.errors import GuardError
from rtctl.guard.feasibility import point_violation
from rtctl.guard.motion import plan_route, retarget_around, route_trajectory
from rtctl.guard.planner import prepare
from rtctl.guard.runtime import RuntimeGuard

log = structlog.get_logger("rtctl.guard")


def runtime_guard(cfg, limits) -> RuntimeGuard | None:
    """The safety stage's guard for this run (None without zones): the deceleration limit is
    the configured one, else the trajectory's acceleration limits."""
    g = cfg.guard
    if g is None:
        return None
    decel = g.deceleration if g.deceleration is not None else limits.a_max
    return RuntimeGuard(g.scene, decel, cfg.loop.period, margin=g.guard_margin, action=g.action,
                        damping=cfg.safety.damping, stiffness=cfg.safety.hold_stiffness)


def warm_up(cfg, guard) -> None:
    """Before "started": the per-tick check compiled or loaded, the planners' kernels loaded and
    the visibility graphs built (a `move` is planned inside the loop)."""
    if guard is not None:
        guard.warm_up()
        prepare(cfg.guard.scene)


def check_start(cfg, q) -> None:
    """GuardError when the measured start configuration is inside a zone (the run must not start)."""
    if cfg.guard is None:
        return
    bad = point_violation(cfg.guard.scene, q, margin=0.0)
    if bad is not None and not bad.what.endswith(" limit"):  # limits: the safety stage's call
        raise GuardError(f"the start configuration is {bad}: the robot cannot start inside an "
                         f"interference zone (move it out with the drives off, or correct the zone)")
    near = point_violation(cfg.guard.scene, q)
    if near is not None and not near.what.endswith(" limit"):
        log.warning("start near a zone", detail=str(near))


def initial_trajectory(cfg, q0, limits):
    """The configured trajectory from the measured start, around the zones (GuardError if a
    leg has no path)."""
    tcfg, g = cfg.trajectory, cfg.guard
    route = plan_route(g.scene, q0, tcfg.waypoints, resolution=g.resolution, max_nodes=g.plan_budget)
    trajectory, smooth = route_trajectory(g.scene, route, limits, smooth=tcfg.smooth, dwell=tcfg.dwell,
                                          durations=tcfg.durations)
    bypassed = [i for i, leg in enumerate(route.legs) if leg.crossing is not None]
    if bypassed or smooth != tcfg.smooth:
        log.info("guarded trajectory", bypassed_legs=bypassed, points=len(route.points), smooth=smooth,
                 length_rad=round(route.length, 4), duration_s=round(trajectory.duration, 3))
    return trajectory


def check_timed_move(cfg, trajectory, t0: float, step: float = 0.002) -> None:
    """A move whose times the operator fixed cannot be routed around a zone: GuardError naming
    the zone when its path (sampled every ``step`` s) enters one."""
    if cfg.guard is None:
        return
    q, qd, qdd = np.zeros(trajectory.n), np.zeros(trajectory.n), np.zeros(trajectory.n)
    for t in np.arange(t0, trajectory.t_end + step, step):
        trajectory.sample(min(t, trajectory.t_end), q, qd, qdd)
        bad = point_violation(cfg.guard.scene, q, margin=0.0)
        if bad is not None and not bad.what.endswith(" limit"):
            raise GuardError(f"move refused: with the times given the path enters {bad} at t = {t - t0:.3f} s; "
                             f"give no times to let the guard plan around it")


def move_trajectory(cfg, t, ref, points, limits, duration=None, deg=False):
    """(trajectory, reply fields) for the control socket's ``move``; GuardError when refused
    (positions in degrees for the revolute joints when the move was asked in degrees)."""
    g = cfg.guard
    mask = cfg.model.joint_types == 0 if deg else None
    trajectory, route = retarget_around(g.scene, t, ref.q, ref.qd, ref.qdd, points, limits, duration=duration,
                                        resolution=g.resolution, max_nodes=g.move_budget, deg=mask)
    inserted = route.points[1:][~route.waypoint[1:]]
    return trajectory, {"bypass": np.asarray(inserted).tolist()}
