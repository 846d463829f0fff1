"""One client connection of the control socket, and a reply the handler gives later."""
from __future__ import annotations

import socket

from rtctl.control_socket.framing import HEADER, decode

URGENT = frozenset({"stop", "estop"})  # served even past a poll's budget, and while the daemon starts


def urgent(body: bytes) -> bool:
    """A stop or an e-stop (a few bytes of msgpack): served even past the poll's budget."""
    if len(body) > 32:
        return False
    try:
        request = decode(body)
    except ValueError:
        return False
    return isinstance(request, dict) and request.get("cmd") in URGENT


def first_frame(inbuf: bytearray) -> bytes:
    """The body of the first frame in ``inbuf``, as much of it as has arrived."""
    if len(inbuf) < HEADER.size:
        return b""
    (length,) = HEADER.unpack_from(inbuf)
    return bytes(inbuf[HEADER.size:HEADER.size + length])


def frame_waiting(inbuf: bytearray) -> bool:
    """A whole frame is buffered: it waits its turn (the poll's budget, a Deferred before it)."""
    if len(inbuf) < HEADER.size:
        return False
    (length,) = HEADER.unpack_from(inbuf)
    return len(inbuf) >= HEADER.size + length


class Deferred:
    """A reply the handler gives later: return one from the handler, :meth:`resolve` it from
    the loop when the answer is known (a move once it is planned). Until then the connection
    waits — its further requests stay queued, it is not timed out as idle — and the server
    sends the reply at its first poll after :meth:`resolve`."""

    __slots__ = ("reply",)

    def __init__(self):
        self.reply: dict | None = None

    def resolve(self, reply: dict) -> None:
        if self.reply is None:  # the first answer stands (a cancel after the swap changes nothing)
            self.reply = reply


class Connection:
    __slots__ = ("sock", "inbuf", "outbuf", "deadline", "closing", "last_request", "waiting")

    def __init__(self, sock: socket.socket, now: float, deadline: float):
        self.sock = sock
        self.inbuf = bytearray()
        self.outbuf = bytearray()
        self.deadline = deadline
        self.closing = False  # close once outbuf is sent (after a framing error)
        self.last_request = now  # accepted, or its last request answered: who is dropped first
        self.waiting: Deferred | None = None  # a request answered later

    def drain(self, chunk: int) -> bool:
        """Read what the client has sent (a socket closed with unread data resets its peer);
        True if a request, whole or in part, is waiting."""
        for _ in range(4):
            try:
                data = self.sock.recv(chunk)
            except OSError:  # (BlockingIOError: nothing more)
                break
            if not data:
                break
            self.inbuf += data
        return bool(self.inbuf)

    def eviction_rank(self) -> tuple:
        """Lower is dropped first: closing, then idle, then mid-frame; oldest first in each."""
        busy = 0 if self.closing else (2 if self.inbuf or self.waiting else 1)
        return busy, self.last_request
