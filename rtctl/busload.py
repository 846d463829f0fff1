"""CAN bus load: the budget every bus must fit at the loop rate (docs/can_joints.md).

Pure arithmetic on frame sizes, so ``rtctl check`` can print it without importing any driver.
A standard (11-bit) classic CAN frame with n data bytes occupies at worst, with every possible
stuff bit, ``8n + 47 + ⌊(34 + 8n − 1)/4⌋`` bits: 47 bits of framing (SOF, id, control, CRC,
delimiters, ACK, EOF, intermission), 34 + 8n of them subject to stuffing (one stuff bit per 4
after the first).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from rtctl.errors import BusLoadError

DEFAULT_LIMIT = 0.8


def frame_bits(n_data: int) -> int:
    """Worst-case stuffed length in bits of a standard classic CAN frame with n data bytes."""
    if not 0 <= n_data <= 8:
        raise ValueError(f"classic CAN carries 0..8 data bytes, not {n_data}")
    return 8 * n_data + 47 + (34 + 8 * n_data - 1) // 4


@dataclass(frozen=True)
class ProtocolFrames:
    """Data bytes of the frames one joint costs per tick, plus those the bus costs once per tick."""

    per_joint: tuple[int, ...]
    per_bus: tuple[int, ...] = ()

    def bits_per_tick(self, joints: int) -> int:
        return joints * sum(map(frame_bits, self.per_joint)) + sum(map(frame_bits, self.per_bus))


PROTOCOLS = {
    # one 8-byte command and one reply per joint per tick (6 bytes; 8 for the temperature/error variants)
    "mit": ProtocolFrames(per_joint=(8, 6)),
    "mit8": ProtocolFrames(per_joint=(8, 8)),
    # CiA 402 CST, the shipped EDS's PDO set: RPDO1 (controlword + torque, 4 B), TPDO1 (statusword +
    # position + torque, 8 B), TPDO2 (velocity, 4 B) per joint, one SYNC (0 B) per bus; a drive
    # whose EDS maps them otherwise brings its own frames (bus_load's ``frames``)
    "cia402": ProtocolFrames(per_joint=(4, 8, 4), per_bus=(0,)),
}


@dataclass(frozen=True)
class BusLoad:
    """Load of one bus at one loop rate; ``load`` is a fraction (1.0 = the bus is full)."""

    bus: str
    protocol: str
    joints: int
    rate_hz: float
    bitrate: int
    bits_per_tick: int
    frames: ProtocolFrames

    @property
    def bits_per_second(self) -> float:
        return self.bits_per_tick * self.rate_hz

    @property
    def load(self) -> float:
        return self.bits_per_second / self.bitrate

    @property
    def time_per_tick_s(self) -> float:
        """Bus time the tick's frames occupy (at worst)."""
        return self.bits_per_tick / self.bitrate

    def max_rate_hz(self, limit: float = DEFAULT_LIMIT) -> float:
        return limit * self.bitrate / self.bits_per_tick

    def max_joints(self, limit: float = DEFAULT_LIMIT) -> int:
        """Most joints of this protocol one such bus carries at this rate within the limit."""
        frames = self.frames
        per_bus = frames.bits_per_tick(0)
        per_joint = frames.bits_per_tick(1) - per_bus
        return max(0, math.floor((limit * self.bitrate / self.rate_hz - per_bus) / per_joint))

    def describe(self) -> str:
        return (
            f"bus {self.bus!r}: {self.joints} {self.protocol} joint(s) × {self.rate_hz:g} Hz = "
            f"{self.bits_per_tick} bits/tick = {self.bits_per_second / 1e3:g} kbit/s on "
            f"{self.bitrate / 1e3:g} kbit/s: {100 * self.load:.0f} %"
        )


def bus_load(bus: str, protocol: str, joints: int, rate_hz: float, bitrate: int,
             frames: ProtocolFrames | None = None) -> BusLoad:
    """The worst-case load of ``joints`` joints speaking ``protocol`` (a key of PROTOCOLS), or
    exchanging ``frames`` when given (a configured PDO set)."""
    if frames is None:
        if protocol not in PROTOCOLS:
            raise ValueError(f"unknown protocol {protocol!r}; known: {', '.join(PROTOCOLS)}")
        frames = PROTOCOLS[protocol]
    if rate_hz <= 0 or bitrate <= 0 or joints < 0:
        raise ValueError("rate and bitrate must be positive, joints non-negative")
    return BusLoad(bus, protocol, joints, float(rate_hz), int(bitrate), frames.bits_per_tick(joints), frames)


def check_bus_load(load: BusLoad, file, key_path: str, limit: float = DEFAULT_LIMIT) -> BusLoad:
    """Return ``load`` if it is within ``limit``; otherwise raise BusLoadError naming the numbers
    and the ways out."""
    if load.load <= limit:
        return load
    per_bus = load.max_joints(limit)
    ways = [f"lower the loop rate to ≤ {math.floor(load.max_rate_hz(limit)):d} Hz"]
    if per_bus >= 1 and load.joints > 1:
        buses = math.ceil(load.joints / per_bus)
        ways.append(f"split the joints over {buses} buses (≤ {per_bus} per bus at {load.rate_hz:g} Hz)")
    ways.append("or use CAN FD where the drives support it")
    raise BusLoadError(
        file,
        key_path,
        f"a bus load ≤ {100 * limit:.0f} %, but {load.describe()}; " + ", ".join(ways),
    )


def format_budget(loads, limit: float = DEFAULT_LIMIT) -> str:
    """The table ``rtctl check`` prints: one line per bus."""
    rows = [f"{'bus':<12} {'protocol':<8} {'joints':>6} {'rate Hz':>8} {'kbit/s':>8} {'µs/tick':>8} {'load':>6}"]
    for b in loads:
        flag = "" if b.load <= limit else f"  > {100 * limit:.0f} % limit"
        rows.append(
            f"{b.bus:<12} {b.protocol:<8} {b.joints:>6} {b.rate_hz:>8g} {b.bitrate / 1e3:>8g} "
            f"{1e6 * b.time_per_tick_s:>8.0f} {100 * b.load:>5.0f}%{flag}"
        )
    return "\n".join(rows)
