"""The leg board's firmware behind a pseudo-terminal, for ``hil-sim --transport serial``.

What a USB-serial leg board looks like to ``drivers.leg_board`` (pyserial opens the pty's
path): it decodes command frames (drivers/protocols/leg_board.py), applies the actions to
the leg plant and answers each command with a sensor frame. Lock-step (``realtime_factor``
0): the plant advances one period per command frame. Free-running (F > 0): it advances with
the wall clock × F and a sensor frame goes out every period, commands or not.

The board's own watchdog: no valid command for ``watchdog_s`` → both joints locked (status
bit WATCHDOG) until commands come again. Scripted faults (after N commands): ``silent`` —
the board stops answering; ``drop`` — the pty is closed (the host sees the line go away).
One thread blocks in ``select()``; nothing polls.
"""
from __future__ import annotations

import time

from drivers.protocols import leg_board as proto
from hil_sim.leg_plant import LegPlant
from hil_sim.pty import Pty
from hil_sim.select_server import SelectServer

_MAX_QUEUED = 65536


class LegBoardServer(SelectServer):
    def __init__(self, plant: LegPlant, period: float, realtime_factor: float = 0.0, watchdog_s: float = 0.05,
                 emit=print, clock=time.monotonic):
        super().__init__(clock)
        self.plant, self.period, self.factor = plant, period, realtime_factor
        self.watchdog_s, self.emit = watchdog_s, emit
        self.pty = Pty()
        self.path = self.pty.path
        self.decoder = proto.Decoder(proto.COMMAND)
        self._seq = 0
        self.locked = False  # by the watchdog
        self.silent = False
        self.faults: list = []  # ScriptedFault (silent / drop) by command count
        self.last_command = None
        self.commands = 0
        self.counters = {"commands": 0, "replies": 0, "watchdog_trips": 0, "overflows": 0}
        self._next_free = None

    # -- serving ----------------------------------------------------------------------------
    def close(self) -> None:
        self.pty.close()
        super().close()

    def _files(self) -> tuple[list, list]:
        return self.pty.files()

    def _ready(self, readable: list, now: float) -> None:
        if self.pty.fd in readable and (data := self.pty.read()):
            self._commands(self.decoder.feed(data), now)

    def _service(self, now: float) -> None:
        self._watchdog(now)
        if self.factor > 0:
            self._free_run(now)
        self.pty.flush()

    def _next_deadline(self) -> float | None:
        t = [] if self.last_command is None or self.locked else [self.last_command + self.watchdog_s]
        if self.factor > 0 and self._next_free is not None:
            t.append(self._next_free)
        return min(t) if t else None

    def _commands(self, count: int, now: float) -> None:
        for _ in range(count):
            self.commands += 1
            self.counters["commands"] += 1
            self.last_command = now
            if self.locked:
                self.locked = False
                self.emit({"event": "watchdog_release", "commands": self.commands})
            self.plant.actions[:] = proto.unpack_actions(self.decoder.actions)
            self._scripted()
            if self._stop:
                return
            if self.factor == 0:
                self.plant.step(self.period)
                self._reply()
            elif self._next_free is None:
                self._next_free = now

    def _free_run(self, now: float) -> None:
        while self._next_free is not None and now >= self._next_free:
            self.plant.step(self.period)
            self._reply()
            self._next_free += self.period / self.factor
            if now - self._next_free > 0.1:  # the process was stopped: do not replay the gap
                self._next_free = now

    def _watchdog(self, now: float) -> None:
        if self.last_command is not None and not self.locked and now - self.last_command > self.watchdog_s:
            self.locked = True
            self.counters["watchdog_trips"] += 1
            self.plant.actions[:] = proto.HOLD
            self.emit({"event": "watchdog_lock", "since_command_ms": 1e3 * (now - self.last_command),
                       "commands": self.commands})

    def _reply(self) -> None:
        if self.silent:
            return
        status = (int(self.plant.actions[0]) << 2 | int(self.plant.actions[1])) | (proto.WATCHDOG if self.locked else 0)
        if len(self.pty.out) > _MAX_QUEUED:
            self.counters["overflows"] += 1
            return
        self.pty.out += proto.encode_sensor(self._seq, status, self.plant.channels)
        self._seq = (self._seq + 1) & 0xFF
        self.counters["replies"] += 1

    def _scripted(self) -> None:
        for f in self.faults:
            if f.done or f.at_cycle > self.commands:
                continue
            f.done = True
            self.emit({"event": "fault", "kind": f.kind, "commands": self.commands})
            if f.kind == "silent":
                self.silent = True
            elif f.kind == "drop":
                self._stop = True

    def summary(self) -> dict:
        return {"event": "exit", "commands": self.commands, "plant_time": self.plant.time, "locked": self.locked,
                "counters": dict(self.counters), "decoder": dict(self.decoder.counters)}
