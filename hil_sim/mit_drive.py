"""Emulated MIT-protocol drive firmware: the far side of the wire for the CAN joint driver.

A :class:`MitDrive` decodes commands with the shared codec, closes the impedance law
τ = kp (p_des − p) + kd (v_des − v) + t_ff (clamped to the model's torque range) on a
:class:`JointPort` it is given — it owns no physics — answers every command and special frame
with exactly one reply, turns its motor off when no command came for ``timeout_s``
(drive-side watchdog, 20 ms by default) and offers fault-injection knobs (:class:`DriveFaults`).

A :class:`MitDriveBus` is the set of drives on one CAN bus, seen as frames in and frames out;
the transports (python-can bus pump, socketcand server, slcan pty) drive it. :class:`InertiaJoint`
and :func:`free_running` are a stand-in 1-DoF plant for standalone servers, tests and benches;
the embedded simulator supplies the real multi-joint plant through the same port.
"""
from __future__ import annotations

import argparse
import math
import random
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

import can

from drivers.protocols import mit
from drivers.protocols.mit import DRIVE_MODELS, KATZ, MitDriveModel, Special
from rtctl import jsonout
from hil_sim.drive_bus import DriveBus


class JointPort(Protocol):
    """What a drive sees of its joint: the plant's state and a torque input."""

    def get_position(self) -> float: ...
    def get_velocity(self) -> float: ...
    def set_torque(self, tau: float) -> None: ...


@dataclass
class DriveFaults:
    """Fault-injection knobs; change them at any time (the server threads read them live)."""

    silent: bool = False  # a dead drive: receives nothing, answers nothing
    drop_rate: float = 0.0  # probability that a reply is lost
    delay_s: float = 0.0  # replies leave this much later
    corrupt_rate: float = 0.0  # probability that a reply goes out malformed (truncated to 3 bytes)
    seed: int = 0
    rng: random.Random = field(init=False, repr=False)

    def __post_init__(self):
        self.rng = random.Random(self.seed)


@dataclass
class DriveCounters:
    commands: int = 0
    specials: int = 0
    malformed: int = 0  # wrong length or unknown FF…FF xx: ignored, not answered
    replies: int = 0
    dropped: int = 0
    corrupted: int = 0
    watchdog_trips: int = 0
    zero_refused: int = 0  # set-zero while in motor mode is refused (answered, not applied)


class MitDrive:
    """One drive. Call :meth:`receive` for each frame on its id and :meth:`update` at the
    drive's control rate (the plant integrator's substeps)."""

    def __init__(self, drive_id: int, port: JointPort, model: MitDriveModel = KATZ, *,
                 master_id: int = mit.DEFAULT_MASTER_ID, timeout_s: float = 0.020,
                 temperature: float = 30.0, faults: DriveFaults | None = None):
        if not 0 < drive_id <= 0x7FF or drive_id == master_id:
            raise ValueError(f"drive id {drive_id:#x} must be a standard id other than the master's")
        self.drive_id, self.port, self.model = drive_id, port, model
        self.master_id, self.timeout_s, self.temperature = master_id, timeout_s, temperature
        self.faults = faults or DriveFaults()
        self.counters = DriveCounters()
        self.enabled = False
        self.error_code = 0
        self.zero_offset = 0.0
        self.torque = 0.0
        self.last_command_time = -math.inf
        self.command = mit.MitCommand(0.0, 0.0, 0.0, 0.0, 0.0)
        self._reply = bytearray(8)

    # -- firmware -----------------------------------------------------------------------
    def receive(self, data, now: float) -> bytes | None:
        """Handle one frame addressed to this drive; the reply payload, or None (no answer)."""
        if self.faults.silent:
            return None
        if len(data) != mit.COMMAND_LENGTH:
            self.counters.malformed += 1
            return None
        if data[0] == 0xFF and data[:7] == mit.SPECIAL_PREFIX:
            kind = mit.special_kind(data)
            if kind is None:
                self.counters.malformed += 1
                return None
            self.counters.specials += 1
            self._special(kind, now)
        else:
            self.counters.commands += 1
            self.last_command_time = now
            if self.enabled:
                self.command = mit.unpack_command(data, self.model)
        self.update(now)
        return self._answer()

    def _special(self, kind: Special, now: float) -> None:
        if kind is Special.ENTER_MOTOR_MODE:
            if self.error_code == 0:
                self.enabled = True
                self.last_command_time = now  # the watchdog starts now
                self.command = mit.MitCommand(0.0, 0.0, 0.0, 0.0, 0.0)  # never resume a stale command
        elif kind is Special.EXIT_MOTOR_MODE:
            self._motor_off()
        elif kind is Special.SET_ZERO:
            if self.enabled:
                self.counters.zero_refused += 1  # the set-point would jump under a live motor
            else:
                self.zero_offset = self.port.get_position()
        elif kind is Special.CLEAR_ERROR:
            self.error_code = 0

    def _motor_off(self) -> None:
        self.enabled = False
        self.command = mit.MitCommand(0.0, 0.0, 0.0, 0.0, 0.0)

    def update(self, now: float) -> float:
        """Watchdog, then the impedance law on the port's current state; returns the torque."""
        if self.enabled and now - self.last_command_time > self.timeout_s:
            self.counters.watchdog_trips += 1
            self._motor_off()
        if self.enabled and self.error_code == 0:
            c = self.command
            p = self.port.get_position() - self.zero_offset
            tau = c.kp * (c.p - p) + c.kd * (c.v - self.port.get_velocity()) + c.t
            lo, hi = self.model.t
            tau = lo if tau < lo else (hi if tau > hi else tau)
        else:
            tau = 0.0
        self.torque = tau
        self.port.set_torque(tau)
        return tau

    def _answer(self) -> bytes | None:
        f = self.faults
        if f.drop_rate and f.rng.random() < f.drop_rate:
            self.counters.dropped += 1
            return None
        n = mit.pack_reply_into(
            self._reply, self.model, self.drive_id,
            self.port.get_position() - self.zero_offset, self.port.get_velocity(),
            self.torque / self.model.torque_constant,
            temperature=self.temperature, error=self.error_code, enabled=self.enabled,
        )
        if f.corrupt_rate and f.rng.random() < f.corrupt_rate:
            self.counters.corrupted += 1
            n = 3
        self.counters.replies += 1
        return bytes(self._reply[:n])

    # -- fault injection ----------------------------------------------------------------
    def set_error(self, code: int) -> None:
        """Enter the drive error state (motor off until CLEAR_ERROR and ENTER_MOTOR_MODE)."""
        self.error_code = code
        if code:
            self._motor_off()


class MitDriveBus(DriveBus):
    """The MIT drives on one CAN bus (see :class:`hil_sim.drive_bus.DriveBus`): a frame on a
    drive's id is its command or special frame, answered on the drive's master id."""

    def __init__(self, drives, name: str = "can0", advance: Callable[[float], None] | None = None,
                 max_staleness: float = 0.001):
        super().__init__(drives, name, advance, max_staleness)
        self.master_ids = {d.master_id for d in drives}

    def receive(self, arbitration_id: int, data, now: float, out: list, is_extended: bool = False) -> None:
        drive = None if is_extended else self.drives.get(arbitration_id)
        if drive is None:
            if arbitration_id not in self.master_ids or is_extended:
                self.ignored += 1
            return
        self._addressed(now)
        reply = drive.receive(data, now)
        if reply is not None:
            self._reply(drive, drive.master_id, reply, now, out)

    def commanded_by(self, arbitration_id: int, data, is_extended: bool = False) -> tuple:
        if is_extended or arbitration_id not in self.drives:
            return ()
        return (arbitration_id,) if len(data) == mit.COMMAND_LENGTH and not mit.is_special_prefix(data) else ()


class MappedJointPort:
    """Joint ``index`` of an array-backed plant as a drive mounted on it sees it:
    drive position = direction · (q − offset), drive torque → direction · τ on the joint."""

    __slots__ = ("q", "qd", "tau", "index", "direction", "offset")

    def __init__(self, q, qd, tau, index: int, direction: float = 1.0, offset: float = 0.0):
        self.q, self.qd, self.tau, self.index = q, qd, tau, index
        self.direction, self.offset = direction, offset

    def get_position(self) -> float:
        return self.direction * (float(self.q[self.index]) - self.offset)

    def get_velocity(self) -> float:
        return self.direction * float(self.qd[self.index])

    def set_torque(self, tau: float) -> None:
        self.tau[self.index] = self.direction * tau


# -- stand-in plant -------------------------------------------------------------------------
class InertiaJoint:
    """1-DoF J q̈ = τ − b q̇, integrated exactly for a torque held over each step (zero-order
    hold, as the drive's own control loop holds it)."""

    def __init__(self, inertia: float = 0.05, damping: float = 0.05, position: float = 0.0):
        self.inertia, self.damping = inertia, damping
        self.position, self.velocity, self.tau = position, 0.0, 0.0

    def get_position(self) -> float:
        return self.position

    def get_velocity(self) -> float:
        return self.velocity

    def set_torque(self, tau: float) -> None:
        self.tau = tau

    def step(self, h: float) -> None:
        a = self.damping / self.inertia
        v_inf = self.tau / self.damping  # terminal velocity under this torque
        decay = math.exp(-a * h)
        self.position += v_inf * h + (self.velocity - v_inf) * (1.0 - decay) / a
        self.velocity = v_inf + (self.velocity - v_inf) * decay


def free_running(drives, substep: float = 2e-4, max_gap: float = 0.1) -> Callable[[float], None]:
    """An ``advance(now)`` for :class:`MitDriveBus`: integrates each drive's InertiaJoint up to
    ``now`` in ``substep`` steps, the drive's law re-evaluated every step. A gap longer than
    ``max_gap`` (the process was stopped) is not replayed: time jumps."""
    state = {"t": None}

    def advance(now: float) -> None:
        t = state["t"]
        if t is None or now - t > max_gap:
            t = now - substep if t is None else now - max_gap
        while t + substep <= now:
            t += substep
            for d in drives:
                d.update(t)
                d.port.step(substep)
        state["t"] = t

    return advance


def stand_in_bus(ids, model: MitDriveModel = KATZ, name: str = "can0", timeout_s: float = 0.020) -> MitDriveBus:
    """Drives ``ids`` on InertiaJoints, free-running against the clock: what the servers run
    standalone (``python -m hil_sim.socketcand``) and what the tests and benches use."""
    drives = [MitDrive(i, InertiaJoint(), model, timeout_s=timeout_s) for i in ids]
    return MitDriveBus(drives, name=name, advance=free_running(drives))


def add_stand_in_arguments(parser: argparse.ArgumentParser) -> None:
    """Command-line options of the standalone servers (``python -m hil_sim.socketcand|slcan``)."""
    parser.add_argument("--ids", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6], help="drive ids")
    parser.add_argument("--model", default="katz", choices=sorted(DRIVE_MODELS), help="drive model")
    parser.add_argument("--channel", default="can0", help="bus name clients open")
    parser.add_argument("--timeout-ms", type=float, default=20.0, help="drive-side command watchdog")


def stand_in_bus_from_args(args) -> MitDriveBus:
    return stand_in_bus(args.ids, DRIVE_MODELS[args.model], args.channel, args.timeout_ms / 1e3)


def announce(server) -> None:
    """ready_callback for standalone runs: one JSON line saying where the server listens, and
    SIGTERM/SIGINT stop it cleanly."""
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: server.shutdown())
    print(jsonout.dumps(server.info()), flush=True)
    sys.stdout.flush()


# -- python-can transports (virtual in-process, socketcan/vcan) --------------------------------
def pump(drive_bus: MitDriveBus, can_bus: can.BusABC, now: float | None = None) -> int:
    """Lock-step step of the drives behind a python-can bus: handle every frame waiting, send
    the replies (and any now due); returns the number of frames handled. ``now`` defaults to
    the monotonic clock; the embedded simulator passes its own time."""
    now = time.monotonic() if now is None else now
    out: list = []
    handled = 0
    while (msg := can_bus.recv(0.0)) is not None:
        if not (msg.is_error_frame or msg.is_remote_frame):
            drive_bus.receive(msg.arbitration_id, msg.data, now, out, msg.is_extended_id)
        handled += 1
    _send_all(can_bus, out)  # answer first, then advance the plant: the replies are not delayed by it
    drive_bus.service(now, out)
    _send_all(can_bus, out)
    return handled


def _send_all(can_bus: can.BusABC, out: list) -> None:
    for arbitration_id, payload in out:
        can_bus.send(can.Message(arbitration_id=arbitration_id, data=payload, is_extended_id=False))
    out.clear()


def serve_python_can(drive_bus: MitDriveBus, can_bus: can.BusABC, stop: threading.Event,
                     clock: Callable[[], float] = time.monotonic) -> None:
    """Serve the drives on a python-can bus until ``stop`` is set, blocking in ``recv``
    (at most 50 ms, to notice ``stop``; earlier when a watchdog or delayed reply is due)."""
    out: list = []
    while not stop.is_set():
        deadline = drive_bus.next_deadline()
        timeout = 0.05 if deadline is None else min(0.05, max(0.0, deadline - clock()))
        msg = can_bus.recv(timeout)
        now = clock()
        while msg is not None:
            if not (msg.is_error_frame or msg.is_remote_frame):
                drive_bus.receive(msg.arbitration_id, msg.data, now, out, msg.is_extended_id)
            msg = can_bus.recv(0.0)
        _send_all(can_bus, out)
        drive_bus.service(now, out)
        _send_all(can_bus, out)
