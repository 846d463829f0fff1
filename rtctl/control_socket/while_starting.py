"""Serving ``stop`` and ``estop`` while the daemon starts, from a helper thread.

server.py explains why the running loop polls the socket itself and no thread serves it.
Before the first tick there is no loop to poll, and the start-up's steps are long and cannot
be cut into pieces: loading a group of kernels from numba's cache (0.3–0.4 s for the dynamics
library on a 2-core machine), a device's configure or activate (SDO transfers, a CiA 402
drive's state machine), waiting for the compile workers, planning the initial trajectory.
:class:`ServedWhileStarting` polls the socket every ``every_s`` from a thread meanwhile, with
the server's ``starting`` set to what the daemon is doing: ``stop`` and ``estop`` are handled —
their handlers only set what the start-up checks between its steps — and any other request is
answered at once that the daemon is starting (and doing what), never held for the loop.

The thread sleeps between polls and needs the GIL only for a poll, which it gets within the
interpreter's switch interval (5 ms) even while the main thread runs Python. It is joined on
exit: before the loop starts (from then on the loop polls) and before any fork (a forked
child keeps only the forking thread; a lock the helper held would stay held there).
"""
from __future__ import annotations

import threading

import structlog

log = structlog.get_logger("rtctl.control_socket")

SERVE_EVERY_S = 0.01  # a stop sent while the daemon starts waits at most this (+ the GIL's 5 ms)


class ServedWhileStarting:
    """``with ServedWhileStarting(server, "loading kernels") as served:`` — the server is polled
    from a helper thread until the block ends, stop and estop handled, the rest answered that the
    daemon is starting; :meth:`doing` says what it does next. Nothing else may use the server
    meanwhile."""

    def __init__(self, server, doing: str, every_s: float = SERVE_EVERY_S):
        self.server, self.every_s, self._doing = server, every_s, doing
        self._done = threading.Event()
        self._thread: threading.Thread | None = None

    def doing(self, what: str) -> None:
        """What the start does now, for the answers to requests other than stop and estop."""
        self.server.starting = self._doing = what  # (one attribute: the helper reads it whole)

    def __enter__(self) -> "ServedWhileStarting":
        self.server.starting = self._doing
        self._done.clear()
        self._thread = threading.Thread(target=self._serve, name="rtctl-socket-while-starting", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._done.set()
        self._thread.join()
        self._thread = None
        self.server.starting = None

    def _serve(self) -> None:
        while not self._done.wait(self.every_s):
            try:
                self.server.poll()
            except Exception as e:  # (the handler's own errors are answered inside poll)
                log.error("control socket failed while starting", error=f"{type(e).__name__}: {e}",
                          detail="stop and estop are served again once the loop runs; SIGTERM works meanwhile")
                return
