"""``rtctl run``: the foreground daemon (docs/architecture.md, "The tick" and "Process model").

Order of events — every step that can fail does so before the next touches anything:

1. parse and validate the configuration and every plug-in's options (exit 2 on an error);
2. open the control socket and the telemetry file; load the run's kernels, or start compiling
   them in worker processes (a machine's first run, :mod:`rtctl.warmup`); start the move
   planner's process (:mod:`rtctl.moves`);
3. configure the devices (exit 4 if one cannot be brought up, after closing the others) and
   read the initial state; wait for the kernels, logging progress, and load them; apply the
   real-time knobs once the compile workers are gone (exit 5 with ``--enforce-rt`` if one
   cannot be applied); start the trajectory from the state; activate the devices. Steps 2–3
   are :mod:`rtctl.start_up`: the socket serves ``stop`` and ``estop`` meanwhile (from a
   helper thread, gone before the loop), and either ends the start before the next step;
4. the loop, in the main thread, on absolute deadlines, until the duration ends, ``stop``,
   SIGTERM or SIGINT (exit 0) or a safe stop after a fault (exit 3). An operator's
   ``estop`` stops the robot (damping, then drives off) but not the daemon: ``status``
   shows it, ``reset`` re-enables the drives and holds where the arm is, ``stop`` ends;
5. a stop is always controlled: the safety stage damps the motion, then the drives are
   deactivated and closed; the telemetry is closed (nothing recorded is lost) and the
   summary written (strict JSON) and, on a terminal, printed as a table.

Signals only set a flag; the loop acts on it at the next tick boundary.
"""
from __future__ import annotations

import contextlib
import os
import signal
from dataclasses import replace
from pathlib import Path

import structlog

from rtctl import run_records, start_up
from rtctl.config import load_config, realtime_factor
from rtctl.logs import written_in_background
from rtctl.outputs import output_path
from rtctl.control_socket import ControlServer
from rtctl.control_socket.while_starting import ServedWhileStarting
from rtctl.errors import ConfigError, HardwareError, RtctlError, TrajectoryError, exit_code_for
from rtctl.cell import shared as shared_zones
from rtctl.guard import run as guarded
from rtctl.progress import Progress, interval_for
from rtctl.model.dynamics import gravity as gravity_of
from rtctl.moves.pending import Moves
from rtctl.live import LiveChanges
from rtctl.operator import Operator
from rtctl.runtime import build
from rtctl.safety import SafetyStage
from rtctl.telemetry import live_view
from rtctl.tick import Tick
from rtctl.timing import DAEMON_PHASES, SERVE, MonotonicClock, Ticker
from rtctl.trajectory import JointLimits, through_waypoints
from rtctl.warmup import Precompile

EXIT_OK, EXIT_FAULT, EXIT_HARDWARE = 0, 3, 4
STOP_GRACE_S = 5.0  # longest a controlled stop may take before the drives are cut regardless
SERVE_BUDGET = 0.2  # of a period: past it a tick serves no further request (but stop and estop)

log = structlog.get_logger("rtctl.daemon")


def run(args, fmt: str) -> int:
    """``rtctl run``, logging in ``fmt`` (``console`` or ``json``: the CLI has configured it)."""
    daemon = prepare(args)
    daemon.summary_line = fmt == "json"  # on a terminal the table below says it better
    daemon.progress_s = interval_for(getattr(args, "progress", None), fmt)
    daemon.log_in_background = True
    try:
        return daemon.run()
    finally:
        if fmt == "console" and daemon.summary is not None:
            from rtctl.summary_table import format_summary

            print(format_summary(daemon.summary), flush=True)


def prepare(args) -> "Daemon":
    """Everything ``run`` does before it touches anything — parse, validate every plug-in's
    options, plan the trajectory — so ``rtctl check`` runs exactly this (ConfigError: exit 2)."""
    cfg = load_config(args.config, sim=args.sim)
    if getattr(args, "realtime_factor", None) is not None:
        cfg = _with_realtime_factor(cfg, args.realtime_factor)
    cfg = replace(cfg, live=live_view.from_argument(getattr(args, "live", None), cfg.live))
    return Daemon(cfg, build(cfg), args)


def _with_realtime_factor(cfg, factor: float):
    def error(key, expected):
        return ConfigError("<command line>", key, expected)

    factor = realtime_factor(factor, error, "--realtime-factor")
    if factor != 1.0 and cfg.sim is None:
        raise error("--realtime-factor", "1 unless the devices are simulated ([sim] or --sim)")
    return replace(cfg, loop=replace(cfg.loop, realtime_factor=factor))


class Daemon:
    def __init__(self, cfg, runtime, args):
        self.cfg, self.rt, self.args = cfg, runtime, args
        self.model = cfg.model
        self.stop_reason: str | None = None
        self.exit_code = EXIT_OK
        self.estopped = False  # by the operator: drives off, the daemon stays up until `reset` or `stop`
        self.running = False  # the loop has started (before it, a stop or estop ends the start)
        self.summary: dict | None = None  # written by _finish
        self.summary_line = True  # log the summary as one event (the JSON log's last line)
        self.progress_s = 0.0  # a "running" line every progress_s s of wall time (0: none)
        self.limits = JointLimits.for_run(cfg.model, cfg.trajectory)
        self._check_trajectory()
        self.guard = guarded.runtime_guard(cfg, self.limits)
        self.zones = shared_zones.for_run(args, cfg, self.limits)  # a cell's shared zones (--cell): leases, gate
        self.safety = SafetyStage.from_model(
            self.model, cfg.safety, device_joints=runtime.device_joints, devices=runtime.devices,
            gravity=lambda q: gravity_of(self.model, q),
            guard=self.guard if self.zones is None else self.zones.guard(self.guard))
        # a signal's stop request cuts the sleep to the next deadline short: SIGTERM is answered
        # at once, however long the period
        clock = MonotonicClock(round(cfg.loop.spin_us * 1e3), interrupted=lambda: self.stop_reason is not None)
        self.ticker = Ticker(round(1e9 * cfg.loop.period), realtime_factor=cfg.loop.realtime_factor,
                             max_consecutive_overruns=cfg.loop.overrun_limit, clock=clock, phases=DAEMON_PHASES)
        self.recorder = None
        self.live_view = None  # the Foxglove live view's process (rtctl.telemetry.live_view)
        self.telemetry_failure: str | None = None
        self.tick = Tick(runtime, self.ticker, self.safety)
        self.moves = Moves(cfg, self.limits, cfg.loop.period)  # `move`: planned in its own process
        self.live = LiveChanges(self)  # switch controllers, get/set parameters while it runs
        self.operator = Operator(self)  # what the control socket's commands do
        self.log_in_background = False  # `rtctl run`: the log through a writer thread

    # -- lifecycle ---------------------------------------------------------------------
    def run(self) -> int:
        path = self.args.telemetry or self.cfg.telemetry_path
        server = compiling = None
        logs = contextlib.ExitStack()
        # from here on SIGTERM/SIGINT only set the stop flag: a signal during start-up stops
        # the run at its first tick (or, while kernels compile, before the drives are enabled),
        # with the same summary as later
        previous = {s: signal.signal(s, self._on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
        try:
            if self.args.summary:  # (written at the end: a path that cannot be is refused now)
                output_path(self.args.summary, "--summary")
            # the exclusive resources first (a second daemon on the same socket or telemetry
            # file gives up here), then truncate: nothing another run holds is overwritten
            server = ControlServer(self.args.socket or self.cfg.socket_path, self.operator.handle, n_joints=self.model.nq,
                                   budget_s=SERVE_BUDGET * self.cfg.loop.period)
            if self.cfg.live is not None:  # (exit 2 before the telemetry file is truncated)
                live_view.check_port(self.cfg.live)
            if path or self.cfg.live is not None:  # the live view reads the recorder's ring
                self.recorder = run_records.open_recorder(self, Path(path or os.devnull))
            if self.cfg.live is not None:
                self.live_view = live_view.LiveView.start(self.recorder, self.cfg.live)
                log.info("live view", url=self.live_view.url)
            compiling = Precompile(start_up.warm_up_groups(self)).start(
                loading=ServedWhileStarting(server, "loading the compiled kernels"),
                stop=lambda: start_up.stopping(self))
            self.moves.start()  # the move planner: a process of its own, like the compile workers
            if compiling.loaded == len(compiling.groups):  # nothing to compile: it loads its kernels now
                self.moves.warm()
            if self.log_in_background:  # (a thread: only after the forks) a slow log reader must not stall a tick
                logs.enter_context(written_in_background())
            if start_up.bring_up(self, compiling, server):
                self._loop(server)
            self._fault_if_latched()
        except HardwareError as e:
            log.error("hardware failed", error=str(e))
            self.exit_code, self.stop_reason = EXIT_HARDWARE, f"hardware: {e}"
            raise
        except RtctlError as e:  # the summary says what the process exits with
            self.exit_code = exit_code_for(e)[0]
            self.stop_reason = self.stop_reason or str(e)
            raise
        finally:
            if compiling is not None:
                compiling.abort()
            self.deactivate_all()  # the drives first
            for dev in self.rt.all_devices:
                dev.close()
            self.moves.close()
            if server is not None:
                server.close(stopping=self.stop_reason or "its run ended")
            run_records.finish(self)
            for s, h in previous.items():
                signal.signal(s, h)
            logs.close()  # what is queued is written
        return self.exit_code

    def _fault_if_latched(self) -> None:
        """A run that ends while its fallback is engaged (a fault not cleared by ``reset``,
        e.g. within the fault's off-delay when the duration ends) is a fault stop, not a clean one."""
        pending = [f.reason for f in self.safety.faults]  # (a normal stop latches none)
        if pending and self.exit_code == EXIT_OK:
            self.exit_code = EXIT_FAULT
            log.error("fault: safe stop", reason="the run ended with faults latched: " + "; ".join(pending[:3]),
                      stop_reason=self.stop_reason)

    def hand_over(self, trajectory, t: float) -> None:
        """Run ``trajectory`` from time ``t`` with fresh controllers (at the start, and after a
        ``reset``); the devices are the caller's to activate."""
        ref = self.rt.ref
        if self.zones is not None:  # (it waits at a shared zone's border for the lease)
            trajectory = self.zones.gated(trajectory, t)
        self.tick.trajectory = trajectory
        trajectory.sample(t, ref.q, ref.qd, ref.qdd)
        for c in self.rt.configured:  # (the inactive ones too: a switch starts them from here)
            c.reset(self.rt.state)

    def _check_trajectory(self) -> None:
        """Plan the configured trajectory from its first waypoint now: the measured start is
        known only once the devices are up, and a plan the limits refuse must exit 2 before."""
        tcfg = self.cfg.trajectory
        if tcfg is not None:
            try:
                through_waypoints(tcfg.waypoints, self.limits, smooth=tcfg.smooth, dwell=tcfg.dwell)
            except TrajectoryError as e:
                raise ConfigError(self.cfg.file, "trajectory", f"waypoints the limits allow to plan ({e})") from None

    def _loop(self, server) -> None:
        ticker, tick, safety, moves = self.ticker, self.tick, self.safety, self.moves
        duration = self.args.duration
        stopping_since = None
        self.running = True
        ticker.start()
        if self.zones is not None:  # (leases arrive as CLOCK_MONOTONIC instants)
            self.zones.tick0_ns = ticker.deadline_ns(0)
        progress = Progress(self.progress_s, duration, ticker, self.rt.state, self.rt.ref, tracking=tick.tracks)
        while True:
            ticker.wait()
            t = ticker.sim_time_s
            progress.tick(t)
            if self.stop_reason is None and duration is not None and t >= duration:
                self.stop_reason = "duration reached"
            if self.stop_reason is not None and stopping_since is None:
                stopping_since = t
                safety.stop(self.stop_reason)  # category 1 like an e-stop, but not a fault
                moves.cancel(self.stop_reason)
            planned = moves.swap(t)  # a planned move starts at a tick boundary
            if planned is not None:
                tick.trajectory = planned if self.zones is None else self.zones.gated(planned, t)
            tick(t)
            if tick.recorder is not None and tick.recorder.failure is not None:
                self._telemetry_failed(tick.recorder.failure)
            if server is not None:
                server.poll()
            if moves.move is not None and safety.faulted:
                moves.cancel("a fault is latched: " + safety.faults[-1].reason)
            moves.poll(t, tick.trajectory)
            ticker.mark(SERVE)
            if ticker.end_tick() and stopping_since is None:
                self._fault("overrun limit reached")
            # the stage, not this tick's verdict: a `reset` in poll() may just have re-armed it
            if safety.deactivated or (stopping_since is not None and t - stopping_since > STOP_GRACE_S):
                if self.stop_reason is None and not self.estopped:
                    self._fault("safety stop: " + "; ".join(f.reason for f in safety.faults[-3:]))
                self.deactivate_all()
                if self.stop_reason is not None:
                    break

    def deactivate_all(self) -> None:
        """Every device's actuators off. One that cannot confirm it is a hardware error: what
        stops its drives then is their own watchdog, and the operator must know."""
        for dev in self.rt.all_devices:
            if not dev.deactivate():
                log.error("drives not confirmed off", device=dev.name, reason=dev.last_error)
                if self.exit_code == EXIT_OK:
                    self.exit_code = EXIT_HARDWARE

    def _telemetry_failed(self, reason: str) -> None:
        """The writer cannot write (a full disk): say so now, stop recording, and apply the
        policy — a safe stop (default), or running on without telemetry."""
        self.tick.recorder = None
        self.telemetry_failure = reason
        policy = self.cfg.telemetry_on_failure
        log.error("telemetry failed", reason=reason, on_failure=policy, rows=self.recorder.rows)
        if policy == "stop":
            self._fault(f"telemetry: {reason}")

    def _fault(self, reason: str) -> None:
        if self.stop_reason is None:
            self.stop_reason = reason
            self.exit_code = EXIT_FAULT
            log.error("safe stop after a fault", reason=reason)

    def _on_signal(self, signum, frame) -> None:
        if self.stop_reason is None:
            self.stop_reason = f"signal {signal.Signals(signum).name}"
