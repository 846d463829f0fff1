"""The plant behind ``hil-sim``'s transports: drives on several buses, one plant, and the
events the HIL tests read.

Lock-step (``realtime_factor = 0``) follows the protocol: the plant advances one period when
every drive of every bus has been sent a command since the last advance — one command set of
the loop — plus the whole periods a paced loop skipped before that set (time that passed for
the robot, with the torques held); the drives' watchdogs run on the wall clock (a frozen loop
turns the motors off after their timeout). Free-running (``realtime_factor = F > 0``)
advances the plant with the wall clock × F, commands or not, from the first command set on
(until then the robot rests on its brakes).

Events are JSON-able dicts passed to ``emit``: every motor on/off of a drive with its cause
(``command``, ``watchdog``, ``error``) and, for an off, the time since the drive's last
command; every scripted fault as it is applied. Scripted faults (:class:`ScriptedFault`) fire
after a given number of command sets, so a lock-step scenario is the same on every run.
"""
from __future__ import annotations

import threading
import time
from dataclasses import asdict, dataclass
from typing import Callable

from hil_sim.cia402_drive import Cia402DriveBus
from hil_sim.drive_bus import DriveBus
from hil_sim.mit_drive import MitDrive, MitDriveBus

MAX_REPLAY_S = 0.1  # longest pause of the loop replayed for the plant (a stopped process: time jumps)


@dataclass
class ScriptedFault:
    """``kind``: silent | corrupt | error | drop; ``drive``: (bus name or None, id) or None."""

    kind: str
    at_cycle: int = 0
    drive: tuple | None = None
    value: float = 0.0
    done: bool = False

    @classmethod
    def parse(cls, spec: str) -> "ScriptedFault":
        """``silent:ID``, ``corrupt:ID:RATE``, ``error:ID:CODE``, ``drop``; ID is ``N`` (any bus)
        or ``BUS/N``; ``@CYCLES`` appended: after that many command sets (default 0: at once)."""
        body, _, at = spec.partition("@")
        kind, *args = body.split(":")
        try:
            at_cycle = int(at) if at else 0
            if kind == "drop" and not args:
                return cls(kind, at_cycle)
            if kind in ("silent", "corrupt", "error") and len(args) == (1 if kind == "silent" else 2):
                bus, _, ident = args[0].rpartition("/")
                value = float(args[1]) if len(args) > 1 else 0.0
                return cls(kind, at_cycle, (bus or None, int(ident, 0)), value)
        except ValueError:
            pass
        raise ValueError(f"bad fault {spec!r}: expected silent:ID, corrupt:ID:RATE, error:ID:CODE or drop, "
                         f"ID as N or BUS/N, optionally @CYCLES")


class PlantHub:
    """The plant shared by every drive bus of one hil-sim process."""

    def __init__(self, plant, period: float, realtime_factor: float = 0.0, emit: Callable[[dict], None] = print,
                 clock: Callable[[], float] = time.monotonic):
        self.plant, self.period, self.factor = plant, period, realtime_factor
        self.emit, self.clock = emit, clock
        self.lock = threading.RLock()  # slcan serves each bus from its own thread
        self.buses: list[HubBus] = []
        self.drives: list[tuple[str, MitDrive]] = []
        self.commands: list[int] = []  # command sets each drive received
        self._pending = 0  # drives not yet commanded in this cycle
        self._enabled: list[bool] = []
        self._trips: list[int] = []
        self.faults: list[ScriptedFault] = []
        self.drop_connections: Callable[[], None] | None = None  # set by the socketcand server
        self.cycles = 0
        self.t0 = clock()
        self._sim_start: float | None = None  # free-running: wall time of plant time 0
        self._first_set: float | None = None  # lock-step: arrival of the first command set
        self._periods = 0  # lock-step: periods the plant advanced

    def add_bus(self, bus: "HubBus") -> None:
        self.buses.append(bus)
        for d in bus.drives.values():
            self.drives.append((bus.name, d))
            self.commands.append(0)
            self._pending = len(self.commands)
            self._enabled.append(d.enabled)
            self._trips.append(d.counters.watchdog_trips)
        if self.factor > 0 and len(self.buses) == 1:
            self._pace(bus)

    def _pace(self, bus: DriveBus) -> None:
        """Free-running: service the buses every period even when no frame comes."""
        def tick():
            bus.call_at(self.clock() + self.period / self.factor, tick)

        bus.call_at(self.clock(), tick)

    # -- called by the buses ------------------------------------------------------------------
    def commanded(self, index: int, now: float) -> None:
        """Drive ``index`` was sent a command (and has answered it). The last of a command set
        completes a cycle: lock-step advances the plant now, before the next set can arrive
        (even when the transport delivers two sets in one read). Counted per drive: when this
        process reads one bus's next set before another bus's current one (a stall, two
        connections), that set counts for the next cycle instead of vanishing into this one."""
        self.commands[index] += 1
        if self.commands[index] == self.cycles + 1:  # its command of the cycle in progress
            self._pending -= 1
        while self._pending == 0:
            if self.factor == 0:
                for _ in range(self._periods_due(now)):
                    self.plant.step(self.period)
            self.cycles += 1
            self._pending = sum(1 for n in self.commands if n <= self.cycles)
            self._scripted()

    def _periods_due(self, now: float) -> int:
        """One period per command set, plus the periods the loop skipped: a paced loop that
        overran sends its next set whole periods later, and that time passed for the robot too
        (replayed with the torques held, at most MAX_REPLAY_S)."""
        if self._first_set is None:
            self._first_set, self._periods = now, 0
        due = int((now - self._first_set) / self.period) - self._periods
        due = min(max(1, due), max(1, round(MAX_REPLAY_S / self.period)))
        if self._periods + due < int((now - self._first_set) / self.period) - round(MAX_REPLAY_S / self.period):
            self._first_set = now - (self._periods + due) * self.period  # a long stop: do not replay it all
        self._periods += due
        return due

    def advance(self, now: float) -> None:
        """DriveBus.service's plant hook: watchdogs and laws now; free-running: the plant up to now."""
        with self.lock:
            for _, d in self.drives:
                d.update(now)
            if self.factor > 0:
                self._free_run(now)
            self.check(now)

    def _free_run(self, now: float) -> None:
        if self.cycles == 0:
            return  # the brakes hold the robot until the loop first commands every drive
        if self._sim_start is None:
            self._sim_start = now - self.plant.time / self.factor
        target = (now - self._sim_start) * self.factor
        if target - self.plant.time > 0.1 * self.factor:  # the process was stopped: do not replay the gap
            self.plant.time = target - self.period
        while self.plant.time + self.period <= target:
            for _, d in self.drives:
                d.update(now)
            self.plant.step(self.period)

    def check(self, now: float) -> None:
        """Emit an event for every drive whose motor switched on or off."""
        for k, (bus, d) in enumerate(self.drives):
            if d.enabled != self._enabled[k]:
                self._enabled[k] = d.enabled
                trips, self._trips[k] = self._trips[k], d.counters.watchdog_trips
                cause = "watchdog" if d.counters.watchdog_trips > trips else ("error" if d.error_code else "command")
                event = {"event": "motor_on" if d.enabled else "motor_off", "bus": bus, "drive": d.drive_id,
                         "cause": cause, "t": now - self.t0, "cycle": self.cycles}
                if not d.enabled:
                    event["since_command_ms"] = 1e3 * (now - d.last_command_time)
                self.emit(event)

    def _scripted(self) -> None:
        for f in self.faults:
            if f.done or f.at_cycle > self.cycles:
                continue
            f.done = True
            if f.kind == "drop":
                if self.drop_connections is None:
                    raise ValueError("the drop fault needs the socketcand transport")
                self.drop_connections()
            for bus, d in self.drives:
                if f.drive is None or d.drive_id != f.drive[1] or f.drive[0] not in (None, bus):
                    continue
                if f.kind == "silent":
                    d.faults.silent = True
                elif f.kind == "corrupt":
                    d.faults.corrupt_rate = f.value
                elif f.kind == "error":
                    d.set_error(int(f.value))
            self.emit({"event": "fault", "kind": f.kind, "drive": f.drive and f.drive[1], "value": f.value,
                       "cycle": self.cycles, "t": self.clock() - self.t0})

    def summary(self) -> dict:
        return {"event": "exit", "cycles": self.cycles, "plant_time": self.plant.time,
                "drives": [{"bus": bus, "drive": d.drive_id, "enabled": d.enabled, "error": d.error_code,
                            "counters": asdict(d.counters)} for bus, d in self.drives]}


class HubBus:
    """Mixed into a drive bus whose plant is the hub's: it tells the hub which drives a frame
    commanded (the bus's ``commanded_by``)."""

    def _join(self, hub: PlantHub) -> None:
        self.hub = hub
        hub.add_bus(self)
        self._index = {d.drive_id: k for k, (bus, d) in enumerate(hub.drives) if bus == self.name}

    def receive(self, arbitration_id: int, data, now: float, out: list, is_extended: bool = False) -> None:
        with self.hub.lock:
            super().receive(arbitration_id, data, now, out, is_extended)
            for drive_id in self.commanded_by(arbitration_id, data, is_extended):
                self.hub.commanded(self._index[drive_id], now)
            self.hub.check(now)

    def service(self, now: float, out: list) -> None:
        with self.hub.lock:
            super().service(now, out)


class HubDriveBus(HubBus, MitDriveBus):
    """MIT drives on the hub's plant."""

    def __init__(self, drives, name: str, hub: PlantHub):
        MitDriveBus.__init__(self, drives, name=name, advance=hub.advance)
        self._join(hub)


class HubCia402Bus(HubBus, Cia402DriveBus):
    """CiA 402 drives on the hub's plant (a SYNC commands them all)."""

    def __init__(self, drives, name: str, hub: PlantHub):
        Cia402DriveBus.__init__(self, drives, name=name, advance=hub.advance)
        self._join(hub)
