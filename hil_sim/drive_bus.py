"""The emulated drives of one CAN bus as frames in and frames out: the base of
:class:`hil_sim.mit_drive.MitDriveBus` and :class:`hil_sim.cia402_drive.Cia402DriveBus`, the
interface every transport (python-can pump, socketcand server, slcan pty) drives.

``advance(now)`` (optional) brings the plant up to ``now``; :meth:`service` calls it. A server
answers each frame at once and calls ``service`` when :meth:`wants_service` says so: once every
drive had its command since the last service (a full command cycle: the plant then advances
between cycles, not in the middle of one, which keeps the replies prompt), at a watchdog or
delayed-reply deadline, or ``max_staleness`` after an incomplete cycle.
"""
from __future__ import annotations

import heapq
import math
from typing import Callable


class DriveBus:
    """Drives keyed by ``drive_id``; each has ``enabled``, ``last_command_time``, ``timeout_s``
    (its command watchdog), ``faults.delay_s`` and ``update(now)``."""

    def __init__(self, drives, name: str = "can0", advance: Callable[[float], None] | None = None,
                 max_staleness: float = 0.001):
        self.drives = {d.drive_id: d for d in drives}
        if len(self.drives) != len(drives):
            raise ValueError("two drives share an id")
        self.name, self.advance = name, advance
        self.max_staleness = max_staleness
        self.unserviced = 0  # drives addressed since the last service
        self._first_unserviced = 0.0
        self.ignored = 0  # frames for nobody on this bus (other ids, extended ids)
        self._delayed: list = []  # heap of (due, seq, arbitration_id, payload)
        self._actions: list = []  # heap of (when, seq, action): scheduled fault injections
        self._seq = 0

    def receive(self, arbitration_id: int, data, now: float, out: list, is_extended: bool = False) -> None:
        """Handle one frame from the wire; append the (arbitration_id, payload) replies due now."""
        raise NotImplementedError

    def commanded_by(self, arbitration_id: int, data, is_extended: bool = False) -> tuple:
        """The ids of the drives this frame (just received) gave their command of a cycle: what a
        lock-step plant counts (:class:`hil_sim.lockstep.PlantHub`)."""
        raise NotImplementedError

    def _addressed(self, now: float, count: int = 1) -> None:
        if self.unserviced == 0:
            self._first_unserviced = now
        self.unserviced += count

    def _reply(self, drive, arbitration_id: int, payload, now: float, out: list) -> None:
        """Send ``payload`` now, or ``drive.faults.delay_s`` later."""
        if drive.faults.delay_s > 0:
            self._seq += 1
            heapq.heappush(self._delayed, (now + drive.faults.delay_s, self._seq, arbitration_id, payload))
        else:
            out.append((arbitration_id, payload))

    def call_at(self, when: float, action: Callable[[], None]) -> None:
        """Run ``action()`` at time ``when`` (on the clock the bus is given), from
        :meth:`service`: e.g. ``bus.call_at(t0 + 2, lambda: setattr(drive.faults, "silent", True))``
        or a server's ``drop_connections`` — faults scripted for HIL scenarios."""
        self._seq += 1
        heapq.heappush(self._actions, (when, self._seq, action))

    def service(self, now: float, out: list) -> None:
        """Advance the plant, run the watchdogs and due actions, append the delayed replies now due."""
        self.unserviced = 0
        while self._actions and self._actions[0][0] <= now:
            heapq.heappop(self._actions)[2]()
        if self.advance is not None:
            self.advance(now)
        else:
            for d in self.drives.values():
                d.update(now)
        while self._delayed and self._delayed[0][0] <= now:
            _, _, arbitration_id, payload = heapq.heappop(self._delayed)
            out.append((arbitration_id, payload))

    def next_deadline(self) -> float | None:
        """When :meth:`service` must run next at the latest (a delayed reply, a scheduled
        action, a watchdog, an incomplete cycle)."""
        first = self._delayed[0][0] if self._delayed else math.inf
        if self._actions:
            first = min(first, self._actions[0][0])
        if self.unserviced:
            first = min(first, self._first_unserviced + self.max_staleness)
        for d in self.drives.values():
            if d.enabled and d.last_command_time + d.timeout_s < first:
                first = d.last_command_time + d.timeout_s
        return None if first == math.inf else first

    def wants_service(self, now: float) -> bool:
        if self.unserviced >= len(self.drives):
            return True
        deadline = self.next_deadline()
        return deadline is not None and deadline <= now
