"""A socketcand server on loopback TCP in front of emulated drives: the HIL simulator's CAN bus
for python-can's ``socketcand`` interface (``can.Bus(interface="socketcand", host=…, port=…,
channel="can0", tcp_tune=True)``).

Protocol (linux-can/socketcand doc/protocol.md, and what python-can's client expects): on
connect the server says ``< hi >``; ``< open NAME >`` → ``< ok >`` (NAME is a served bus, else
``< error … >`` and the connection closes); ``< rawmode >`` → ``< ok >``; from then on every
frame on the bus goes to the client as ``< frame ID SECS.USECS DATA >`` (ID 3 hex digits, 8 for
extended; DATA hex without spaces, as socketcand prints it) and the client sends
``< send ID DLC B0 B1 … >``. ``< echo >`` is echoed. No frame is sent to a client before its
``< rawmode >`` was answered: python-can reads each handshake answer with one ``recv`` and
compares it whole. One thread blocks in ``select()``; nothing polls.

Run standalone: ``python -m hil_sim.socketcand --ids 1 2 3 4 5 6`` prints one JSON line
``{"transport": "socketcand", "host": …, "port": …, "channels": ["can0"]}`` and serves until
SIGTERM/SIGINT.
"""
from __future__ import annotations

import argparse
import socket
import time
from dataclasses import dataclass, field

from hil_sim.mit_drive import MitDriveBus, add_stand_in_arguments, announce, stand_in_bus_from_args
from hil_sim.select_server import DriveBusServer

_MAX_PENDING = 4096  # bytes without a closing '>' before a client's input is discarded


@dataclass
class _Client:
    sock: socket.socket
    state: str = "nobus"  # nobus → bcm → raw
    bus: MitDriveBus | None = None
    buf: bytearray = field(default_factory=bytearray)


class SocketcandServer(DriveBusServer):
    """Serves ``buses`` (MitDriveBus, one per channel name) on ``host:port`` (0 → a free port)."""

    def __init__(self, buses, host: str = "127.0.0.1", port: int = 0, clock=time.monotonic):
        buses = [buses] if isinstance(buses, MitDriveBus) else list(buses)
        super().__init__(buses, clock)
        self.buses = {b.name: b for b in buses}
        self._listen = socket.create_server((host, port))
        self._listen.setblocking(False)
        self._clients: dict[socket.socket, _Client] = {}
        self._drop_all = False
        self.counters = {"connections": 0, "frames_in": 0, "frames_out": 0, "syntax_errors": 0}

    @property
    def address(self) -> tuple[str, int]:
        return self._listen.getsockname()[:2]

    def info(self) -> dict:
        host, port = self.address
        return {"transport": "socketcand", "host": host, "port": port, "channels": sorted(self.buses)}

    def drop_connections(self) -> None:
        """Fault injection: close every client connection (thread-safe); the listener stays,
        so clients may reconnect."""
        self._drop_all = True
        self._wake()

    def close(self) -> None:
        for c in list(self._clients.values()):
            self._drop(c)
        self._listen.close()
        super().close()

    # -- loop -----------------------------------------------------------------------------
    def _files(self) -> tuple[list, list]:
        return [self._listen, *self._clients], []

    def _woken(self) -> None:
        if self._drop_all:
            self._drop_all = False
            for c in list(self._clients.values()):
                self._drop(c)

    def _ready(self, readable: list, now: float) -> None:
        for s in readable:
            if s is self._listen:
                self._accept()
            elif s in self._clients:  # (a client dropped earlier in this round is gone)
                self._read(self._clients[s], now)

    def _frames_out(self, bus: MitDriveBus, frames: list) -> None:
        self._broadcast(bus, frames, None)

    # -- connections ----------------------------------------------------------------------
    def _accept(self) -> None:
        try:
            sock, _ = self._listen.accept()
        except BlockingIOError:
            return
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # one frame per segment, now
        self._clients[sock] = _Client(sock)
        self.counters["connections"] += 1
        self._send(self._clients[sock], b"< hi >")

    def _drop(self, client: _Client) -> None:
        self._clients.pop(client.sock, None)
        client.sock.close()

    def _send(self, client: _Client, data: bytes) -> None:
        try:
            client.sock.sendall(data)
        except OSError:
            self._drop(client)

    def _read(self, client: _Client, now: float) -> None:
        try:
            data = client.sock.recv(65536)
            client.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_QUICKACK, 1)  # as socketcand: ack now
        except OSError:
            data = b""
        if not data:
            self._drop(client)
            return
        client.buf += data
        out: list = []
        while client.sock in self._clients:
            start = client.buf.find(b"<")
            end = client.buf.find(b">", start + 1) if start >= 0 else -1
            if end < 0:
                if start < 0 or len(client.buf) > _MAX_PENDING:
                    client.buf.clear()
                elif start > 0:
                    del client.buf[:start]
                break
            command = bytes(client.buf[start + 1 : end]).decode("ascii", "replace").split()
            del client.buf[: end + 1]
            self._command(client, command, now, out)
        if out and client.bus is not None:
            self._broadcast(client.bus, out, None)

    def _command(self, client: _Client, words: list[str], now: float, out: list) -> None:
        verb = words[0] if words else ""
        if verb == "echo":
            self._send(client, b"< echo >")
        elif client.state == "nobus":
            if verb == "open" and len(words) == 2 and words[1] in self.buses:
                client.bus, client.state = self.buses[words[1]], "bcm"
                self._send(client, b"< ok >")
            else:
                self._send(client, b"< error could not open bus >")
                self._drop(client)
        elif verb == "rawmode":
            client.state = "raw"
            self._send(client, b"< ok >")
        elif verb == "bcmmode":
            client.state = "bcm"
            self._send(client, b"< ok >")
        elif verb == "send":
            self._frame_from_client(client, words, now, out)
        else:
            self.counters["syntax_errors"] += 1
            self._send(client, b"< error unknown command >")

    def _frame_from_client(self, client: _Client, words: list[str], now: float, out: list) -> None:
        try:
            dlc = int(words[2])
            if not 0 <= dlc <= 8 or len(words) != 3 + dlc:
                raise ValueError
            arbitration_id = int(words[1], 16)
            data = bytes([int(b, 16) for b in words[3:]])
        except (ValueError, IndexError):
            self.counters["syntax_errors"] += 1  # socketcand logs and drops a bad send
            return
        extended = len(words[1]) == 8
        self.counters["frames_in"] += 1
        if len(self._clients) > 1:  # other clients on the bus see the frame
            self._broadcast(client.bus, [(arbitration_id, data, extended)], client)
        client.bus.receive(arbitration_id, data, now, out, extended)

    def _broadcast(self, bus: MitDriveBus, frames: list, sender: _Client | None) -> None:
        """Send frames on ``bus`` to every raw-mode client on it except ``sender``; clears ``frames``."""
        to = [c for c in self._clients.values() if c.bus is bus and c.state == "raw" and c is not sender]
        if frames and to:
            stamp = f"{time.time():.6f}"
            text = "".join(
                f"< frame {f[0]:08X} {stamp} {f[1].hex().upper()} >" if len(f) > 2 and f[2]
                else f"< frame {f[0]:03X} {stamp} {f[1].hex().upper()} >"
                for f in frames
            ).encode("ascii")
            for c in to:
                self._send(c, text)
                self.counters["frames_out"] += len(frames)
        frames.clear()


def serve_socketcand(buses, host: str = "127.0.0.1", port: int = 0, ready_callback=None) -> SocketcandServer:
    """Create a server, call ``ready_callback(server)`` (e.g. print ``server.info()`` or keep the
    server to call ``shutdown`` from elsewhere), then serve until shutdown; returns the server."""
    server = SocketcandServer(buses, host, port)
    if ready_callback is not None:
        ready_callback(server)
    server.serve_forever()
    return server


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m hil_sim.socketcand", description=__doc__.split("\n")[0])
    add_stand_in_arguments(parser)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=0, help="0: pick a free port (printed)")
    args = parser.parse_args(argv)
    serve_socketcand(stand_in_bus_from_args(args), args.host, args.port, ready_callback=announce)


if __name__ == "__main__":
    main()
