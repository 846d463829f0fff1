"""The daemon's start: from its open socket to the first tick (steps 2–3 in :mod:`rtctl.daemon`).

Each step that can take long — loading or compiling kernels, configuring and activating a
device, planning the first trajectory — runs in the main thread while the control socket is
served from a helper thread (:class:`~rtctl.control_socket.while_starting.ServedWhileStarting`):
a ``stop`` or ``estop`` is answered in milliseconds, and the start asks after every step
whether one came. If so it ends there, before the loop; the daemon's clean-up then disables
whatever was enabled and closes the devices.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import structlog

from rtctl.control_socket.while_starting import ServedWhileStarting
from rtctl.errors import HardwareError, RtctlError, TrajectoryError
from rtctl.guard import run as guarded
from rtctl.hal import JointCommand, Status
from rtctl.safety import SafetyStage
from rtctl.timing import KnobStatus, apply_rt, rt_budget
from rtctl.trajectory import hold, through_waypoints
from rtctl.warmup import Precompile

log = structlog.get_logger("rtctl.daemon")


def bring_up(d, compiling: Precompile, server) -> bool:
    """Configure the devices, prepare the kernels, plan, activate: True when started, False
    when a ``stop`` or an ``estop`` came first (logged with what was enabled by then)."""
    activated: list[str] = []
    with ServedWhileStarting(server, "configuring the devices") as served:
        for _ in _steps(d, compiling, activated, served.doing):
            if stopping(d):
                break
        else:
            log.info("started", config=str(d.cfg.file), robot=d.model.name, rate_hz=d.cfg.loop.rate_hz,
                     realtime_factor=d.cfg.loop.realtime_factor, devices=[x.name for x in d.rt.all_devices],
                     controllers=[c.name for c in d.rt.controllers])
            return True
    if d.estopped:
        d.stop_reason = ("operator e-stop before start: no drive was enabled" if not activated else
                         f"operator e-stop during start-up: {', '.join(activated)} disabled again")
    log.info("stopped before start", reason=d.stop_reason, activated=activated)
    return False


def stopping(d) -> bool:
    """A stop or an e-stop has come: the start ends at its next check."""
    return d.stop_reason is not None or d.estopped


def _steps(d, compiling: Precompile, activated: list[str], doing):
    """The start, one step per ``yield`` (where :func:`bring_up` looks for a stop); ``doing``
    is told each step first (what a request other than stop or estop is answered meanwhile)."""
    yield  # (one may have come while the cached kernels loaded)
    for dev in d.rt.all_devices:
        doing(f"configuring {dev.name}")
        _call(dev, "configure")
        yield
    state = d.rt.state
    for dev in d.rt.io.values():
        if dev.read(0.0) != Status.OK:
            raise HardwareError(f"{dev.name}: no valid state after configure ({dev.last_error})")
    for i, dev in enumerate(d.rt.devices):
        if dev.read(0.0) != Status.OK:
            raise HardwareError(f"{dev.name}: no valid state after configure ({dev.last_error})")
        idx = d.rt.device_joints[i]
        np.put(state.position, idx, dev.state.position)
        np.put(state.velocity, idx, dev.state.velocity)
    guarded.check_start(d.cfg, state.position)
    if not compiling.done:  # (a run that loaded every kernel at its start says nothing of compiling)
        doing("compiling kernels (a first run)")
        compiling.wait(stop=lambda: stopping(d))
        yield
        doing("loading the compiled kernels")
        compiling.finish()
        yield
    doing("planning the initial trajectory")
    if d.recorder is not None:  # (started long before: it is normally waiting already)
        d.recorder.wait_ready()
    apply_rt_knobs(d)
    d.moves.warm()  # it loads the planners' kernels from the cache just filled
    try:
        d.hand_over(initial_trajectory(d, state.position.copy()), 0.0)
    except TrajectoryError as e:  # the devices report a start the limits do not allow
        raise HardwareError(f"cannot start the trajectory from the measured position: {e}") from None
    yield
    for dev in d.rt.all_devices:
        doing(f"activating {dev.name}")
        _call(dev, "activate", passes=())
        activated.append(dev.name)
        yield


def _call(dev, step: str, passes: tuple = (RtctlError,)) -> None:
    try:
        getattr(dev, step)()
    except passes:  # (configure's own errors say what is wrong; activate's are all hardware)
        raise
    except Exception as e:
        raise HardwareError(f"{dev.name}: {step} failed: {type(e).__name__}: {e}") from e


def initial_trajectory(d, q0):
    tcfg = d.cfg.trajectory
    if tcfg is None:
        return hold(q0)
    if d.cfg.guard is not None:
        return guarded.initial_trajectory(d.cfg, q0, d.limits)
    return through_waypoints(tcfg.waypoints, d.limits, start=q0, smooth=tcfg.smooth, dwell=tcfg.dwell,
                             durations=tcfg.durations)


# -- the real-time knobs ---------------------------------------------------------------------
def apply_rt_knobs(d) -> None:
    """The real-time knobs, once the compile workers are gone (a loop at SCHED_FIFO would
    take a core from them) and before a drive is enabled (exit 5 with ``--enforce-rt``)."""
    rt, lock_step = _rt_settings(d)
    for report in apply_rt(rt, enforce=d.args.enforce_rt):
        if report.knob == "sched_fifo" and lock_step:
            log.warning("rt knob", knob="sched_fifo", status="off",
                        detail="lock-step (realtime_factor = 0) never sleeps: SCHED_FIFO would starve its core")
            continue
        log.info("rt knob", **report.as_dict())
        if report.knob == "sched_fifo" and report.status is KnobStatus.APPLIED:
            d.ticker.busy.limit = rt_budget()  # Linux stops a FIFO thread over it


def _rt_settings(d):
    """(The knobs to apply, whether SCHED_FIFO was dropped): ``--enforce-rt`` asks for the
    full set (what is not configured gets a default); a lock-step run never sleeps, so it
    must not run SCHED_FIFO (it would starve its core) — its priority knob is left alone."""
    rt = d.cfg.loop.rt
    if d.args.enforce_rt:
        rt = replace(rt, priority=rt.priority or 80, mlockall=True, timer_slack_ns=rt.timer_slack_ns or 1,
                     gc_freeze=True)
    if d.cfg.loop.realtime_factor == 0 and rt.priority:
        return replace(rt, priority=0), True
    return rt, False


# -- the kernels ---------------------------------------------------------------------------
def warm_up_groups(d) -> list:
    """Every compiled path of this run, as groups that run it once on throwaway outputs (so
    that no tick pays for loading or compiling a numba kernel), in the order workers take
    them (:class:`~rtctl.warmup.Precompile`): a simulated plant first (it compiles the whole
    dynamics library the controllers and the safety stage share), then the guard, the
    controllers, the safety stage."""
    scratch = JointCommand(d.model.nq)
    devices = [(f"device {x.name}", x.warm_up) for x in d.rt.all_devices if hasattr(x, "warm_up")]
    guard = [("guard", lambda: guarded.warm_up(d.cfg, d.guard))] if d.guard is not None else []
    guard += [("shared zones", d.zones.warm_up)] if d.zones is not None else []
    controllers = [(f"controller {c.name}", lambda c=c: c.update(0.0, d.rt.state, d.rt.ref, scratch))
                   for c in d.rt.configured]  # (an inactive one compiled now, not at its switch)
    return devices + guard + controllers + [("safety stage", lambda: _warm_up_safety(d, scratch)),
                                            ("tick", d.tick.warm_up)]


def _warm_up_safety(d, scratch) -> None:
    """The safety stage's normal and fault paths (hold with gravity, damped stop): the first
    real fault must not stall the loop longer than the drives' 20 ms watchdog."""
    spare = SafetyStage.from_model(d.model, d.cfg.safety, device_joints=d.rt.device_joints, gravity=d.safety.gravity)
    spare.log_events = False
    statuses = np.zeros(len(d.rt.devices), dtype=np.int64)
    spare.check(0.0, 0, d.rt.state, statuses, scratch, True)
    spare.check(0.0, 1, d.rt.state, statuses, scratch, False, "warm-up")  # → hold
    spare.estop("warm-up")
    spare.check(0.0, 2, d.rt.state, statuses, scratch, True)  # → damped stop
