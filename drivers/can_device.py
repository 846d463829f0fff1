"""What every CAN joint driver shares (``mit_can``, ``cia402``): the link to one bus — opened,
lost, reopened — its bus-load budget, and the rare events and counters of the run summary.

A bus error → the device reports ERROR, the bus is closed and reopened every
``reconnect_interval`` for ``reconnect_timeout`` s (then it stays ERROR). Events (bus lost /
back, drives off, a fault state) are logged once per episode and kept (the last 100) for the
summary.
"""
from __future__ import annotations

import socket
import time

import can
import numpy as np
import structlog

from drivers.can_bus import BusBudget, BusOptions, read_bus_options
from rtctl.errors import HardwareError
from rtctl.hal import JointGroup, Status

log = structlog.get_logger("rtctl.can")


class CanJointGroup(JointGroup):
    """Joint drives on one CAN bus. Subclasses add their protocol and their counters."""

    # the ``bus`` options reader, for code that reaches a driver class through the registry
    read_bus_options = staticmethod(read_bus_options)

    def __init__(self, name: str, joint_names, bus: BusOptions, *, drive_timeout: float = 0.02,
                 reconnect_timeout: float = 2.0, reconnect_interval: float = 0.05):
        super().__init__(name, joint_names)
        self.bus_options = bus
        self.drive_timeout = drive_timeout  # the drives' own watchdog on our commands
        self.reconnect_timeout, self.reconnect_interval = reconnect_timeout, reconnect_interval
        self.bus = None
        self.budget: BusBudget | None = None  # set by from_config on the run's first CAN device
        n = len(joint_names)
        self._t_loop = 0.0  # loop time of the last read/write (for events)
        self._stamp = 0.0  # loop time of the last command set answered (the state's stamp)
        self._stale = np.zeros(n, dtype=np.int64)  # ticks in a row without a joint's answer
        self._zeros_i = np.zeros(n, dtype=np.int64)
        self._missing_since = np.full(n, np.nan)  # loop time of the first unanswered command in a row
        self._nans = np.full(n, np.nan)
        self._last_sent = -float("inf")  # clock time of the last command set sent
        self._drives_off: str | None = None  # why the drives must be assumed off (their watchdog)
        self._acks_per_send = 0  # see _acknowledged
        self._empty_read_s = 0.0
        self._lost_at: float | None = None  # monotonic time the bus was lost
        self._next_attempt = 0.0
        self.counters = {"cycles": 0, "missing_replies": 0, "late_replies": 0, "malformed_replies": 0,
                         "foreign_frames": 0, "error_frames": 0, "bus_errors": 0, "reconnects": 0}
        self.events: list[dict] = []  # rare: bus lost / back, drives assumed off, fault states
        self._last_event: str | None = None  # so a fault state is reported once, not every tick

    def bus_budget(self, rate_hz: float) -> list[str]:
        """The CAN bus-load table for ``rtctl check`` (printed once, by the run's first CAN device)."""
        return [] if self.budget is None else self.budget.lines(rate_hz)

    # -- per tick ------------------------------------------------------------------------
    def _start_write(self, t: float, watchdog: str) -> bool:
        """The start of every ``write``: False when the bus is down (and not reopened now). When
        our commands paused longer than the drives' watchdog (a lost link, a frozen loop), they
        have stopped themselves: remembered (``_drives_off``), reported once."""
        self._t_loop = t
        if self.bus is None and not self._reconnect():
            return False
        now = self._clock()
        if now - self._last_sent > self.drive_timeout and self._drives_off is None:
            self._drives_off = (f"no command for {1e3 * (now - self._last_sent):.0f} ms, longer than the drives' "
                                f"{1e3 * self.drive_timeout:g} ms {watchdog}")
            self._report("drives_off", self._drives_off)  # the cause of the DEACTIVATE that follows
        return True

    def _answered(self, t: float, missing: int, answered) -> None:
        """The replies to the commands of loop time ``t``: counters, since when each joint has
        been unanswered (``answered``: a mask), the state's stamp."""
        if missing:
            self.counters["missing_replies"] += missing
            np.copyto(self._missing_since, t, where=~answered & np.isnan(self._missing_since))  # (rare path)
        np.copyto(self._missing_since, self._nans, where=answered)
        self._stamp = t

    def _acknowledged(self, frames_per_send: int) -> None:
        """slcan acknowledges every frame sent with a line that python-can's ``recv()`` returns
        as None once its timeout has passed, like an empty port: past its deadline a collection
        reads that many more before it takes the port for empty. Subclasses say how many frames
        a tick sends; other interfaces have no acknowledgements."""
        kw = self.bus_options.kwargs
        self._acks_per_send = frames_per_send if kw["interface"] == "slcan" else 0
        # an empty port blocks a read for the serial timeout (python-can's default 1 ms); an
        # acknowledgement already there returns at once
        self._empty_read_s = 0.5 * float(kw.get("timeout", 0.001))

    def _may_hold_frames(self) -> bool:
        """Whether a read could find a frame now. Elsewhere an empty read returns at once: always
        look. Over slcan it waits out the serial timeout, so the port's count of bytes waiting
        (one ioctl) decides; a bus without that count (only in tests) is always read."""
        if not self._acks_per_send:
            return True
        port = getattr(self.bus, "serialPortOrig", None)
        return port is None or port.in_waiting > 0

    def _drain(self, take_late) -> None:
        """Take every frame already received, without waiting: until a read finds the port
        empty — over slcan, a None that took the serial timeout, not an acknowledgement."""
        bus, acks = self.bus, self._acks_per_send
        while True:
            t0 = time.monotonic() if acks else 0.0  # (timed only where acknowledgements come)
            msg = bus.recv(0.0)
            if msg is not None:
                take_late(msg)
            elif acks and time.monotonic() - t0 < self._empty_read_s:
                acks -= 1
            else:
                return

    def _receive(self, pending: int, timeout: float, take, acks: int = 0) -> int:
        """Receive until ``take(msg)`` — how many of the awaited frames ``msg`` was — has counted
        ``pending`` down to 0, or ``timeout`` s passed (blocking in ``recv``, not spinning) and
        ``recv`` found nothing ``acks`` + 1 times (``acks``: slcan's acknowledgements, which read as
        nothing); returns how many are still missing."""
        bus = self.bus
        end = time.monotonic() + timeout
        while pending:
            remaining = end - time.monotonic()
            msg = bus.recv(remaining if remaining > 0.0 else 0.0)
            if msg is None:
                if remaining <= 0.0:
                    if not acks:
                        break
                    acks -= 1
                continue  # (before the deadline: slcan's acknowledgement, or a spurious wake-up)
            pending -= take(msg)
        return pending

    # -- the link ------------------------------------------------------------------------
    def _open(self) -> None:
        kw = self.bus_options.kwargs
        try:
            if kw["interface"] == "socketcand":
                # python-can retries a refused connection for 10 s in a busy loop: look first
                socket.create_connection((kw["host"], kw["port"]), timeout=0.2).close()
            self.bus = can.Bus(**kw)
        except Exception as e:
            self.bus = None
            raise HardwareError(f"{self.name}: cannot open CAN bus {self.bus_options.label} "
                                f"({kw['interface']}): {type(e).__name__}: {e}") from e

    def _close_bus(self) -> None:
        bus, self.bus = self.bus, None
        if bus is not None:
            try:
                bus.shutdown()
            except Exception:
                pass

    def _lost(self, e: Exception) -> Status:
        self.counters["bus_errors"] += 1
        self.last_error = f"bus {self.bus_options.label}: {type(e).__name__}: {e}"
        self._close_bus()
        self._lost_at = time.monotonic()
        self._next_attempt = self._lost_at + self.reconnect_interval
        self._event("bus_lost", self.last_error)
        return Status.ERROR

    def _reconnect(self) -> bool:
        now = time.monotonic()
        if self._lost_at is None or now - self._lost_at > self.reconnect_timeout or now < self._next_attempt:
            return False
        self._next_attempt = now + self.reconnect_interval
        try:
            self._open()
        except HardwareError as e:
            self.last_error = str(e)
            return False
        self.counters["reconnects"] += 1
        self._event("bus_back", f"reopened after {now - self._lost_at:.3f} s")
        return True

    # -- hooks and bookkeeping -------------------------------------------------------------
    def _after_send(self) -> None:
        """Called right after frames were sent (an in-process simulator answers here)."""

    def _clock(self) -> float:
        """The clock the drives' watchdogs run on."""
        return time.monotonic()

    def _event(self, kind: str, reason: str, **fields) -> None:
        event = {"event": kind, "reason": reason, "t": self._t_loop, "clock": self._clock(), **fields}
        self._last_event = kind
        if len(self.events) < 100:
            self.events.append(event)
        log.warning(kind, device=self.name, **{k: v for k, v in event.items() if k != "event"})

    def _report(self, kind: str, reason: str, **fields) -> None:
        """A fault state's first tick: remember it as the last error and log it."""
        self.last_error = reason
        self._event(kind, reason, **fields)

    def stale_cause(self) -> str | None:
        silent = [name for name, ticks in zip(self.joint_names, self._stale) if ticks]
        if not silent:
            return None
        return (f"no answer from the drive(s) of {', '.join(silent)} on {self.bus_options.label} for "
                f"{int(self._stale.max())} tick(s)")

    def diagnostics(self) -> dict:
        d = super().diagnostics()
        d.update(bus=self.bus_options.label, counters=dict(self.counters), events=self.events[-20:])
        return d
