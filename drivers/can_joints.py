"""MIT-protocol CAN joint drives as one JointGroup per bus (driver ``mit_can``; docs/can_joints.md).

One device is one CAN bus; a robot on several buses is several devices (the budget still adds
up devices that name the same bus). Options (the ``[[devices]]`` table; drive layout in
:mod:`drivers.protocols.mit_layout`, bus in :mod:`drivers.can_bus`)::

    protocol = "mit"          # for the bus-load budget: "mit" (6-byte replies), "mit8" (default when a reply is 8 bytes)
    bus_load_limit = 0.8      # refuse the configuration above it (exit 2)
    reply_deadline = 0.6      # fraction of the period after write() by which the replies are due
    stale_limit = 3           # ticks in a row without a joint's reply → Status.ERROR
    drive_timeout = 0.02      # s: the drives' command watchdog; a longer gap in our commands → DEACTIVATE
    exchange_timeout = 0.5    # s for the answers to enter/exit motor mode and set-zero
    reconnect_timeout = 2.0   # s of reopening after a bus error; then the device stays ERROR
    reconnect_interval = 0.05 # s between attempts
    set_zero = false          # set every drive's zero at configure (motor off)

Lifecycle: ``configure`` opens the bus and sends *exit motor mode* to every drive — answered
with its state, so states are readable and nothing is enabled (a drive left on by a crashed
run is turned off). ``activate`` sends *enter motor mode* and requires every answer.
``deactivate`` sends *exit motor mode* at once, always (reopening the bus once if it was lost),
up to three times until every drive answered it. A drive answers every frame, in order, and the
Katz reply does not say whether the motor is on: an answer to a mode frame is a reply beyond
every reply the drive could still owe for earlier frames — including those the tick gave up on,
until ``exchange_timeout`` (the bound on a reply's lateness) has passed — never a late reply to
an earlier command (docs/can_joints.md). A Damiao answer must also say the motor is off. A drive
not confirmed so makes ``deactivate`` fail (the daemon reports it and exits 4): its watchdog is
then what turns it off.

Per tick: the drives answer only commands. ``write()`` sends all commands and returns;
``read()`` of the next tick collects the answers — usually already there, a period later — and
waits only for those still due (until ``reply_deadline × period`` after the send, blocking in
``recv``, not spinning), then publishes them. The state the controllers see is the drives'
measurement taken when tick k's commands arrived — one period old, inherent to a protocol that
replies to commands, whichever call collects. Collecting in ``write()`` (until 2026-12-02)
waited out the round trip inside the tick — 0.6 ms at the median for 6 drives over socketcand —
and with the host's jitter up to 31 % of a 500 Hz loop's ticks overran (docs/can_joints.md; the
CiA 402 driver made the same move, docs/cia402.md).

A reply after its deadline is taken at the start of the next ``write()``, before the new frames
go out (its values are the newest and are published, but its joint is not fresh), and the
collection after it waits for each drive's answer to the frames just sent — the last reply it
owes. Otherwise a late reply, first in the next collection, would be taken as that tick's answer
and the real one would miss its tick in turn: each stall would leave the measurement one more
period old, unnoticed. Torque mode sends kp = kd = 0, t = τ.

Hot path: the command messages and all arrays are preallocated; the codec packs into the
messages' own ``data``. python-can still allocates a Message per received frame, and its
socketcand and slcan ``send`` format a string per frame (unavoidable without replacing them).

Once every drive has answered, a collection also takes what else is already there (a frame
received twice, a reply no drive owed: ``extra_replies``), so nothing left in the buffer passes
for the next tick's answer.

Faults: a missing reply marks that joint not fresh; ``stale_limit`` in a row → ERROR. Malformed
replies, frames for other ids and error frames are counted and ignored. A bus error → ERROR,
the bus is closed and reopened every ``reconnect_interval`` for ``reconnect_timeout`` s. When
our commands paused longer than ``drive_timeout`` (a lost link, a frozen loop), the drives'
own watchdogs have turned their motors off: the device reports DEACTIVATE (its own stop) until
it is activated again.
"""
from __future__ import annotations

import time

import can
import numpy as np

from drivers.can_bus import BusBudget, read_bus_options
from drivers.can_device import CanJointGroup
from drivers.protocols import mit
from drivers.protocols.mit import REPLY_EFFORT, REPLY_ERROR, REPLY_POSITION, REPLY_VELOCITY, Special
from drivers.protocols.mit_layout import read_master_id, read_mit_joints, reply_keys
from rtctl.busload import DEFAULT_LIMIT, PROTOCOLS
from rtctl.errors import HardwareError
from rtctl.hal import Lifecycle, Status


EXIT_ATTEMPTS = 3  # a lost (or corrupted) answer to exit motor mode must not leave a motor on


def _hex(drive_ids) -> str:
    return ", ".join(f"{i:#x}" for i in drive_ids)


class MitCanJointGroup(CanJointGroup):
    """The MIT drives of one CAN bus."""

    def __init__(self, name: str, joints, bus, *, master_id: int = mit.DEFAULT_MASTER_ID, period: float = 0.001,
                 reply_deadline: float = 0.6, stale_limit: int = 3, drive_timeout: float = 0.02,
                 exchange_timeout: float = 0.5, reconnect_timeout: float = 2.0, reconnect_interval: float = 0.05,
                 set_zero: bool = False):
        super().__init__(name, [j.name for j in joints], bus, drive_timeout=drive_timeout,
                         reconnect_timeout=reconnect_timeout, reconnect_interval=reconnect_interval)
        n = len(joints)
        self.counters["extra_replies"] = 0  # replies taken after every drive had answered
        self.joints, self.master_id = tuple(joints), master_id
        self.reply_timeout = reply_deadline * period
        self.stale_limit = stale_limit
        self.exchange_timeout, self.set_zero_at_configure = exchange_timeout, set_zero
        self._models = [j.model for j in joints]
        self._row_of_key = [-1] * 256  # reply byte 0 → row
        for row, j in enumerate(joints):
            for key in reply_keys(j):
                self._row_of_key[key] = row
        self._commands = [can.Message(arbitration_id=j.drive_id, data=bytearray(8), is_extended_id=False)
                          for j in joints]
        self._specials = {kind: [can.Message(arbitration_id=j.drive_id, data=bytearray(mit.special_frame(kind)),
                                             is_extended_id=False) for j in joints] for kind in Special}
        self._dir = np.array([j.direction for j in joints])
        self._offset = np.array([j.offset for j in joints])
        self._effort_scale = self._dir * np.array([j.model.torque_constant for j in joints])
        # the centre of each reply's quantisation interval, not its floor (mit.reply_half_steps)
        self._half_p, self._half_v, self._half_e = np.array([mit.reply_half_steps(j.model) for j in joints]).T.copy()
        self._replies = np.zeros((n, mit.REPLY_COLUMNS))
        self._reply_position, self._reply_velocity, self._reply_effort, self._reply_error = (
            self._replies[:, c] for c in (REPLY_POSITION, REPLY_VELOCITY, REPLY_EFFORT, REPLY_ERROR))
        self._got = np.zeros(n, dtype=bool)  # a reply since the last read
        self._cycle = np.zeros(n, dtype=bool)  # the answer to the last frame sent, in the current collection
        # every frame goes to every drive, and a drive answers in order: a drive owes the frames
        # sent minus its replies (``_replied``), and its answer to a frame just sent is the last
        # reply it owes — not a late one to an earlier command
        self._acknowledged(n)
        self._cycle_t: float | None = None  # loop time of the commands whose answers read() collects next
        self._replies_by = 0.0  # time.monotonic() by which they are due
        self._sent = 0
        self._replied = [0] * n
        # replies a drive sent on this link, plus those lost for sure (≤ _sent): unlike _replied,
        # never credited with what the tick gave up on while it may still come (see _exchange)
        self._heard = [0] * n
        self._sent_at = self._gave_up_at = -float("inf")  # time.monotonic() of the last send, the last give-up
        self._tmp = np.zeros(n)
        self._p, self._v, self._tau, self._zero = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)

    # -- configuration -------------------------------------------------------------------
    @classmethod
    def from_config(cls, device, context) -> "MitCanJointGroup":
        """Validate the options and the bus-load budget; opens nothing."""
        t = device.options
        names = [context.model.joint_names[j] for j in device.joints]
        joints = read_mit_joints(t, names)
        bus = read_bus_options(t)
        kw = cls._read_timing(t, context.period)
        budget = cls._check_budget(t, device.name, bus, joints, context)
        t.done()
        dev = cls(device.name, joints, bus, master_id=read_master_id(t), period=context.period, **kw)
        dev.budget = budget
        return dev

    @staticmethod
    def _read_timing(t, period) -> dict:
        return dict(
            reply_deadline=t.float("reply_deadline", 0.6, positive=True, max=0.95),
            stale_limit=t.int("stale_limit", 3, min=1, max=10_000),
            drive_timeout=t.float("drive_timeout", 0.02, positive=True, max=10.0),
            exchange_timeout=t.float("exchange_timeout", 0.5, positive=True, max=60.0),
            reconnect_timeout=t.float("reconnect_timeout", 2.0, min=0.0, max=60.0),
            reconnect_interval=t.float("reconnect_interval", 0.05, positive=True, max=10.0),
            set_zero=t.bool("set_zero", False),
        )

    @staticmethod
    def _check_budget(t, name, bus, joints, context) -> BusBudget | None:
        """Add this device's joints to the run's budget (BusLoadError above the limit); the
        budget if this device is the run's first CAN device (it prints the table), else None."""
        wide = any(j.model.reply_length == 8 for j in joints)
        protocol = t.str("protocol", "mit8" if wide else "mit", choices=tuple(p for p in PROTOCOLS if p.startswith("mit")))
        if wide and protocol == "mit":
            raise t.error("protocol", "\"mit8\": these drives reply with 8 bytes")
        limit = t.float("bus_load_limit", DEFAULT_LIMIT, positive=True, max=1.0)
        budget, first = BusBudget.of(context.shared)
        budget.add(t, name, bus, protocol, len(joints), 1.0 / context.period, limit)
        budget.claim_ids(t, name, bus, {j.drive_id: j.name for j in joints}, read_master_id(t),
                         {key: j.name for j in joints for key in reply_keys(j)})
        return budget if first else None

    # -- lifecycle -----------------------------------------------------------------------
    def _on_configure(self) -> None:
        self._open()
        try:
            self._exchange(Special.EXIT_MOTOR_MODE, "exit motor mode")
            if self.set_zero_at_configure:
                self._exchange(Special.SET_ZERO, "set zero")
        except Exception:
            self._close_bus()
            raise

    def _on_activate(self) -> None:
        self._stale[:] = 0
        self._drives_off, self._lost_at = None, None
        if self.bus is None:
            self._open()
        try:
            self._exchange(Special.ENTER_MOTOR_MODE, "enter motor mode")
        except Exception:
            self._send_special(Special.EXIT_MOTOR_MODE)  # leave none of them enabled
            raise
        self._last_sent = self._clock()

    def _on_deactivate(self) -> None:
        if self.bus is None:
            self._open()  # one attempt: the drives must hear exit motor mode if the link allows
        self._exchange(Special.EXIT_MOTOR_MODE, "exit motor mode", EXIT_ATTEMPTS)

    def _on_close(self) -> None:
        self._close_bus()

    def _open(self) -> None:
        super()._open()
        self._forget_owed()  # a new link: nothing sent on the old one will be answered on it
        self._heard = [self._sent] * len(self._heard)

    def set_zero(self) -> None:
        """Make every drive's present position its zero (FE). Refused while active: the
        set-point would jump under a live motor."""
        if self.lifecycle is not Lifecycle.INACTIVE:
            raise HardwareError(f"{self.name}: set_zero needs the device configured and not active "
                                f"(it is {self.lifecycle.value})")
        self._exchange(Special.SET_ZERO, "set zero")

    # -- per tick ------------------------------------------------------------------------
    def _read(self, t: float) -> Status:
        self._t_loop = t
        if self._cycle_t is not None:  # the answers to the last tick's commands
            cycle_t, self._cycle_t = self._cycle_t, None
            if self.bus is not None:
                try:
                    self._answered(cycle_t, self._collect(max(0.0, self._replies_by - time.monotonic())), self._cycle)
                except Exception as e:
                    self._lost(e)
        got, s, tmp, stale = self._got, self.state, self._tmp, self._stale
        np.add(self._reply_position, self._half_p, out=tmp)
        tmp *= self._dir
        tmp += self._offset
        np.copyto(s.position, tmp, where=got)
        np.add(self._reply_velocity, self._half_v, out=tmp)
        tmp *= self._dir
        np.copyto(s.velocity, tmp, where=got)
        np.add(self._reply_effort, self._half_e, out=tmp)
        tmp *= self._effort_scale
        np.copyto(s.effort, tmp, where=got)
        np.copyto(s.fault, self._reply_error, where=got, casting="unsafe")
        np.copyto(s.fresh, self._cycle)  # a late reply's values are newer than ours but a period old
        stale += 1
        np.copyto(stale, self._zeros_i, where=self._cycle)
        s.stamp = self._stamp
        got.fill(False)
        self._cycle.fill(False)
        if self.bus is None:
            return Status.ERROR
        if self._drives_off is not None:
            return Status.DEACTIVATE
        if stale.max() >= self.stale_limit:
            if self._last_event != "stale":  # build the message once per episode, not every tick
                self._report("stale", f"no reply from drive(s) {self._stale_ids()} for {self.stale_limit} ticks",
                             missing_since=float(np.nanmin(self._missing_since)))
            return Status.ERROR
        if s.fault.any():
            if self._last_event != "drive_error":
                self._report("drive_error", f"drive error codes {dict(zip(self.joint_names, s.fault.tolist()))}")
            return Status.ERROR
        self._last_event = None  # healthy again: the next fault state is a new episode
        return Status.OK

    def _write(self, t: float) -> Status:
        if not self._start_write(t, "watchdog: their motors are off"):
            return Status.ERROR
        c, p, v, tau = self.command, self._p, self._v, self._tau
        if c.mode:  # impedance: the drive closes kp (p − q) + kd (v − q̇) + t
            np.subtract(c.q_des, self._offset, out=p)
            p *= self._dir
            np.multiply(c.qd_des, self._dir, out=v)
            kp, kd = c.kp, c.kd
        else:  # torque: zero gains, the torque as feed-forward
            p.fill(0.0)
            v.fill(0.0)
            kp = kd = self._zero
        np.multiply(c.tau_ff, self._dir, out=tau)
        models, messages = self._models, self._commands
        for i in range(len(messages)):
            mit.pack_command_into(messages[i].data, models[i], p[i], v[i], kp[i], kd[i], tau[i])
        try:
            bus = self.bus
            late = min(self._replied) < self._sent  # answers missing at the last read: late or lost
            # what came since the last collection (a late answer, a copy) answers nothing sent now
            if self._may_hold_frames():
                self._drain(self._take_late if late else self._take_extra)
            if late:
                self._forget_owed()  # the rest are as good as lost
            for m in messages:
                bus.send(m)
            self._sent += 1
            self._last_sent = self._clock()
            self._sent_at = time.monotonic()
            self._replies_by = self._sent_at + self.reply_timeout
            self._after_send()
        except Exception as e:
            return self._lost(e)
        self.counters["cycles"] += 1
        self._cycle_t = t  # its answers are collected by the next read
        return Status.DEACTIVATE if self._drives_off is not None else Status.OK

    # -- frames --------------------------------------------------------------------------
    def _collect(self, timeout: float) -> int:
        """Receive until every drive answered the last frames sent or ``timeout`` s passed;
        returns how many did not. Once all have, what else already arrived is taken too: a
        reply no drive owed (a frame received twice, another node's) left in the buffer would
        be the next collection's answer and leave the real one behind — a period older from then
        on, marked fresh, as a late reply would."""
        self._cycle.fill(False)
        missing = self._receive(len(self._cycle), timeout, self._take_answer, self._acks_per_send)
        if not missing:
            self._drain(self._take_extra)
        return missing

    def _take_answer(self, msg) -> int:
        """1 when ``msg`` is the last reply a drive owed (its answer to the frame just sent), else 0."""
        row = self._take(msg)
        if row >= 0 and self._replied[row] == self._sent and not self._cycle[row]:
            self._cycle[row] = True
            return 1
        return 0

    def _take_late(self, msg) -> int:
        """Decode a reply that missed its collection (its values are the newest); it answers nothing."""
        if self._take(msg) >= 0:
            self.counters["late_replies"] += 1
        return 0

    def _take_extra(self, msg) -> int:
        """Decode a reply after every drive answered (its values are the newest); it answers nothing."""
        if self._take(msg) >= 0:
            self.counters["extra_replies"] += 1
        return 0

    def _forget_owed(self) -> None:
        """Give up on the replies owed (for the tick's collection; ``_heard`` still awaits them)."""
        replied = self._replied
        for row in range(len(replied)):
            replied[row] = self._sent
        self._gave_up_at = time.monotonic()

    def _take(self, msg) -> int:
        """Decode one received frame into the reply table; its row, or −1 when ignored."""
        data = msg.data
        if msg.is_error_frame:
            self.counters["error_frames"] += 1
            return -1
        if msg.arbitration_id != self.master_id or msg.is_extended_id or msg.is_remote_frame or not data:
            self.counters["foreign_frames"] += 1  # other ids (e.g. another master's commands on a shared bus)
            return -1
        row = self._row_of_key[data[0]]
        if row < 0 or len(data) != self._models[row].reply_length:
            self.counters["malformed_replies"] += 1
            return -1
        mit.unpack_reply_into(data, self._models[row], self._replies, row)
        self._got[row] = True
        if self._replied[row] < self._sent:  # (a reply owed nothing credits no later frame)
            self._replied[row] += 1
        if self._heard[row] < self._sent:
            self._heard[row] += 1
        return row

    def _send_special(self, kind: Special) -> None:
        try:
            self._send_to_all(self._specials[kind])
        except Exception as e:
            self.last_error = f"{kind.name.lower()}: {type(e).__name__}: {e}"

    def _send_to_all(self, messages) -> None:
        for m in messages:
            self.bus.send(m)
        self._sent += 1
        self._sent_at = time.monotonic()
        self._after_send()

    def _exchange(self, kind: Special, what: str, attempts: int = 1) -> None:
        """Send ``kind`` to every drive — again, up to ``attempts`` frames, while one has not
        answered — and require every answer (HardwareError naming the others). Replies carry no
        sequence number: a drive has answered once it sent more replies than it could still owe
        for the frames before the first — every reply not heard, also those the tick gave up on,
        until ``exchange_timeout`` (the bound on a reply's lateness) passed since they were sent;
        then the missing ones are lost (docs/can_joints.md). A Damiao reply saying the motor is
        on answers no exit."""
        if self.bus is None:
            raise HardwareError(f"{self.name}: {what}: the bus is not open")
        heard, answered, motor_on = self._heard, self._cycle, set()
        if time.monotonic() - self._gave_up_at > self.exchange_timeout:  # given up on long enough ago: lost
            self._heard = heard = [max(h, r) for h, r in zip(heard, self._replied)]
        before, sent_before_at, exiting = self._sent, self._sent_at, kind is Special.EXIT_MOTOR_MODE

        def take(msg) -> int:
            row = self._take(msg)
            if row < 0 or answered[row] or heard[row] <= before:
                return 0
            if exiting and mit.reply_says_motor_on(msg.data, self._models[row]):
                motor_on.add(self.joints[row].drive_id)
                return 0
            answered[row] = True
            return 1

        answered.fill(False)
        self._cycle_t = None  # the answers awaited now are this frame's, not a tick's
        try:
            for attempt in range(attempts):
                if attempt and time.monotonic() - sent_before_at >= self.exchange_timeout:
                    for row in range(len(heard)):  # the earlier frames' replies not heard by now are lost
                        heard[row] = max(heard[row], before)
                self._send_to_all(self._specials[kind])
                if not self._receive(len(answered) - int(answered.sum()), self.exchange_timeout, take):
                    break
        except Exception as e:
            self._close_bus()
            raise HardwareError(f"{self.name}: {what}: bus error: {type(e).__name__}: {e}") from e
        self._stamp = self._clock()
        missing = [j.drive_id for j, ok in zip(self.joints, answered) if not ok]
        if missing:
            self._forget_owed()  # lost, or later than any answer awaited: the next exchange starts afresh
            silent = [i for i in missing if i not in motor_on]
            why = [f"drive(s) {_hex(silent)} did not answer {what} within {self.exchange_timeout:g} s ({attempts} "
                   f"frame(s)) on {self.bus_options.label} (power, ids, bitrate, termination?)"] if silent else []
            why += [f"drive(s) {_hex(sorted(motor_on))} answered {what} with the motor on"] if motor_on else []
            raise HardwareError(f"{self.name}: " + "; ".join(why))

    # -- bookkeeping ---------------------------------------------------------------------
    def _stale_ids(self) -> str:
        return _hex(j.drive_id for j, k in zip(self.joints, self._stale) if k >= self.stale_limit)

    def diagnostics(self) -> dict:
        d = super().diagnostics()
        d["stale_ticks"] = dict(zip(self.joint_names, self._stale.tolist()))
        return d
