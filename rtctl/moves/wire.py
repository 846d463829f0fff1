"""The planner's pipe, read by the loop without ever waiting.

A message is pickled and cut into pieces of at most ``PIECE`` bytes, each one
:meth:`~multiprocessing.connection.Connection.send_bytes` call: a piece that size reaches the
reader in one write (a Unix socket queues it whole), so once the pipe polls readable the
reader's ``recv_bytes`` returns at once — a large trajectory (a 200-waypoint move is 0.3 MB)
arrives over several ticks instead of blocking one until its writer, at a low priority,
gets the CPU to finish. The first piece starts with the message's length (4 bytes).
"""
from __future__ import annotations

import pickle
import struct

PIECE = 16 * 1024  # Connection.send_bytes writes header and body in one call up to this size
LENGTH = struct.Struct("!I")


def send(conn, obj) -> None:
    data = LENGTH.pack(0) + pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    data = LENGTH.pack(len(data) - LENGTH.size) + data[LENGTH.size:]
    for i in range(0, len(data), PIECE):
        conn.send_bytes(data[i:i + PIECE])


class Inbox:
    """The reader's end: :meth:`take` what has arrived, a whole message or None."""

    def __init__(self, conn):
        self.conn = conn
        self.buffer = bytearray()

    def take(self):
        """The next whole message, or None when it has not all arrived (never waits).
        EOFError/OSError when the writer is gone."""
        while not self._whole() and self.conn.poll(0):
            self.buffer += self.conn.recv_bytes()
        if not self._whole():
            return None
        (n,) = LENGTH.unpack_from(self.buffer)
        msg = pickle.loads(self.buffer[LENGTH.size:LENGTH.size + n])
        del self.buffer[:LENGTH.size + n]
        return msg

    def _whole(self) -> bool:
        return len(self.buffer) >= LENGTH.size and len(self.buffer) >= LENGTH.size + LENGTH.unpack_from(self.buffer)[0]
