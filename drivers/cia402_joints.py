"""CiA 402 servo drives in cyclic synchronous torque as one JointGroup per CAN bus (driver
``cia402``).

Options (the ``[[devices]]`` table; drive layout in :mod:`drivers.protocols.cia402_layout`, bus
in :mod:`drivers.can_bus`)::

    bus_load_limit = 0.8      # refuse the configuration above it (exit 2)
    reply_deadline = 0.6      # fraction of the period after the SYNC until which read() waits for its TPDOs
    stale_limit = 3           # ticks in a row without a joint's TPDOs → Status.ERROR
    drive_timeout = 0.02      # s: the drives' RPDO deadline (0x1400 sub 5, whole ms); a longer gap → DEACTIVATE
    heartbeat_period = 0.1    # s: the drives' heartbeat (0x1017, whole ms)
    heartbeat_timeout = 0.3   # s without a drive's heartbeat → its joint is stale (default 3 periods)
    exchange_timeout = 0.5    # s for SDO answers and for the state machine to reach its state
    reconnect_timeout = 2.0   # s of reopening after a bus error; then the device stays ERROR
    reconnect_interval = 0.05 # s between attempts

Lifecycle: ``configure`` opens the bus, configures every drive through python-canopen (NMT,
SDO: :mod:`drivers.cia402_bringup`), starts the nodes and runs one SYNC cycle with the
controlword *disable voltage* — its TPDOs are the state ``read`` publishes, and nothing is
enabled. ``activate`` walks every drive's state machine to OPERATION ENABLED (a fault is reset
on the way), one SYNC cycle per step. ``deactivate`` sends *disable voltage* until every drive
reports SWITCH ON DISABLED (or FAULT), reopening the bus once if it was lost. ``close`` puts the
nodes back in PRE-OPERATIONAL (no PDOs) and closes the bus. One device per bus: it is the bus's
SYNC producer.

Per tick, ``write()``: frames that arrived since the last collection are taken first (EMCY,
heartbeats, a late TPDO); then each drive's RPDO (controlword *enable operation*, target torque
in ‰ of its rated torque; *disable voltage* and no torque to a drive that fell out of OPERATION
ENABLED) and one SYNC — and ``write()`` returns. The drives apply the torque at the SYNC and
report their state measured there; ``read()`` of the next tick collects those TPDOs and
publishes them (one period old, as with any SYNC-cyclic drive). In a paced loop they arrived
while the loop slept, so neither call waits; ``read()`` waits (blocking in ``recv``) only until
``reply_deadline × period`` after the SYNC, which matters in lock-step (``realtime_factor =
0``), where the next tick follows at once. Two buses' round trips thus overlap the loop's
sleep instead of adding up in ``write()``. Impedance commands are closed here, at the loop
rate, on the state the tick read: a CST drive takes torque only.

Hot path: the RPDO and SYNC messages and all arrays are preallocated; the codec packs into the
messages' own ``data``. python-can still allocates a Message per received frame.

Faults: a joint whose TPDOs did not all arrive is not fresh; ``stale_limit`` in a row → ERROR.
An EMCY → ERROR with the drive's error code in ``state.fault`` and a ``drive_fault`` event (an
EMCY 0x0000, error reset, clears it). A drive not OPERATION ENABLED while active → ERROR. No
heartbeat for ``heartbeat_timeout``, or a heartbeat from a node not OPERATIONAL → its joint is
stale, ERROR. Malformed frames, frames for other ids and error frames are counted and ignored.
A bus error → ERROR and reopening (:class:`~drivers.can_device.CanJointGroup`). When our
commands paused longer than ``drive_timeout`` (a lost link, a frozen loop), the drives' RPDO
deadline has faulted them: the device reports DEACTIVATE (their own stop) until activated again.
"""
from __future__ import annotations

import math
import time

import canopen
import numpy as np

from drivers.can_bus import BusBudget, read_bus_options
from drivers.can_device import CanJointGroup
from drivers.cia402_bringup import MasterNetwork, configure_drive, sdo_session
from drivers.cia402_frames import Cia402Frames
from drivers.protocols import cia402 as c
from drivers.protocols.cia402_layout import read_cia402_joints, read_eds
from rtctl.busload import DEFAULT_LIMIT, ProtocolFrames
from rtctl.errors import HardwareError
from rtctl.hal import CommandMode, Lifecycle, Status

SW, POS, VEL, TRQ = range(4)  # columns of the TPDO values (STATE_FIELDS order)
STATE_MACHINE_CYCLES = 16  # SYNC cycles allowed to reach a state (FAULT → OPERATION ENABLED takes 5): docs/cia402.md
DISABLED = (c.SWITCH_ON_DISABLED, c.FAULT, c.NOT_READY)  # power stage off


class Cia402JointGroup(Cia402Frames, CanJointGroup):
    """The CiA 402 drives of one CAN bus."""

    def __init__(self, name: str, joints, bus, *, eds=c.EDS, layout=None, period: float = 0.001,
                 reply_deadline: float = 0.6, stale_limit: int = 3, drive_timeout: float = 0.02,
                 heartbeat_period: float = 0.1, heartbeat_timeout: float | None = None,
                 exchange_timeout: float = 0.5, reconnect_timeout: float = 2.0, reconnect_interval: float = 0.05,
                 max_torque=None):
        super().__init__(name, [j.name for j in joints], bus, drive_timeout=drive_timeout,
                         reconnect_timeout=reconnect_timeout, reconnect_interval=reconnect_interval)
        n = len(joints)
        self.joints, self.eds = tuple(joints), eds
        self.layout = layout or c.PdoLayout.from_eds(eds)
        self.reply_timeout = reply_deadline * period
        self.stale_limit, self.exchange_timeout = stale_limit, exchange_timeout
        self.heartbeat_period = heartbeat_period
        self.heartbeat_timeout = 3 * heartbeat_period if heartbeat_timeout is None else heartbeat_timeout
        self.max_torque = np.full(n, math.inf) if max_torque is None else np.asarray(max_torque, dtype=float)
        self.network: MasterNetwork | None = None
        self.counters.update(emcy=0, heartbeats=0)
        self._init_frames(self.joints, self.layout)
        self._dir = np.array([j.direction for j in joints])
        self._offset = np.array([j.offset for j in joints])
        self._rad = self._dir / np.array([j.counts_per_rad for j in joints])  # rad (rad/s) per increment
        self._nm = self._dir * np.array([j.rated_torque for j in joints]) / 1000  # N·m per ‰
        self._tmp, self._tau = np.zeros(n), np.zeros(n)
        self._hb_late = np.zeros(n, dtype=bool)
        self._cycle_t: float | None = None  # loop time of the SYNC whose TPDOs read() collects next

    # -- configuration -------------------------------------------------------------------
    @classmethod
    def from_config(cls, device, context) -> "Cia402JointGroup":
        """Validate the options and the bus-load budget; opens nothing."""
        t = device.options
        names = [context.model.joint_names[j] for j in device.joints]
        eds, layout = read_eds(t)
        joints = read_cia402_joints(t, names)
        bus = read_bus_options(t)
        kw = dict(
            reply_deadline=t.float("reply_deadline", 0.6, positive=True, max=0.95),
            stale_limit=t.int("stale_limit", 3, min=1),
            drive_timeout=t.float("drive_timeout", 0.02, min=0.001, max=65.535),
            heartbeat_period=t.float("heartbeat_period", 0.1, min=0.001, max=65.535),
            exchange_timeout=t.float("exchange_timeout", 0.5, positive=True),
            reconnect_timeout=t.float("reconnect_timeout", 2.0, min=0.0),
            reconnect_interval=t.float("reconnect_interval", 0.05, positive=True),
        )
        kw["heartbeat_timeout"] = t.float("heartbeat_timeout", 3 * kw["heartbeat_period"], min=kw["heartbeat_period"])
        budget = cls._check_budget(t, device.name, bus, len(joints), layout, context)
        t.done()
        dev = cls(device.name, joints, bus, eds=eds, layout=layout, period=context.period,
                  max_torque=context.model.tau_max[list(device.joints)], **kw)
        dev.budget = budget
        return dev

    @staticmethod
    def _check_budget(t, name, bus, n, layout, context) -> BusBudget | None:
        limit = t.float("bus_load_limit", DEFAULT_LIMIT, positive=True, max=1.0)
        budget, first = BusBudget.of(context.shared)
        other = budget.buses.get(bus.identity)
        if other is not None and other.protocol == "cia402":
            raise t.error("bus", f"a bus of its own: {', '.join(other.devices)} already sends the SYNC on "
                                 f"{bus.label} (one SYNC producer per bus: put these joints in that device)")
        frames = ProtocolFrames(per_joint=layout.frame_lengths, per_bus=(0,))  # the PDOs, one SYNC
        budget.add(t, name, bus, "cia402", n, 1.0 / context.period, limit, frames)
        return budget if first else None

    # -- lifecycle -----------------------------------------------------------------------
    def _on_configure(self) -> None:
        self._open()
        try:
            self._bring_up()
            self._cycle_until(lambda row, sw: c.CW_DISABLE_VOLTAGE, lambda sw: True, "report its state")
        except Exception:
            self._close_bus()
            raise

    def _bring_up(self) -> None:
        network = self.network = MasterNetwork(self.bus, self._after_send)
        nodes = []
        for j in self.joints:
            node = canopen.RemoteNode(j.node_id, canopen.import_od(str(self.eds), j.node_id))
            node.sdo.RESPONSE_TIMEOUT = self.exchange_timeout
            network.add_node(node)
            nodes.append(node)
        with sdo_session(network):
            for node, j, tau_max in zip(nodes, self.joints, self.max_torque):
                configure_drive(node, j, heartbeat_ms=round(1000 * self.heartbeat_period),
                                deadline_ms=round(1000 * self.drive_timeout), max_torque=tau_max,
                                label=self.bus_options.label)
        self._nmt("OPERATIONAL")

    def _nmt(self, state: str) -> None:
        for node in self.network.values():
            node.nmt.state = state

    def _on_activate(self) -> None:
        self._stale[:] = 0
        self._drives_off, self._lost_at = None, None
        if self.bus is None:
            self._open()
        try:
            self._nmt("OPERATIONAL")  # (again: a drive may have rebooted, or a reset follows a stop)
            self._heartbeat_at.fill(self._clock())
            self._nmt_state.fill(c.NMT_OPERATIONAL)  # (what we just commanded; their heartbeats confirm it)
            self._nmt_bad, self._emcy_active = False, False
            self._emcy.fill(0)
            self._cycle_until(self._towards_operation, c.is_operation_enabled, "reach OPERATION ENABLED")
        except Exception:
            self._disable_all()  # leave none of them enabled
            raise

    def _towards_operation(self, row: int, statusword: int) -> int:
        return c.controlword_towards_operation(c.state_of(statusword), self._command[row][0])

    def _on_deactivate(self) -> None:
        if self.bus is None:
            self._open()  # one attempt: the drives must hear disable voltage if the link allows
        self._disable_all(raise_errors=True)

    def _disable_all(self, raise_errors: bool = False) -> None:
        """*Disable voltage* until every drive confirms, within half their RPDO deadline: the
        next device on the loop must not starve past its drives' deadlines while this one
        waits. A drive that does not confirm (silent, or its answer lost) is an error, also
        when it was silent before: its own deadline turns it off once our RPDOs stop, but
        nothing here has seen it off."""
        silent = self._stale > 0
        try:
            self._cycle_until(lambda row, sw: c.CW_DISABLE_VOLTAGE, lambda sw: c.state_of(sw) in DISABLED,
                              "disable (SWITCH ON DISABLED)", budget=self.drive_timeout / 2)
        except Exception as e:
            self.last_error = f"disable: {e}" + (f"; node(s) {self._ids(silent)} silent before: their RPDO "
                                                  f"deadline ({1e3 * self.drive_timeout:g} ms) turns them off"
                                                  if silent.any() else "")
            if raise_errors:
                raise HardwareError(f"{self.name}: {self.last_error}") from e

    def _on_close(self) -> None:
        if self.bus is not None and self.network is not None:
            try:
                self._nmt("PRE-OPERATIONAL")  # PDOs off: the bus goes quiet
            except Exception:
                pass
        self._close_bus()

    def _open(self) -> None:
        super()._open()
        if self.network is not None:
            self.network.bus = self.bus

    # -- per tick ------------------------------------------------------------------------
    def _read(self, t: float) -> Status:
        self._t_loop = t
        if self._cycle_t is not None:  # the TPDOs of the last tick's SYNC
            cycle_t, self._cycle_t = self._cycle_t, None
            if self.bus is not None:
                try:
                    self._answered(cycle_t, self._collect(), self._fresh)
                except Exception as e:
                    self._lost(e)
        s, v, tmp, fresh, stale = self.state, self._values, self._tmp, self._fresh, self._stale
        active = self.lifecycle is Lifecycle.ACTIVE
        silent = active and self._heartbeats_missing()
        if silent:
            np.logical_and(fresh, ~self._hb_late, out=fresh)  # (rare path)
        np.multiply(v[:, POS], self._rad, out=tmp)
        tmp += self._offset
        np.copyto(s.position, tmp, where=fresh)
        np.multiply(v[:, VEL], self._rad, out=tmp)
        np.copyto(s.velocity, tmp, where=fresh)
        np.multiply(v[:, TRQ], self._nm, out=tmp)
        np.copyto(s.effort, tmp, where=fresh)
        np.copyto(s.fault, self._emcy)
        np.copyto(s.fresh, fresh)
        stale += 1
        np.copyto(stale, self._zeros_i, where=fresh)
        s.stamp = self._stamp
        if self.bus is None:
            return Status.ERROR
        if self._drives_off is not None:
            return Status.DEACTIVATE
        return self._health(active, silent)

    def _heartbeats_missing(self) -> bool:
        """The heartbeat consumer: True (and ``_hb_late`` set) when a node's heartbeat is overdue
        or says it is not OPERATIONAL (a restart, an NMT change)."""
        if self._clock() - self._heartbeat_at.min() <= self.heartbeat_timeout and not self._nmt_bad:
            return False
        late = self._clock() - self._heartbeat_at > self.heartbeat_timeout
        np.logical_or(late, self._nmt_state != c.NMT_OPERATIONAL, out=self._hb_late)
        return True

    def _health(self, active: bool, silent: bool) -> Status:
        """The device's status from the drives' reports (a fault state logged once per episode)."""
        if silent:
            if self._last_event != "heartbeat":
                self._report("heartbeat", f"no heartbeat from node(s) {self._ids(self._hb_late)} within "
                                          f"{self.heartbeat_timeout:g} s, or not OPERATIONAL (NMT states "
                                          f"{self._nmt_state.tolist()})")
            return Status.ERROR
        if self._stale.max() >= self.stale_limit:
            if self._last_event != "stale":
                self._report("stale", f"no TPDOs from node(s) {self._ids(self._stale >= self.stale_limit)} for "
                                      f"{self.stale_limit} ticks", missing_since=float(np.nanmin(self._missing_since)))
            return Status.ERROR
        if self._emcy_active:
            if self._last_event != "drive_fault":
                row = int(np.flatnonzero(self._emcy)[0])
                code = int(self._emcy[row])
                self._report("drive_fault", f"node {self.joints[row].node_id:#x} ({self.joint_names[row]}): EMCY "
                                            f"{code:#06x} ({c.emcy_description(code)})",
                             drive=self.joints[row].node_id, code=code,
                             codes=dict(zip(self.joint_names, self._emcy.tolist())))
            return Status.ERROR
        if active and self._not_enabled:
            if self._last_event != "not_enabled":
                states = {j.name: c.state_of(int(w)) for j, w in zip(self.joints, self._statusword)}
                self._report("not_enabled", f"drive(s) left OPERATION ENABLED: {states}")
            return Status.ERROR
        self._last_event = None  # healthy again: the next fault state is a new episode
        return Status.OK

    def _write(self, t: float) -> Status:
        if not self._start_write(t, "RPDO deadline: they have faulted, torque off"):
            return Status.ERROR
        c_, tau, s = self.command, self._tau, self.state
        if c_.mode == CommandMode.IMPEDANCE:  # τ = kp (q_des − q) + kd (qd_des − q̇) + τ_ff, closed here
            np.subtract(c_.q_des, s.position, out=tau)
            tau *= c_.kp
            np.subtract(c_.qd_des, s.velocity, out=self._tmp)
            self._tmp *= c_.kd
            tau += self._tmp
            tau += c_.tau_ff
        else:
            np.copyto(tau, c_.tau_ff)
        tau /= self._nm  # → ‰ of the rated torque, in the drive's direction
        np.rint(tau, out=tau)
        np.clip(tau, -32768, 32767, out=tau)
        self._pack(tau)
        try:
            self._send_sync(self.reply_timeout)
        except Exception as e:
            return self._lost(e)
        self.counters["cycles"] += 1
        self._cycle_t = t  # its TPDOs are collected by the next read
        return Status.DEACTIVATE if self._drives_off is not None else Status.OK

    def _cycle_until(self, controlword, done, what: str, budget: float | None = None) -> None:
        """SYNC cycles with ``controlword(row, statusword)`` and zero torque until ``done(statusword)``
        for every drive, within ``budget`` s (default ``exchange_timeout``); HardwareError naming
        the others."""
        if self.bus is None:
            raise HardwareError(f"{self.name}: {what}: the bus is not open")
        budget = self.exchange_timeout if budget is None else budget
        self._cycle_t = None  # a tick's SYNC still uncollected is superseded by these
        end = time.monotonic() + budget
        for cycle in range(1, STATE_MACHINE_CYCLES + 1):
            self._pack_each(controlword)
            try:
                self._cycle(max(0.0, end - time.monotonic()))
            except Exception as e:
                self._close_bus()
                raise HardwareError(f"{self.name}: {what}: bus error: {type(e).__name__}: {e}") from e
            self._stamp = self._clock()
            ok = [f and done(int(w)) for f, w in zip(self._fresh, self._statusword)]
            if all(ok):
                return
            if time.monotonic() > end:
                break
        late = [f"{j.node_id:#x} ({c.state_of(int(w)) if f else 'no TPDO'})"
                for j, w, f, good in zip(self.joints, self._statusword, self._fresh, ok) if not good]
        limit = f"{budget:g} s" if time.monotonic() > end else f"{cycle} SYNC cycles"
        raise HardwareError(f"{self.name}: drive(s) {', '.join(late)} did not {what} within "
                            f"{limit} on {self.bus_options.label} (power, ids, bitrate, termination?)")

    def _ids(self, mask) -> str:
        return ", ".join(f"{j.node_id:#x}" for j, m in zip(self.joints, mask) if m)

    def diagnostics(self) -> dict:
        d = super().diagnostics()
        d["stale_ticks"] = dict(zip(self.joint_names, self._stale.tolist()))
        d["states"] = {j.name: c.state_of(int(w)) for j, w in zip(self.joints, self._statusword)}
        return d
