"""An slcan (Lawicel ASCII) CAN adapter on a pseudo-terminal in front of emulated drives: what a
CANable-style USB-serial adapter looks like to python-can's ``slcan`` interface
(``can.Bus(interface="slcan", channel=<pty path>, sleep_after_open=0)``).

Commands, each ending in CR; answers are CR for OK and BEL for an error (Lawicel):

* ``S0``–``S9`` bitrate, ``sXXYY`` BTR registers — only while closed; ``O`` open, ``L`` open
  listen-only (only while closed), ``C`` close (CR also when already closed: python-can's
  ``set_bitrate`` closes first); an empty command answers CR (python-can sends one for
  "no data bitrate").
* ``V`` → ``V1013``, ``N`` → ``NRTSM``, ``F`` → ``F00`` (status flags), ``Z0`` → CR (``Z1``,
  timestamps, is refused), ``M``/``m`` acceptance filters → CR (everything is accepted).
* ``tIIILDD…`` / ``TIIIIIIIILDD…`` transmit (only while open, not listen-only) → ``z``/``Z`` CR
  when ``ack_transmit`` (Lawicel; some firmwares stay silent), ``r``/``R`` remote → the same,
  CAN FD ``d D b B`` → BEL.
* Frames on the bus go to the host as ``tIIILDD…`` CR while open.

One thread blocks in ``select()`` on the pty master; nothing polls. Run standalone:
``python -m hil_sim.slcan --ids 1 2 3`` prints one JSON line
``{"transport": "slcan", "tty": "/dev/pts/N", "channels": [...]}`` and serves until SIGTERM.
"""
from __future__ import annotations

import argparse
import time

from hil_sim.mit_drive import MitDriveBus, add_stand_in_arguments, announce, stand_in_bus_from_args
from hil_sim.pty import Pty
from hil_sim.select_server import DriveBusServer

OK, BELL = b"\r", b"\a"
_MAX_LINE = 64  # longest legal command is ~27 characters
_MAX_QUEUED = 65536  # bytes waiting for the host before new frames are dropped


class SlcanAdapter(DriveBusServer):
    """Serves one ``MitDriveBus`` on a new pty; ``path`` is the device python-can opens."""

    def __init__(self, bus: MitDriveBus, ack_transmit: bool = True, clock=time.monotonic):
        super().__init__([bus], clock)
        self.bus, self.ack_transmit = bus, ack_transmit
        self.pty = Pty()
        self.path = self.pty.path
        self._line = bytearray()
        self.is_open = False
        self.listen_only = False
        self.counters = {"frames_in": 0, "frames_out": 0, "errors": 0, "overflows": 0}

    def info(self) -> dict:
        return {"transport": "slcan", "tty": self.path, "channels": [self.bus.name]}

    def close(self) -> None:
        self.pty.close()
        super().close()

    def _files(self) -> tuple[list, list]:
        return self.pty.files()

    def _ready(self, readable: list, now: float) -> None:
        if self.pty.fd in readable:
            self._feed(self.pty.read(), now, self._frames_due)

    def _service(self, now: float) -> None:
        super()._service(now)
        self.pty.flush()

    # -- host → adapter -------------------------------------------------------------------
    def _feed(self, data: bytes, now: float, out: list) -> None:
        self._line += data
        while (end := self._line.find(b"\r")) >= 0:
            command = bytes(self._line[:end])
            del self._line[: end + 1]
            self.pty.out += self._command(command, now, out)
            self._frames_out(self.bus, out)  # the drives' replies follow the transmit ack
        if len(self._line) > _MAX_LINE:
            self._line.clear()
            self._error()

    def _command(self, c: bytes, now: float, out: list) -> bytes:
        head = c[:1]
        if head in (b"t", b"T", b"r", b"R"):
            return self._transmit(c, now, out)
        if c == b"":
            return OK
        if head == b"S" and len(c) == 2 and c[1:].isdigit() and not self.is_open:
            return OK
        if head == b"s" and len(c) == 5 and not self.is_open:
            return OK
        if c in (b"O", b"L"):
            if self.is_open:
                return self._error()
            self.is_open, self.listen_only = True, c == b"L"
            return OK
        if c == b"C":
            self.is_open = False
            return OK
        if c == b"V":
            return b"V1013" + OK
        if c == b"N":
            return b"NRTSM" + OK
        if c == b"F":
            return b"F00" + OK
        if c == b"Z0" or (head in (b"M", b"m") and len(c) == 9):
            return OK
        return self._error()

    def _transmit(self, c: bytes, now: float, out: list) -> bytes:
        extended = c[:1] in (b"T", b"R")
        remote = c[:1] in (b"r", b"R")
        id_len = 8 if extended else 3
        if not self.is_open or self.listen_only:
            return self._error()
        try:
            arbitration_id = int(c[1 : 1 + id_len], 16)
            dlc = int(c[1 + id_len : 2 + id_len])
            payload = c[2 + id_len :]
            if not 0 <= dlc <= 8 or len(payload) != (0 if remote else 2 * dlc):
                raise ValueError
            data = bytes.fromhex(payload.decode("ascii"))
        except ValueError:
            return self._error()
        self.counters["frames_in"] += 1
        if not remote:
            self.bus.receive(arbitration_id, data, now, out, extended)
        ack = (b"Z" if extended else b"z") + OK
        return ack if self.ack_transmit else b""

    def _error(self) -> bytes:
        self.counters["errors"] += 1
        return BELL

    # -- adapter → host -------------------------------------------------------------------
    def _frames_out(self, bus: MitDriveBus, frames: list) -> None:
        """Queue frames for the host; when the host stops reading and the queue is full, new
        frames are dropped whole (a real adapter's buffer overflows the same way) rather than
        block the drives or cut a line in two."""
        if self.is_open:
            for arbitration_id, payload in frames:
                if len(self.pty.out) > _MAX_QUEUED:
                    self.counters["overflows"] += 1
                    continue
                self.pty.out += b"t%03X%d%s\r" % (arbitration_id, len(payload), payload.hex().upper().encode())
                self.counters["frames_out"] += 1
        frames.clear()


def serve_slcan(bus: MitDriveBus, ready_callback=None, ack_transmit: bool = True) -> SlcanAdapter:
    """Create the adapter, call ``ready_callback(adapter)`` (``adapter.path`` is the tty), then
    serve until ``adapter.shutdown()``; returns the adapter."""
    adapter = SlcanAdapter(bus, ack_transmit=ack_transmit)
    if ready_callback is not None:
        ready_callback(adapter)
    adapter.serve_forever()
    return adapter


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m hil_sim.slcan", description=__doc__.split("\n")[0])
    add_stand_in_arguments(parser)
    parser.add_argument("--no-ack", action="store_true", help="do not answer transmits with z/Z")
    parser.set_defaults(ids=[1, 2, 3])
    args = parser.parse_args(argv)
    serve_slcan(stand_in_bus_from_args(args), ready_callback=announce, ack_transmit=not args.no_ack)


if __name__ == "__main__":
    main()
