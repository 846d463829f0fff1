"""One tick of the loop (docs/architecture.md, "The tick"):

    read() → reference → controllers update() (each at its rate divisor) → safety → write() → record

Joint devices are read first, then the other devices (framegrabber, I/O board …). A device
that fails (ERROR on read or on the previous write) takes the controllers that use it out of
this tick: they are not updated and the safety stage engages the fallback; the fault's reason
names the device and the cause its driver saw (:func:`~rtctl.safety.faults.device_reason`,
built once per failure, when the device starts failing).
While the safety stage is in charge, every device is put in its own safe state before the
write (``Hardware.safe_state``: a leg board locks its joints), in the tick the fault is found.

Each phase is timed by the :class:`~rtctl.timing.Ticker` (``mark``). Nothing here allocates
on the normal path: devices and controllers write into preallocated arrays, the robot-wide
state and command are gathered/scattered with ``np.put``/``np.take``; only an exception —
the fault path, where the fallback takes over — may allocate.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel
from rtctl.hal import Status
from rtctl.safety import Verdict
from rtctl.safety.faults import device_reason
from rtctl.switching import Blend
from rtctl.timing import READ, RECORD, SAFETY, UPDATE, WRITE, LoopStats

OK = int(Status.OK)


@kernel
def track(q, q_ref, err_max, err_sq):
    """Per joint e = |q − q_ref|: max(e) into ``err_max``, e² added to ``err_sq`` (one call a tick)."""
    for j in range(q.shape[0]):
        e = abs(q[j] - q_ref[j])
        if e > err_max[j]:
            err_max[j] = e
        err_sq[j] += e * e


class Tick:
    def __init__(self, runtime, ticker, safety, recorder=None):
        self.rt = runtime
        self.ticker = ticker
        self.safety = safety
        self.recorder = recorder
        self.trajectory = None  # set by the daemon; replaced by `move`
        self.direct = runtime.direct  # one device, all joints: its arrays are the robot's
        n = runtime.model.nq
        # statuses as plain ints: comparing a Status with a numpy integer costs ~5 µs, the tick's whole budget
        self.statuses = np.zeros(len(runtime.devices), dtype=np.int64)  # (the safety stage's kernel reads it)
        self.write_statuses = [OK] * len(runtime.devices)  # carried to the next check
        self.io = list(runtime.io.values())
        self.all_devices = runtime.all_devices
        self.io_statuses = [OK] * len(self.io)
        self.io_write_statuses = [OK] * len(self.io)
        self._io_reasons: list[str | None] = [None] * len(self.io)  # while a device fails: its fault's reason
        self.verdict = Verdict.OK
        self.controller_error: str | None = None
        self.err_sq = np.zeros(n)  # Σ e² for the RMS in the summary
        self.err_max = np.zeros(n)
        self.samples = 0
        self.tracks = any(c.follows_reference for c in runtime.controllers)  # else no tracking error means anything
        self.blend = Blend(n, ticker.period_ns * 1e-9)
        self.starting = ()  # controllers started by a switch: they update at the next tick whatever their divisor

    def __call__(self, t: float) -> Verdict:
        rt, ticker = self.rt, self.ticker
        state, command, ref = rt.state, rt.command, rt.ref

        for i, dev in enumerate(rt.devices):
            status, written = int(dev.read(t)), self.write_statuses[i]
            self.statuses[i] = status if status > written else written  # a failed write counts too
            self.write_statuses[i] = OK
            if not self.direct:
                self._gather(i, dev)
        state.stamp = t
        controller_ok = True
        device_error = None
        for i, dev in enumerate(self.io):
            status, written = int(dev.read(t)), self.io_write_statuses[i]
            if written > status:
                status = written
            self.io_statuses[i] = status
            self.io_write_statuses[i] = OK
            if status != OK:
                if self._io_reasons[i] is None:  # (the fault path: built once per failure)
                    self._io_reasons[i] = device_reason(dev, status)
                device_error = self._io_reasons[i]
            elif self._io_reasons[i] is not None:
                self._io_reasons[i] = None
        ticker.mark(READ)

        if self.trajectory is not None:
            self.trajectory.sample(t, ref.q, ref.qd, ref.qdd)
        starting = self.starting
        for c in rt.controllers:
            if device_error is not None and self._uses_failed_device(c):
                continue
            if ticker.due(c.divisor) or (starting and c in starting):
                try:
                    c.update(t, state, ref, command)
                except Exception as e:  # the safety stage engages the fallback this same tick
                    controller_ok = False
                    self.controller_error = f"{c.name}: {type(e).__name__}: {e}"
        if starting:
            self.starting = ()
        if self.blend.left:
            self.blend.apply(command.tau_ff, ticker.due)
        ticker.mark(UPDATE)

        self.verdict = self.safety.check(t, ticker.tick, state, self.statuses, command, controller_ok,
                                         self.controller_error, None if self.trajectory is None else ref.q,
                                         device_error)
        if self.verdict != Verdict.OK:
            for dev in self.all_devices:
                dev.safe_state()
        ticker.mark(SAFETY)

        for i, dev in enumerate(rt.devices):
            if not self.direct:
                self._scatter(i, dev)
            self.write_statuses[i] = int(dev.write(t))  # seen by the safety stage next tick
        for i, dev in enumerate(self.io):
            self.io_write_statuses[i] = int(dev.write(t))
        ticker.mark(WRITE)

        if self.verdict == Verdict.OK and self.tracks:  # tracking is the controllers' while they are in charge
            self._track()
        if self.recorder is not None:
            self.recorder.row["t"][()] = t
            self.recorder.record()  # (its phase_ns: the previous tick's, this one is still running)
        ticker.mark(RECORD)
        return self.verdict

    def switch(self, active: list, started: list) -> None:
        """Make ``active`` the controllers of the next tick; ``started`` (already reset) take
        over their joints bumplessly from the torque last commanded (:mod:`rtctl.switching`)."""
        self.rt.controllers[:] = active
        self.tracks = any(c.follows_reference for c in active)
        self.starting = tuple(started)
        self.blend.begin(self.rt.command.tau_ff, started)

    def _uses_failed_device(self, controller) -> bool:
        for i, users in enumerate(self.rt.io_users):
            if self.io_statuses[i] != OK and controller in users:
                return True
        return False

    def _gather(self, i: int, dev) -> None:
        """Device i's state into the robot's arrays."""
        idx, s, state = self.rt.device_joints[i], dev.state, self.rt.state
        np.put(state.position, idx, s.position)
        np.put(state.velocity, idx, s.velocity)
        np.put(state.effort, idx, s.effort)
        np.put(state.fresh, idx, s.fresh)

    def _scatter(self, i: int, dev) -> None:
        """The robot's command for device i's joints into the device."""
        idx, c, command = self.rt.device_joints[i], dev.command, self.rt.command
        c.mode = command.mode
        np.take(command.tau_ff, idx, out=c.tau_ff)
        np.take(command.q_des, idx, out=c.q_des)
        np.take(command.qd_des, idx, out=c.qd_des)
        np.take(command.kp, idx, out=c.kp)
        np.take(command.kd, idx, out=c.kd)

    def _track(self) -> None:
        track(self.rt.state.position, self.rt.ref.q, self.err_max, self.err_sq)
        self.samples += 1

    def warm_up(self) -> None:
        """Load the tick's own kernels, its tracking and its ticker's statistics (on scratch:
        compiled here with the run's other kernels, so that ``Ticker.start`` only loads it)."""
        n = len(self.err_sq)
        track(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))
        LoopStats(self.ticker.phases).record(0, [0] * len(self.ticker.phases), 0)

    def tracking_summary(self) -> dict | None:
        """RMS and max |q − q_d| per joint while the controllers were in charge (None when no
        controller follows the reference)."""
        if not self.tracks:
            return None
        names = self.rt.model.joint_names
        m = max(self.samples, 1)
        rms = np.sqrt(self.err_sq / m)
        return {"rms": dict(zip(names, rms.tolist())), "max": dict(zip(names, self.err_max.tolist())),
                "rms_all": float(np.sqrt(self.err_sq.sum() / m / len(names))),
                "max_all": float(self.err_max.max(initial=0.0))}
