"""A pseudo-terminal that a simulated serial device serves: what a USB-serial adapter looks
like to the host (pyserial or python-can open ``path``).

The pty is raw (no echo, no CR→NL: bytes go through untouched) and its master non-blocking;
the slave end stays open here so the master never sees EIO while the host reconnects. Bytes
for the host wait in ``out`` until the pty takes them (:meth:`flush`). :meth:`close` closes
the pty: the host sees the line go.
"""
from __future__ import annotations

import os
import tty


class Pty:
    def __init__(self):
        self.fd, self._slave = os.openpty()  # fd: the master, the device's side
        tty.setraw(self._slave)
        os.set_blocking(self.fd, False)
        self.path = os.ttyname(self._slave)
        self.out = bytearray()

    def files(self) -> tuple[list, list]:
        """What a select() loop waits on: the master, and its writability while bytes wait."""
        return [self.fd], [self.fd] if self.out else []

    def read(self) -> bytes:
        try:
            return os.read(self.fd, 4096)
        except BlockingIOError:
            return b""

    def flush(self) -> None:
        """Write what the pty takes now; the rest waits for select() to say it is writable."""
        while self.out:
            try:
                n = os.write(self.fd, self.out)
            except BlockingIOError:
                return
            del self.out[:n]

    def close(self) -> None:
        for fd in (self.fd, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self.fd = self._slave = -1
