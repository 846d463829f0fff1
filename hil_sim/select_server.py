"""One thread that blocks in ``select()`` and nothing else: the serving loop of the simulator's
devices (socketcand server, slcan adapter, serial leg board).

:class:`SelectServer` wakes for a readable file, a writable file the server waits on, its next
deadline, or :meth:`~SelectServer.shutdown` from another thread or a signal handler (a socket
pair wakes ``select()``; a closed socket object never writes to a reused fd). Every round then
runs the ``_service`` hook. :class:`DriveBusServer` adds the emulated drives: it wakes at their
next deadline and services a bus when it ``wants_service`` (see :mod:`hil_sim.drive_bus`), so a
frame is answered at once and the plant advances between command cycles.
"""
from __future__ import annotations

import select
import socket
import time


class SelectServer:
    """Subclasses name their files (``_files``), handle what is ready (``_ready``) and may have
    a deadline (``_next_deadline``), a per-round ``_service`` and a ``_woken`` hook."""

    def __init__(self, clock=time.monotonic):
        self.clock = clock
        self._wake_r, self._wake_w = socket.socketpair()
        self._stop = False

    def serve_forever(self) -> None:
        """Serve until :meth:`shutdown`, then :meth:`close`."""
        try:
            while not self._stop:
                deadline = self._next_deadline()
                timeout = max(0.0, deadline - self.clock()) if deadline is not None else None
                readers, writers = self._files()
                readable, _, _ = select.select([self._wake_r, *readers], writers, [], timeout)
                now = self.clock()
                if self._wake_r in readable:
                    self._wake_r.recv(64)
                    self._woken()
                self._ready(readable, now)
                self._service(now)
        finally:
            self.close()

    def shutdown(self) -> None:
        """Make :meth:`serve_forever` return (thread- and signal-safe)."""
        self._stop = True
        self._wake()

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"x")
        except OSError:  # already closed: the loop has ended
            pass

    def close(self) -> None:
        self._wake_r.close()
        self._wake_w.close()

    # -- hooks ------------------------------------------------------------------------------
    def _files(self) -> tuple[list, list]:
        """The files to wait on: (readable, writable)."""
        raise NotImplementedError

    def _ready(self, readable: list, now: float) -> None:
        """Handle the files ``select()`` found readable (the wake socket among them is done)."""
        raise NotImplementedError

    def _next_deadline(self) -> float | None:
        return None

    def _woken(self) -> None:
        """After a wake-up from another thread (e.g. a request it left for the loop)."""

    def _service(self, now: float) -> None:
        """Run once per round, after ``_ready``."""


class DriveBusServer(SelectServer):
    """A SelectServer in front of drive buses; ``_frames_out(bus, frames)`` sends the frames a
    service produced and clears the list."""

    def __init__(self, buses, clock=time.monotonic):
        super().__init__(clock)
        self._drive_buses = list(buses)
        self._frames_due: list = []

    def _next_deadline(self) -> float | None:
        deadlines = [d for b in self._drive_buses if (d := b.next_deadline()) is not None]
        return min(deadlines) if deadlines else None

    def _service(self, now: float) -> None:
        for bus in self._drive_buses:  # plant, watchdogs, delayed replies
            if bus.wants_service(now):
                bus.service(now, self._frames_due)
                self._frames_out(bus, self._frames_due)

    def _frames_out(self, bus, frames: list) -> None:
        raise NotImplementedError
