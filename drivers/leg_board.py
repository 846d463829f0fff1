"""The leg board over a serial line (driver ``leg_board``; protocol in drivers/protocols/leg_board.py).

Options (the ``[[devices]]`` table; the device serves the leg's joints hip, knee, ankle)::

    port = "/dev/ttyUSB0"     # any pyserial URL: a device, a pty ("${HIL_SIM_TTY}"), loop://, socket://…
    baudrate = 115200
    reply_deadline = 0.6      # fraction of the period write() waits for the board's sensor frame
    exchange_timeout = 0.5    # s to wait for the first frame at configure
    velocity_time = 0.02      # s, low-pass of the angle difference

Per tick: ``write()`` sends the command frame (the actions) and waits, up to the deadline, for
the sensor frame the board sends back; ``read()`` of the next tick publishes it. A tick with
no new frame marks the joints not fresh, and the safety stage's ``stale_ticks`` in a row is a
fault: the loop locks both joints (a silent board → safe state within that many ticks; the
board's own watchdog locks them too when our commands stop). Lost, garbled and foreign bytes
are counted (:class:`~drivers.protocols.leg_board.Decoder`); a closed or failing port is an
ERROR. ``configure`` opens the port and needs one sensor frame (states readable);
``deactivate`` sends lock commands until the board reports both joints locked (else it fails).
"""
from __future__ import annotations

import time

import serial

from drivers.protocols import leg_board as proto
from rtctl.errors import HardwareError
from rtctl.hal import Status
from rtctl.hal.leg_board import LegBoard
from rtctl.tomltable import expand_env

LOCK_REPEATS = 3
LOCKED = proto.pack_actions(proto.HOLD, proto.HOLD)


class SerialLegBoard(LegBoard):
    def __init__(self, name, joint_names, port: str, period: float, *, baudrate: int = 115200,
                 reply_deadline: float = 0.6, exchange_timeout: float = 0.5, velocity_time: float = 0.02):
        super().__init__(name, joint_names, period, velocity_time)
        self.url, self.baudrate = port, baudrate
        self.reply_timeout = reply_deadline * period
        self.exchange_timeout = exchange_timeout
        self.port = None
        self.decoder = proto.Decoder(proto.SENSOR)
        self._frame = bytearray(proto.COMMAND_LENGTH)
        self._seq = 0
        self._published = 0  # decoder frame count at the last read
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
                  velocity_time=t.float("velocity_time", 0.02, min=0.0))
        t.done()
        names = [context.model.joint_names[j] for j in device.joints]
        return cls(device.name, names, str(port), context.period, **kw)

    # -- lifecycle -----------------------------------------------------------------------
    def _on_configure(self) -> None:
        try:
            self.port = serial.serial_for_url(self.url, baudrate=self.baudrate, timeout=0, write_timeout=0.1)
        except (serial.SerialException, OSError, ValueError) as e:
            raise HardwareError(f"{self.name}: cannot open {self.url}: {e}") from e
        self.safe_state()
        if not self._exchange(self.exchange_timeout):
            self._close_port()
            raise HardwareError(f"{self.name}: no sensor frame from the board on {self.url} "
                                f"within {self.exchange_timeout} s ({self.decoder.counters})")

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
        fresh = self.decoder.counters["frames"] != self._published
        self._published = self.decoder.counters["frames"]
        if fresh:
            self.channels[:] = self.decoder.channels
        self.publish(t, fresh)
        return Status.OK

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
        self.port.write(self._frame)
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

    def diagnostics(self) -> dict:
        return {**super().diagnostics(), "port": self.url, **self.counters, **self.decoder.counters}
