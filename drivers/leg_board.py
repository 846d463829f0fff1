"""The leg board over a serial line (driver ``leg_board``; protocol in drivers/protocols/leg_board.py).

Options (the ``[[devices]]`` table; the device serves the leg's joints hip, knee, ankle)::

    port = "/dev/ttyUSB0"     # any pyserial URL: a device, a pty ("${HIL_SIM_TTY}"), loop://, socket://…
    baudrate = 115200
    reply_deadline = 0.6      # fraction of the period write() waits for the board's sensor frame
    exchange_timeout = 0.5    # s to wait for the first frame at configure
    write_timeout = 0.1       # s write() may wait for the port to take a command frame
    velocity_time = 0.02      # s, low-pass of the angle difference

Per tick: ``write()`` sends the command frame (the actions) and waits, up to the deadline, for
the sensor frame the board sends back; ``read()`` of the next tick publishes it. A tick with
no new frame marks the joints not fresh, and the safety stage's ``stale_ticks`` in a row is a
fault: the loop locks both joints (a silent board → safe state within that many ticks; the
board's own watchdog locks them too when our commands stop). A frame whose sequence number
does not advance (the same frame again, or an older one) is no new frame: a link that replays
frames goes stale like a silent one. Lost, garbled, foreign and refused frames are counted
(:class:`~drivers.protocols.leg_board.Decoder`); a closed or failing port is an ERROR. While
active, the board's status is checked every tick: its watchdog's lock (or a status bit the
protocol does not define) is an ERROR naming it. ``configure`` opens the port and needs one
sensor frame (states readable); ``activate`` needs a frame whose status shows the watchdog's
lock released (the board locks the joints whenever our commands pause, as between configure
and activate); ``deactivate`` sends lock commands until the board reports both joints locked
(else it fails). A port that does not take a command frame within ``write_timeout``, or fails,
is a HardwareError naming the device, the port and the cause (in a tick: the device's ERROR).
"""
from __future__ import annotations

import time

import serial

from drivers.protocols import leg_board as proto
from rtctl.errors import HardwareError
from rtctl.hal import Lifecycle, Status
from rtctl.hal.leg_board import LegBoard
from rtctl.tomltable import expand_env

LOCK_REPEATS = 3
LOCKED = proto.pack_actions(proto.HOLD, proto.HOLD)


class SerialLegBoard(LegBoard):
    def __init__(self, name, joint_names, port: str, period: float, *, baudrate: int = 115200,
                 reply_deadline: float = 0.6, exchange_timeout: float = 0.5, write_timeout: float = 0.1,
                 velocity_time: float = 0.02):
        super().__init__(name, joint_names, period, velocity_time)
        self.url, self.baudrate = port, baudrate
        self.reply_timeout = reply_deadline * period
        self.exchange_timeout, self.write_timeout = exchange_timeout, write_timeout
        self.port = None
        self.decoder = proto.Decoder(proto.SENSOR)
        self._frame = bytearray(proto.COMMAND_LENGTH)
        self._seq = 0
        self._published = 0  # decoder frame count at the last read
        self._reported_status = -1  # the faulty status last_error describes (built once per episode)
        self.counters = {"commands": 0, "late_replies": 0}

    @classmethod
    def from_config(cls, device, context) -> "SerialLegBoard":
        t = device.options
        if len(device.joints) != 3:
            raise t.error("joints", "the leg's three joints (hip, knee, ankle)")
        port = expand_env(t, "port", t.str("port"))
        kw = dict(baudrate=t.int("baudrate", 115200, min=1),
                  reply_deadline=t.float("reply_deadline", 0.6, positive=True, max=0.95),
                  exchange_timeout=t.float("exchange_timeout", 0.5, positive=True),
                  write_timeout=t.float("write_timeout", 0.1, positive=True),
                  velocity_time=t.float("velocity_time", 0.02, min=0.0))
        t.done()
        names = [context.model.joint_names[j] for j in device.joints]
        return cls(device.name, names, str(port), context.period, **kw)

    # -- lifecycle -----------------------------------------------------------------------
    def _on_configure(self) -> None:
        try:
            self.port = serial.serial_for_url(self.url, baudrate=self.baudrate, timeout=0,
                                            write_timeout=self.write_timeout)
        except (serial.SerialException, OSError, ValueError) as e:
            raise HardwareError(f"{self.name}: cannot open {self.url}: {e}") from e
        self.safe_state()
        try:
            if not self._exchange(self.exchange_timeout):
                raise HardwareError(f"{self.name}: no sensor frame from the board on {self.url} "
                                    f"within {self.exchange_timeout} s ({self.decoder.counters})")
        except HardwareError:
            self._close_port()
            raise

    def _on_activate(self) -> None:
        """Send lock commands until the board reports its watchdog's lock released: from then on
        a WATCHDOG bit means our commands stopped reaching it."""
        self.safe_state()
        deadline = time.monotonic() + self.exchange_timeout
        while not (self._exchange(max(0.0, deadline - time.monotonic()))
                   and not self.decoder.status & proto.STATUS_FAULTS):
            if time.monotonic() >= deadline:
                raise HardwareError(f"{self.name}: the board on {self.url} still reports status "
                                    f"{self.decoder.status:#04x} (its watchdog's lock) after "
                                    f"{self.exchange_timeout} s of commands")
        self._reported_status = -1

    def _on_deactivate(self) -> None:
        """Lock both joints until a sensor frame reports both locked (its status: the actions
        the board applies; a late frame from before says otherwise)."""
        self.safe_state()
        for _ in range(LOCK_REPEATS):  # a lost frame must not leave a joint free
            if self._exchange(self.exchange_timeout) and self.decoder.status & proto.ACTIONS_MASK == LOCKED:
                return
        raise HardwareError(f"{self.name}: the board on {self.url} did not report both joints locked after "
                            f"{LOCK_REPEATS} lock commands (its watchdog locks them when our commands stop)")

    def _on_close(self) -> None:
        self._close_port()

    def _close_port(self) -> None:
        if self.port is not None:
            self.port.close()
            self.port = None

    # -- every tick ----------------------------------------------------------------------
    def _read(self, t: float) -> Status:
        self._collect(0.0)  # whatever else arrived since write()
        decoder = self.decoder
        fresh = decoder.counters["frames"] != self._published
        self._published = decoder.counters["frames"]
        if fresh:
            self.channels[:] = decoder.channels
        self.publish(t, fresh)
        if decoder.status & proto.STATUS_FAULTS and self.lifecycle is Lifecycle.ACTIVE:
            return self._board_fault(decoder.status)
        self._reported_status = -1
        return Status.OK

    def _board_fault(self, status: int) -> Status:
        """The board says it is not under our command: ERROR, its cause described once per episode."""
        if status != self._reported_status:
            self._reported_status = status
            if status & proto.WATCHDOG:
                self.last_error = (f"the board's watchdog locked both joints (status {status:#04x}: our commands "
                                   f"stopped reaching it)")
            else:
                undefined = status & proto.STATUS_FAULTS & ~proto.WATCHDOG
                self.last_error = f"the board reports status {status:#04x}: bits {undefined:#04x} are undefined"
        return Status.ERROR

    def _write(self, t: float) -> Status:
        if not self._exchange(self.reply_timeout):
            self.counters["late_replies"] += 1
        return Status.OK

    def _exchange(self, timeout: float) -> bool:
        """Send the actions; wait up to ``timeout`` for a new sensor frame."""
        if self.port is None:
            raise HardwareError(f"{self.name}: port closed")
        proto.encode_command(self._seq, int(self.actions[0]), int(self.actions[1]), self._frame)
        self._seq = (self._seq + 1) & 0xFF
        try:
            self.port.write(self._frame)
        except serial.SerialTimeoutException as e:  # (pyserial says so also of a write it finished late)
            raise HardwareError(f"{self.name}: the port {self.url} did not take a command frame within "
                                f"{self.write_timeout} s") from e
        except (serial.SerialException, OSError) as e:
            raise HardwareError(f"{self.name}: writing to {self.url} failed: {e}") from e
        self.counters["commands"] += 1
        return self._collect(timeout)

    def _collect(self, timeout: float) -> bool:
        """Feed the decoder until a new frame arrived or ``timeout`` passed; True if one did."""
        port, decoder = self.port, self.decoder
        before = decoder.counters["frames"]
        deadline = time.monotonic() + timeout
        while True:
            waiting = port.in_waiting
            if waiting:
                decoder.feed(port.read(waiting))
                if decoder.counters["frames"] != before:
                    return True
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return decoder.counters["frames"] != before
            port.timeout = min(remaining, 0.002)
            data = port.read(1)  # blocks until a byte or the short timeout (no spinning)
            port.timeout = 0
            if data:
                decoder.feed(data)

    def stale_cause(self) -> str:
        c = self.decoder.counters
        return (f"no new sensor frame from the board on {self.url} (the last taken: seq {self.decoder.seq}; so far "
                f"{c['repeated_frames']} repeated and {c['out_of_order']} out-of-order frames refused, "
                f"{c['crc_errors']} CRC errors, {self.counters['late_replies']} late replies)")

    def diagnostics(self) -> dict:
        return {**super().diagnostics(), "port": self.url, **self.counters, **self.decoder.counters}
