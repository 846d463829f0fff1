"""The leg board's serial protocol: pure bytes ↔ values, used by the driver and the simulator.

Two fixed-length frames, little-endian, each ``SYNC`` + type + body + CRC::

    sensor  (board → host, 17 bytes): A5 5A 'S' seq status ch0 … ch4 crc16
    command (host → board,  7 bytes): A5 5A 'C' seq actions crc16

* ``seq`` counts frames per direction (u8, wrapping): a gap is a lost frame. It must advance:
  in serial-number arithmetic (RFC 1982) a step of 1…127 is forward (a step of k loses k − 1
  frames), 0 is the same frame again and 128…255 is backwards — such a frame is refused
  (counted as ``repeated_frames`` or ``out_of_order``; its values are not taken), so a link
  that replays old frames never passes for a live board.
* ``ch0 … ch4`` are int16 in thousandths: hip, knee, ankle angle (mrad), toe and heel load
  (‰ of the body weight). See :data:`CHANNELS`.
* ``actions`` = knee << 2 | ankle, each 2 bits: 00 hold (lock), 01 decrease, 10 increase,
  11 release — the cybernetic actuators' inputs (K1 K2, A1 A2).
* ``status`` = the actions the board applies (bits 0–3) | WATCHDOG (bit 4: it locked both
  joints because no command came in time); bits 5–7 are not defined (:data:`STATUS_FAULTS`:
  the bits that say the board is not under our command).
* ``crc16`` is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF; :func:`binascii.crc_hqx`) over
  type … body. Its Hamming distance of 4 at these lengths detects every error of up to three
  bits; a corrupted sync or type is not a frame at all.

:class:`Decoder` finds frames of one type in a byte stream: it skips bytes until a sync,
checks the type and the CRC, and on a bad frame drops one byte and looks again — so after
any garbage, the first intact frame is found (resynchronisation within one frame). It counts
frames, CRC errors, skipped bytes, sequence gaps and refused (repeated or backwards) frames,
and never raises on input.
"""
from __future__ import annotations

import binascii
import struct

import numpy as np

SYNC = b"\xa5\x5a"
SENSOR, COMMAND = 0x53, 0x43  # 'S', 'C'
CHANNELS = ("hip", "knee", "ankle", "toe", "heel")
SCALE = 1e-3  # one count = 1 mrad or 1 ‰ of the body weight
WATCHDOG = 0x10
ACTIONS_MASK = 0x0F  # the status bits that echo the actions applied
STATUS_FAULTS = 0xFF & ~ACTIONS_MASK  # the watchdog's lock, and bits no board may set
HOLD, DECREASE, INCREASE, RELEASE = 0, 1, 2, 3
ACTION_NAMES = ("hold", "decrease", "increase", "release")

_SENSOR_BODY = struct.Struct(f"<BBB{len(CHANNELS)}h")  # type, seq, status, channels
_COMMAND_BODY = struct.Struct("<BBB")  # type, seq, actions
_CRC = struct.Struct("<H")
SENSOR_LENGTH = len(SYNC) + _SENSOR_BODY.size + _CRC.size
COMMAND_LENGTH = len(SYNC) + _COMMAND_BODY.size + _CRC.size
_LIMIT = 32767


def crc16(data) -> int:
    return binascii.crc_hqx(data, 0xFFFF)


def pack_actions(knee: int, ankle: int) -> int:
    if not (0 <= knee <= 3 and 0 <= ankle <= 3):
        raise ValueError(f"actions are 2-bit codes, got knee={knee}, ankle={ankle}")
    return knee << 2 | ankle


def unpack_actions(actions: int) -> tuple[int, int]:
    return actions >> 2 & 3, actions & 3


def encode_command(seq: int, knee: int, ankle: int, out: bytearray | None = None) -> bytearray:
    """A command frame (into ``out`` of COMMAND_LENGTH bytes if given: no allocation)."""
    frame = out if out is not None else bytearray(COMMAND_LENGTH)
    if len(frame) != COMMAND_LENGTH:
        raise ValueError(f"a command frame is {COMMAND_LENGTH} bytes")
    frame[0:2] = SYNC
    _COMMAND_BODY.pack_into(frame, 2, COMMAND, seq & 0xFF, pack_actions(knee, ankle))
    _CRC.pack_into(frame, COMMAND_LENGTH - 2, crc16(memoryview(frame)[2:COMMAND_LENGTH - 2]))
    return frame


def encode_sensor(seq: int, status: int, channels) -> bytearray:
    """A sensor frame; channel values in SI (rad, fraction of body weight), clipped to int16."""
    values = np.asarray(channels, dtype=float)
    if values.shape != (len(CHANNELS),) or not np.all(np.isfinite(values)):
        raise ValueError(f"{len(CHANNELS)} finite channel values expected, got {channels!r}")
    counts = np.clip(np.rint(values / SCALE), -_LIMIT, _LIMIT).astype(int)
    frame = bytearray(SENSOR_LENGTH)
    frame[0:2] = SYNC
    _SENSOR_BODY.pack_into(frame, 2, SENSOR, seq & 0xFF, status & 0xFF, *counts.tolist())
    _CRC.pack_into(frame, SENSOR_LENGTH - 2, crc16(memoryview(frame)[2:SENSOR_LENGTH - 2]))
    return frame


class Decoder:
    """Frames of one type (SENSOR or COMMAND) out of a byte stream; see the module doc.

    After :meth:`feed`, ``frames`` says how many valid frames it held; the newest one's fields
    are in ``seq``, ``status`` and ``channels`` (sensor) or ``actions`` (command). Between
    feeds it keeps at most one frame's beginning (fewer bytes than a frame), however much
    garbage arrives."""

    def __init__(self, kind: int):
        if kind not in (SENSOR, COMMAND):
            raise ValueError("kind must be SENSOR or COMMAND")
        self.kind = kind
        self.length = SENSOR_LENGTH if kind == SENSOR else COMMAND_LENGTH
        self._body = _SENSOR_BODY if kind == SENSOR else _COMMAND_BODY
        self._buf = bytearray()
        self.channels = np.zeros(len(CHANNELS))
        self.seq = -1
        self.status = 0
        self.actions = 0
        self.counters = {"frames": 0, "crc_errors": 0, "skipped_bytes": 0, "lost_frames": 0, "repeated_frames": 0,
                         "out_of_order": 0}

    def feed(self, data) -> int:
        """Add bytes; return how many valid new frames they completed (refused ones not counted)."""
        buf = self._buf
        buf += data
        found = 0
        start = 0
        n = len(buf)
        while True:
            i = buf.find(SYNC, start)
            if i < 0:
                keep = n - 1 if n and buf[-1] == SYNC[0] else n  # a trailing A5 may begin a sync
                self.counters["skipped_bytes"] += keep - start if keep > start else 0
                start = max(start, keep)
                break
            self.counters["skipped_bytes"] += i - start
            if n - i < self.length:
                start = i
                break
            end = i + self.length
            if buf[i + 2] == self.kind and crc16(memoryview(buf)[i + 2:end - 2]) == _CRC.unpack_from(buf, end - 2)[0]:
                found += self._accept(buf, i + 2)
                start = end
            else:
                if buf[i + 2] == self.kind:
                    self.counters["crc_errors"] += 1
                self.counters["skipped_bytes"] += 1
                start = i + 1  # not a frame here: look for the next sync from the next byte
        del buf[:start]
        return found

    def _accept(self, buf, at: int) -> bool:
        """Take an intact frame if its sequence number advances; False (counted) when it does not."""
        fields = self._body.unpack_from(buf, at)
        seq = fields[1]
        if self.seq >= 0:
            step = (seq - self.seq) & 0xFF
            if step == 0:
                self.counters["repeated_frames"] += 1
                return False
            if step >= 0x80:
                self.counters["out_of_order"] += 1
                return False
            self.counters["lost_frames"] += step - 1
        self.seq = seq
        self.counters["frames"] += 1
        if self.kind == SENSOR:
            self.status = fields[2]
            for k, v in enumerate(fields[3:]):
                self.channels[k] = v * SCALE
        else:
            self.actions = fields[2]
        return True
