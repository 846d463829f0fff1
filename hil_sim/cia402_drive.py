"""Emulated CiA 402 servo drive in cyclic synchronous torque: the far side of the wire for the
``cia402`` driver.

A :class:`Cia402Drive` is a python-canopen ``LocalNode`` built from the same EDS the driver
configures: its SDO server, NMT slave, heartbeat producer and EMCY producer are the library's.
What ``LocalNode`` does not do is here: the CiA 402 state machine (the shared
:func:`drivers.protocols.cia402.device_transition`), the RPDO applied and the TPDOs sent on
SYNC (codec from the EDS's PDO set), the torque on a :class:`~hil_sim.mit_drive.JointPort` it
is given — it owns no physics —, the RPDO deadline (0x1400 sub 5) as its command watchdog
(EMCY 0x8250 and FAULT, torque off), the abort-connection reaction (leaving NMT OPERATIONAL
while enabled disables it) and fault-injection knobs (:class:`Cia402Faults`; a fault code is
:meth:`Cia402Drive.set_error`).

A :class:`Cia402DriveBus` is the drives of one bus as frames in and frames out
(:class:`hil_sim.drive_bus.DriveBus`): the same transports serve it as the MIT drives — the
python-can pump (``virtual`` in-process, socketcan) and the socketcand server.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from typing import Callable

import canopen

from drivers.protocols import cia402 as c
from drivers.protocols.cia402 import EDS, PdoLayout
from hil_sim.drive_bus import DriveBus

I32 = (-(2**31), 2**31 - 1)


class FrameNetwork(canopen.Network):
    """A canopen Network without a bus (python-canopen's hook for a custom backend): what the
    node sends is collected in ``outbox``; a periodic frame (the heartbeat) is a
    :class:`_Periodic` the drive bus sends when due, on its clock."""

    def __init__(self):
        super().__init__(None)
        self.outbox: list = []
        self.periodic: list[_Periodic] = []
        self.now = 0.0

    def send_message(self, can_id: int, data, remote: bool = False) -> None:
        self.outbox.append((can_id, bytes(data)))

    def send_periodic(self, can_id: int, data, period: float, remote: bool = False) -> "_Periodic":
        task = _Periodic(self, can_id, bytes(data), period)
        self.periodic.append(task)
        return task


class _Periodic:
    """python-canopen's PeriodicMessageTask interface (``stop``, ``update``) on the bus clock."""

    def __init__(self, network: FrameNetwork, can_id: int, data: bytes, period: float):
        self.network, self.can_id, self.data, self.period = network, can_id, data, period
        self.due = network.now + period

    def stop(self) -> None:
        if self in self.network.periodic:
            self.network.periodic.remove(self)

    def update(self, data) -> None:
        self.data = bytes(data)


@dataclass
class Cia402Faults:
    """Fault-injection knobs; change them at any time (the server threads read them live)."""

    silent: bool = False  # a dead drive: hears nothing, says nothing (no PDO, SDO, heartbeat, EMCY)
    corrupt_rate: float = 0.0  # probability that a TPDO goes out one byte short
    heartbeat: bool = True  # False: the heartbeat stops, the PDOs go on
    delay_s: float = 0.0  # (the drive bus's knob; CiA 402 drives answer on SYNC at once)
    seed: int = 0
    rng: random.Random = field(init=False, repr=False)

    def __post_init__(self):
        self.rng = random.Random(self.seed)


@dataclass
class Cia402Counters:
    syncs: int = 0
    commands: int = 0  # RPDOs applied
    tpdos: int = 0
    sdo_requests: int = 0
    malformed: int = 0  # RPDOs of the wrong length, unparsable NMT: ignored
    corrupted: int = 0
    emcys: int = 0
    watchdog_trips: int = 0


class Cia402Drive:
    """One drive. The bus hands it the frames on its ids, SYNC and NMT (:meth:`receive`) and
    calls :meth:`update` at the drive's control rate; what it sends is in ``network.outbox``."""

    def __init__(self, node_id: int, port, *, rated_torque: float = 1.0, counts_per_rev: int = 1 << 20,
                 eds=EDS, faults: Cia402Faults | None = None):
        self.drive_id = node_id
        self.node = canopen.LocalNode(node_id, canopen.import_od(str(eds), node_id))
        self.network = FrameNetwork()
        self.network[node_id] = self.node
        self.layout = PdoLayout.from_od(self.node.object_dictionary)
        self.port, self.faults = port, faults or Cia402Faults()
        self.counters = Cia402Counters()
        self.rated_torque = round(rated_torque * 1000) / 1000
        self.counts_per_rad = counts_per_rev / (2 * math.pi)
        self.state = c.NOT_READY
        self.controlword = 0
        self.error_code = 0
        self.mode = 0
        self.torque_permille = 0
        self.torque = 0.0  # N·m applied
        self.timeout_s = math.inf  # the RPDO deadline (0x1400 sub 5; 0 = none)
        self.last_command_time = -math.inf
        self.transitions: list[int] = []  # CiA 402 transition numbers taken (for the tests)
        self._command = [0, 0]  # controlword, target torque ‰ (COMMAND_FIELDS order): applied at SYNC
        self._state_values = [0, 0, 0, 0]  # statusword, position, velocity, torque (STATE_FIELDS order)
        self._rpdo_of = {p.cob_id(node_id): p for p in self.layout.rpdos}
        self._tpdos = [(p, p.cob_id(node_id), bytearray(p.length)) for p in self.layout.tpdos]
        sdo = self.node.sdo
        sdo[c.RATED_TORQUE].raw = round(rated_torque * 1000)
        sdo[c.ENCODER_RESOLUTION][1].raw, sdo[c.ENCODER_RESOLUTION][2].raw = counts_per_rev, 1
        self._max_permille = sdo[c.MAX_TORQUE].raw
        self.node.add_write_callback(self._on_write)
        self.node.add_read_callback(self._on_read)
        self.node.nmt.send_command(0x81)  # power on: boot-up message (NMT state 0) …
        self.node.nmt.send_command(0x80)  # … then PRE-OPERATIONAL, where the heartbeat starts
        self._automatic()  # NOT READY TO SWITCH ON → SWITCH ON DISABLED (transition 1)

    @property
    def enabled(self) -> bool:
        return self.state == c.OPERATION_ENABLED

    @property
    def nmt_state(self) -> str:
        return self.node.nmt.state

    # -- frames ---------------------------------------------------------------------------
    def receive(self, can_id: int, data, now: float) -> None:
        """One frame for this drive (its RPDO or SDO request, SYNC or NMT)."""
        if self.faults.silent:
            return
        self.network.now = now
        if can_id == c.SYNC:
            self._on_sync(now)
            return
        pdo = self._rpdo_of.get(can_id)
        if pdo is not None:
            self._on_rpdo(pdo, data, now)
            return
        was_operational = self.nmt_state == "OPERATIONAL"
        if can_id == c.SDO_RX_BASE + self.drive_id:
            self.counters.sdo_requests += 1
        try:
            self.network.notify(can_id, data, now)  # SDO server, NMT slave (python-canopen's)
        except Exception:  # e.g. an NMT frame too short to unpack
            self.counters.malformed += 1
        if was_operational and self.nmt_state != "OPERATIONAL" and self.state in (c.OPERATION_ENABLED, c.QUICK_STOP):
            self._transition(c.SWITCH_ON_DISABLED, 9 if self.enabled else 12)  # abort connection: disable voltage

    def _on_rpdo(self, pdo, data, now: float) -> None:
        if self.nmt_state != "OPERATIONAL":
            return
        if len(data) != pdo.length:
            self.counters.malformed += 1
            return
        pdo.unpack_into(data, self._command)
        self.counters.commands += 1
        self.last_command_time = now

    def _on_sync(self, now: float) -> None:
        self.counters.syncs += 1
        if self.nmt_state != "OPERATIONAL":
            return
        self.update(now)
        self.apply_controlword(self._command[0])
        self.torque_permille = self._command[1] if self.enabled else 0
        self._apply_torque()
        self._send_tpdos()

    def apply_controlword(self, controlword: int) -> None:
        state, number = c.device_transition(self.state, controlword, self.controlword)
        self.controlword = controlword
        if number is not None:
            self._transition(state, number)

    def _transition(self, state: str, number: int) -> None:
        if number == 15:
            self.error_code = 0
            self.node.emcy.reset()  # EMCY 0x0000: error reset
            self.counters.emcys += 1
        self.state = state
        self.transitions.append(number)
        if state != c.OPERATION_ENABLED:
            self.torque_permille = 0
            self._apply_torque()

    def _apply_torque(self) -> None:
        cap = self._max_permille
        permille = max(-cap, min(cap, self.torque_permille)) if self.enabled else 0
        self.torque = permille * self.rated_torque / 1000
        self.port.set_torque(self.torque)

    def _send_tpdos(self) -> None:
        v = self._state_values
        v[0] = c.statusword_of(self.state)
        v[1] = _i32(self.port.get_position() * self.counts_per_rad)
        v[2] = _i32(self.port.get_velocity() * self.counts_per_rad)
        v[3] = max(-self._max_permille, min(self._max_permille, self.torque_permille)) if self.enabled else 0
        f = self.faults
        for pdo, cob, buf in self._tpdos:
            pdo.pack_into(buf, v)
            n = pdo.length
            if f.corrupt_rate and f.rng.random() < f.corrupt_rate:
                self.counters.corrupted += 1
                n -= 1
            self.network.send_message(cob, buf[:n])
            self.counters.tpdos += 1

    # -- the drive's own time -----------------------------------------------------------------
    def update(self, now: float) -> None:
        """The RPDO deadline and the automatic transitions (call at the control rate)."""
        if self.enabled and now - self.last_command_time > self.timeout_s:
            self.counters.watchdog_trips += 1
            self.set_error(c.EMCY_RPDO_TIMEOUT)
        self._automatic()

    def _automatic(self) -> None:
        nxt = c.AUTOMATIC.get(self.state)
        if nxt is not None:
            self._transition(*nxt)

    def set_error(self, code: int) -> None:
        """A fault with EMCY ``code``: FAULT REACTION ACTIVE (transition 13, torque off), then
        FAULT; cleared only by a fault reset."""
        if not code or self.state in (c.FAULT, c.FAULT_REACTION):
            return
        self.error_code = code
        self._transition(c.FAULT_REACTION, 13)
        self.node.emcy.send(code, 0x01)  # error register: generic error
        self.counters.emcys += 1

    # -- the object dictionary ---------------------------------------------------------------------
    def _on_write(self, index: int, subindex: int, od, data: bytes) -> None:
        value = od.decode_raw(data)
        if index == c.MODES_OF_OPERATION:
            self.mode = value
        elif index == c.RPDO_COMM and subindex == c.EVENT_TIMER:
            self.timeout_s = value / 1000 if value else math.inf
        elif index == c.MAX_TORQUE:
            self._max_permille = value
        elif index == c.CONTROLWORD:
            self.apply_controlword(value)

    def _on_read(self, index: int, subindex: int, od):
        live = {c.STATUSWORD: lambda: c.statusword_of(self.state), c.ERROR_CODE: lambda: self.error_code,
                c.MODES_DISPLAY: lambda: self.mode, c.ERROR_REGISTER: lambda: int(self.error_code != 0),
                c.TORQUE: lambda: self.torque_permille,
                c.POSITION: lambda: _i32(self.port.get_position() * self.counts_per_rad),
                c.VELOCITY: lambda: _i32(self.port.get_velocity() * self.counts_per_rad)}.get(index)
        return None if live is None else live()


def _i32(x: float) -> int:
    return int(min(I32[1], max(I32[0], round(x))))


class Cia402DriveBus(DriveBus):
    """The CiA 402 drives on one CAN bus. SYNC and NMT go to every drive, an RPDO or SDO request
    to its drive; what the drives send leaves at once, the heartbeats when due. A SYNC completes
    a command cycle (every drive applied its RPDO): for a lock-step plant, it commands the
    drives when one of them was operation enabled before it and still is — a torque cycle, not
    a step of the state machine on the way up or down (a disabled robot rests on its brakes)."""

    def __init__(self, drives, name: str = "can0", advance: Callable[[float], None] | None = None,
                 max_staleness: float = 0.001):
        super().__init__(drives, name, advance, max_staleness)
        self._torque_cycle = False  # the last SYNC found a drive enabled, and left it so
        self._route = {}
        for d in drives:
            for cob in (*d._rpdo_of, c.SDO_RX_BASE + d.drive_id):
                self._route[cob] = d

    def receive(self, arbitration_id: int, data, now: float, out: list, is_extended: bool = False) -> None:
        if is_extended:
            self.ignored += 1
            return
        if arbitration_id == c.SYNC:
            was = [d.enabled for d in self.drives.values()]
            for d in self.drives.values():
                d.receive(arbitration_id, data, now)
            self._torque_cycle = any(w and d.enabled for w, d in zip(was, self.drives.values()))
            self._addressed(now, len(self.drives))
        elif arbitration_id == c.NMT:
            for d in self.drives.values():
                d.receive(arbitration_id, data, now)
        else:
            d = self._route.get(arbitration_id)
            if d is None:
                self.ignored += 1  # another node's frames, our own TPDOs echoed by a shared bus
                return
            d.receive(arbitration_id, data, now)
        self._flush(now, out)

    def commanded_by(self, arbitration_id: int, data, is_extended: bool = False) -> tuple:
        if is_extended or arbitration_id != c.SYNC or not self._torque_cycle:
            return ()
        return tuple(self.drives)

    def service(self, now: float, out: list) -> None:
        for d in self.drives.values():
            d.network.now = now
        super().service(now, out)
        for d in self.drives.values():
            for task in d.network.periodic:
                if task.due <= now:
                    task.due = max(task.due + task.period, now)  # a stalled process does not send a burst
                    if d.faults.heartbeat:
                        d.network.outbox.append((task.can_id, task.data))
        self._flush(now, out)

    def next_deadline(self) -> float | None:
        first = super().next_deadline()
        for d in self.drives.values():
            for task in d.network.periodic:
                if first is None or task.due < first:
                    first = task.due
        return first

    def _flush(self, now: float, out: list) -> None:
        for d in self.drives.values():
            box = d.network.outbox
            if box:
                if not d.faults.silent:
                    for arbitration_id, payload in box:
                        self._reply(d, arbitration_id, payload, now, out)
                box.clear()


def stand_in_cia402_bus(ids, name: str = "can0", rated_torque: float = 10.0, counts_per_rev: int = 1 << 20):
    """Drives ``ids`` on InertiaJoints, free-running against the clock (tests, benches)."""
    from hil_sim.mit_drive import InertiaJoint, free_running

    drives = [Cia402Drive(i, InertiaJoint(), rated_torque=rated_torque, counts_per_rev=counts_per_rev) for i in ids]
    return Cia402DriveBus(drives, name=name, advance=free_running(drives))
