"""A ``move`` request → the trajectory that carries it out, from a given reference state.

Pure planning (no loop, no devices): the planner process runs it (:mod:`rtctl.moves.worker`),
and so can a test. The start is the reference the loop will have at ``t0`` — position,
velocity and acceleration stay continuous at the swap — and every waypoint is reached at the
time asked for, or the move is refused with the reason.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rtctl.errors import RtctlError, TrajectoryError


class Start(NamedTuple):
    """The reference state a move starts from (what ``rtctl.guard`` calls ``ref``)."""
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def targets(model, req: dict) -> np.ndarray:
    """The request's waypoints as an (m, nq) array in the model's units (radians / metres)."""
    points = req["waypoints"] if req.get("waypoints") is not None else np.atleast_2d(req["q"])
    points = np.atleast_2d(np.asarray(points, dtype=float))
    if points.ndim != 2 or points.shape[1] != model.nq:
        raise RtctlError(f"move refused: expected {model.nq} joint values per point, got {points.shape[-1]}")
    if req.get("deg"):
        points = points * np.where(model.joint_types == 0, np.pi / 180.0, 1.0)
    return points


def plan_move(cfg, limits, t0: float, start: Start, req: dict):
    """(trajectory starting at ``t0``, extra reply fields) for a validated ``move`` request
    (:func:`rtctl.control_socket.requests.validate`); :class:`RtctlError` "move refused: …"
    when the limits, the zones or the asked times do not allow it."""
    from rtctl.guard import run as guarded
    from rtctl.trajectory import retarget

    points = targets(cfg.model, req)
    times = req.get("times")
    duration = times[0] if times is not None else req.get("duration")
    extra = {}
    try:
        if cfg.guard is not None and times is None:  # around the interference zones
            trajectory, extra = guarded.move_trajectory(cfg, t0, start, points, limits, duration, bool(req.get("deg")))
        else:
            trajectory = retarget(t0, start.q, start.qd, start.qdd, points, limits, duration=duration,
                                  durations=None if times is None else np.diff(times))
            guarded.check_timed_move(cfg, trajectory, t0)
    except TrajectoryError as e:  # (a GuardError says "refused" in its own words)
        raise RtctlError(f"move refused: {e}") from None
    asked = times[-1] if times is not None else duration
    took = trajectory.t_end - t0
    if asked is not None and not extra.get("bypass") and abs(took - asked) > 1e-9 * max(1.0, asked):
        raise RtctlError(f"move refused: it would end after {took:.6g} s, not the {asked:.6g} s asked")
    return trajectory, extra
