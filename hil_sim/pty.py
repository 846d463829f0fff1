"""A pseudo-terminal that a simulated serial device serves: what a USB-serial adapter looks
like to the host (pyserial or python-can open ``path``).

The pty is raw (no echo, no CR→NL: bytes go through untouched) and its master non-blocking;
the slave end stays open here so the master never sees EIO while the host reconnects. A
socket pair wakes the serving thread's ``select()`` for :meth:`shutdown` (a closed socket
object never writes to a reused fd). :meth:`close` closes the pty: the host sees the line go.
"""
from __future__ import annotations

import os
import socket
import tty


class PtyEndpoint:
    def __init__(self):
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self._wake_r, self._wake_w = socket.socketpair()
        self._stop = False

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"x")
        except OSError:  # already closed: the loop has ended
            pass

    def shutdown(self) -> None:
        """Stop serving (from any thread); the serving loop closes the pty."""
        self._stop = True
        self._wake()

    def close(self) -> None:
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self._master = self._slave = -1
        self._wake_r.close()
        self._wake_w.close()
