"""The planner process: ``move`` requests in on a pipe, trajectories (or the refusal) out.

Planning a move has no useful time bound (a search around the zones, a long move checked
against them every 2 ms of its path): here it can take what it takes without delaying a tick.
The process is spawned (a fresh interpreter: it inherits no device, socket or thread of the
daemon) at a low CPU priority (nice 10), so on a loaded machine it waits for the loop, not the
reverse; it loads its kernels from the cache the daemon's warm-up filled, then says "ready".

It is started before the daemon takes its real-time settings (so it inherits none of them;
one started later drops them first thing) and warms up when the daemon says so — once the
kernels it loads are compiled.

Messages (pickled tuples on a :func:`multiprocessing.Pipe`; the planner's cut into pieces the
loop can read without waiting, :mod:`rtctl.moves.wire`)::

    daemon → planner   ("warm",)
                       (id, t0, q, qd, qdd, request)
    planner → daemon   ("ready", seconds)
                       (id, "ok", knots, coeffs, extra, seconds)
                       (id, "refused", message, seconds)

It exits when the daemon's end of the pipe closes (the daemon stopped or died).
"""
from __future__ import annotations

import os
import pickle
import signal
import time
import traceback


# below every normal process, not at the very bottom: at nice 19 a machine kept busy by other
# work (a test suite next to it) gave it 1.5 % of a core and a move waited half a minute
PLANNER_NICE = 10


def main(conn, payload: bytes, loop_cpus: tuple = ()) -> None:
    """The process's entry point: ``payload`` is the pickled (configuration, joint limits);
    ``loop_cpus`` the CPUs the loop is pinned to (the planner keeps off them when it can)."""
    _leave_realtime(loop_cpus)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the daemon's to answer
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # what the planners log is in the reply, not on the daemon's terminal
    from rtctl.moves import wire

    cfg, limits = pickle.loads(payload)
    try:
        while True:
            msg = conn.recv()
            if msg[0] == "warm":
                t_start = time.monotonic()
                _warm_up(cfg, limits)
                wire.send(conn, ("ready", time.monotonic() - t_start))
            else:
                wire.send(conn, _serve(cfg, limits, msg))
    except (EOFError, OSError):  # the daemon has gone
        return


def _leave_realtime(loop_cpus: tuple) -> None:
    """A low CPU priority, and no real-time policy or pinning inherited from the loop:
    planning must wait for the loop, never the reverse."""
    try:
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        others = set(range(os.cpu_count() or 1)) - set(loop_cpus)
        if others:
            os.sched_setaffinity(0, others)
        os.nice(PLANNER_NICE - os.nice(0))
    except (OSError, AttributeError):  # (not Linux, or not allowed: then as it is)
        pass


def _warm_up(cfg, limits) -> None:
    """Load the planners' kernels and build the zones' visibility graphs before the first move."""
    import numpy as np

    from rtctl.moves.plan import Start, plan_move

    if cfg.guard is not None:
        from rtctl.guard.planner import prepare

        prepare(cfg.guard.scene)
    q = np.clip(np.zeros(cfg.model.nq), limits.q_min, limits.q_max)
    zero = np.zeros_like(q)
    try:
        plan_move(cfg, limits, 0.0, Start(q, zero, zero), {"q": q, "waypoints": None, "times": None})
    except Exception:  # (the zero posture may be inside a zone: the kernels are loaded all the same)
        pass


def _serve(cfg, limits, msg):
    from rtctl.errors import RtctlError
    from rtctl.moves.plan import Start, plan_move

    ident, t0, q, qd, qdd, req = msg
    began = time.monotonic()
    try:
        trajectory, extra = plan_move(cfg, limits, t0, Start(q, qd, qdd), req)
    except RtctlError as e:
        return ident, "refused", str(e), time.monotonic() - began
    except Exception as e:  # a bug: the operator gets its name, the loop never sees it
        where = traceback.extract_tb(e.__traceback__)[-1]
        return (ident, "refused", f"internal error planning the move: {type(e).__name__}: {e} "
                f"({os.path.basename(where.filename)}:{where.lineno})", time.monotonic() - began)
    return ident, "ok", trajectory.knots, trajectory.coeffs, extra, time.monotonic() - began
