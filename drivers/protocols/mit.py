"""MIT "mini-cheetah" joint-drive protocol: pure bytes ↔ values, shared by the CAN driver and
the emulated drives in ``hil_sim`` (docs/can_joints.md).

Command (standard 11-bit id = the drive's id, 8 bytes, big-endian bit fields)::

    b0=p[15:8] b1=p[7:0] b2=v[11:4] b3=v[3:0]<<4|kp[11:8] b4=kp[7:0] b5=kd[11:4] b6=kd[3:0]<<4|t[11:8] b7=t[7:0]

Reply (on the master id, the joint in b0)::

    b0=id b1=p[15:8] b2=p[7:0] b3=v[11:4] b4=v[3:0]<<4|i[11:8] b5=i[7:0] [b6 b7: see ReplyFormat]

Quantisation is the firmware's: clamp to [x_min, x_max], then
``x_int = int((x − x_min)·(2^bits − 1)/(x_max − x_min))`` (truncation, in that order of
operations so that full scale maps to exactly 2^bits − 1); decoding is
``x = x_int·(x_max − x_min)/(2^bits − 1) + x_min``. Non-finite values raise ``ValueError``.

Special frames ``FF FF FF FF FF FF FF xx`` (``Special``) switch the drive's mode. A real command
collides with that prefix only when p, v, kp and kd are all at full scale and t is in the top
1/16 of its range; the packer then emits ``p_int = 0xFFFE`` instead of ``0xFFFF`` (one position
LSB, 0.38 mrad with the default range, and only for a position already saturated at p_max),
so no command ever reads as a mode switch.

Hot path: :func:`pack_command_into` writes into a caller-owned buffer (e.g. a reused
``can.Message.data``) and :func:`unpack_reply_into` into a preallocated array row.
"""
from __future__ import annotations

import dataclasses
import enum
import math
import struct
from dataclasses import dataclass
from typing import NamedTuple

from rtctl.errors import ProtocolError

COMMAND_LENGTH = 8
_U64 = struct.Struct(">Q")  # a command is one big-endian 64-bit word
_U16_U32 = struct.Struct(">HI")  # the common six reply bytes
SPECIAL_PREFIX = b"\xff" * 7
DEFAULT_MASTER_ID = 0x000

# Columns of the array unpack_reply_into fills.
REPLY_POSITION, REPLY_VELOCITY, REPLY_EFFORT, REPLY_TEMPERATURE, REPLY_ERROR = range(5)
REPLY_COLUMNS = 5


class Special(enum.IntEnum):
    """Last byte of a special frame; each is answered with a normal reply."""

    ENTER_MOTOR_MODE = 0xFC
    EXIT_MOTOR_MODE = 0xFD
    SET_ZERO = 0xFE
    CLEAR_ERROR = 0xFB  # Damiao


class ReplyFormat(enum.Enum):
    """Layout of the reply's bytes beyond the common six."""

    KATZ = "katz"  # 6 bytes (Ben Katz's firmware, AK80-9 and most clones)
    CUBEMARS = "cubemars"  # 8 bytes: b6 = temperature (°C, int8), b7 = error code (AK10-9 V1.1 …)
    DAMIAO = "damiao"  # 8 bytes: b0 = id | state << 4 (0 disabled, 1 enabled, else an error), b6 = MOS °C, b7 = rotor °C


REPLY_LENGTH = {ReplyFormat.KATZ: 6, ReplyFormat.CUBEMARS: 8, ReplyFormat.DAMIAO: 8}


@dataclass(frozen=True)
class MitDriveModel:
    """Field ranges and reply layout of one drive model (each range is ``(min, max)``).

    ``effort`` is the reply's third field: torque on Katz and Damiao firmware, phase current
    on others; ``effort × torque_constant`` is the joint torque in N·m.
    """

    name: str = "katz"
    p: tuple[float, float] = (-12.5, 12.5)  # rad
    v: tuple[float, float] = (-65.0, 65.0)  # rad/s
    kp: tuple[float, float] = (0.0, 500.0)  # N·m/rad
    kd: tuple[float, float] = (0.0, 5.0)  # N·m·s/rad
    t: tuple[float, float] = (-18.0, 18.0)  # N·m
    effort: tuple[float, float] = (-18.0, 18.0)
    reply_format: ReplyFormat = ReplyFormat.KATZ
    torque_constant: float = 1.0

    def __post_init__(self):
        for field in ("p", "v", "kp", "kd", "t", "effort"):
            lo, hi = getattr(self, field)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"{self.name}: {field} range must be finite with min < max, got {(lo, hi)}")
        if not (math.isfinite(self.torque_constant) and self.torque_constant > 0):
            raise ValueError(f"{self.name}: torque_constant must be positive")
        # (min, max, span) per field, unpacked in one go on the hot path
        q = tuple((lo, hi, hi - lo) for lo, hi in (self.p, self.v, self.kp, self.kd, self.t, self.effort))
        object.__setattr__(self, "_q", q)

    @property
    def reply_length(self) -> int:
        return REPLY_LENGTH[self.reply_format]


KATZ = MitDriveModel()
DRIVE_MODELS = {
    "katz": KATZ,
    "ak80-9": MitDriveModel(name="ak80-9", v=(-25.64, 25.64)),
    "dm4310": MitDriveModel(
        name="dm4310", v=(-30.0, 30.0), t=(-10.0, 10.0), effort=(-10.0, 10.0), reply_format=ReplyFormat.DAMIAO
    ),
}


def drive_model_from_table(table) -> MitDriveModel:
    """Read a drive model from a :class:`rtctl.tomltable.Table`: ``drive_model = "dm4310"`` (a
    key of :data:`DRIVE_MODELS`, default "katz") and optional overrides ``p_range``,
    ``v_range``, ``kp_range``, ``kd_range``, ``t_range``, ``effort_range`` (``[min, max]``),
    ``reply_format`` and ``torque_constant``. Reads only these keys (the caller calls ``done()``)."""
    base = DRIVE_MODELS[table.str("drive_model", "katz", choices=tuple(DRIVE_MODELS))]
    changes = {}
    for field in ("p", "v", "kp", "kd", "t", "effort"):
        key = f"{field}_range"
        rng = table.vector(key, 2, default=None)
        if rng is not None:
            if not rng[0] < rng[1]:
                raise table.error(key, f"[min, max] with min < max, got {list(rng)}")
            changes[field] = (float(rng[0]), float(rng[1]))
    if "t" in changes and "effort" not in changes and base.effort == base.t:
        changes["effort"] = changes["t"]  # the reply reports torque on the same scale
    fmt = table.str("reply_format", base.reply_format.value, choices=tuple(f.value for f in ReplyFormat))
    changes["reply_format"] = ReplyFormat(fmt)
    changes["torque_constant"] = table.float("torque_constant", base.torque_constant, positive=True)
    return dataclasses.replace(base, **changes)


# -- commands -----------------------------------------------------------------------------
class MitCommand(NamedTuple):
    p: float
    v: float
    kp: float
    kd: float
    t: float


def pack_command_into(buf, model: MitDriveModel, p: float, v: float, kp: float, kd: float, t: float) -> None:
    """Write the 8-byte command into ``buf[0:8]`` (bytearray, memoryview, uint8 array)."""
    # the firmware's float_to_uint, inlined (this runs per joint per tick): clamp, then truncate
    (plo, phi, psp), (vlo, vhi, vsp), (kplo, kphi, kpsp), (kdlo, kdhi, kdsp), (tlo, thi, tsp), _ = model._q
    p_int = int(((plo if p < plo else (phi if p > phi else p)) - plo) * 65535 / psp)
    v_int = int(((vlo if v < vlo else (vhi if v > vhi else v)) - vlo) * 4095 / vsp)
    kp_int = int(((kplo if kp < kplo else (kphi if kp > kphi else kp)) - kplo) * 4095 / kpsp)
    kd_int = int(((kdlo if kd < kdlo else (kdhi if kd > kdhi else kd)) - kdlo) * 4095 / kdsp)
    t_int = int(((tlo if t < tlo else (thi if t > thi else t)) - tlo) * 4095 / tsp)
    word = (p_int << 48) | (v_int << 36) | (kp_int << 24) | (kd_int << 12) | t_int
    if word >> 8 == 0xFF_FFFF_FFFF_FFFF:
        word -= 1 << 48  # p_int 0xFFFF → 0xFFFE: b0..b6 would all be FF, a special frame
    _U64.pack_into(buf, 0, word)


def pack_command(model: MitDriveModel, p: float, v: float, kp: float, kd: float, t: float) -> bytes:
    buf = bytearray(COMMAND_LENGTH)
    pack_command_into(buf, model, p, v, kp, kd, t)
    return bytes(buf)


def command_ints(data) -> tuple[int, int, int, int, int]:
    """The five raw fields (p, v, kp, kd, t) of a command frame."""
    (w,) = _U64.unpack_from(data)
    return w >> 48, (w >> 36) & 0xFFF, (w >> 24) & 0xFFF, (w >> 12) & 0xFFF, w & 0xFFF


def unpack_command(data, model: MitDriveModel) -> MitCommand:
    """Decode a command (drive side). Raises ProtocolError on a wrong length or a special frame."""
    if len(data) != COMMAND_LENGTH:
        raise ProtocolError(f"MIT command: expected {COMMAND_LENGTH} bytes, got {len(data)}")
    if data[:7] == SPECIAL_PREFIX:
        raise ProtocolError(f"MIT command: {bytes(data).hex(' ')} is a special frame")
    (plo, _, psp), (vlo, _, vsp), (kplo, _, kpsp), (kdlo, _, kdsp), (tlo, _, tsp), _ = model._q
    (w,) = _U64.unpack_from(data)
    return MitCommand(
        (w >> 48) * psp / 65535 + plo,
        ((w >> 36) & 0xFFF) * vsp / 4095 + vlo,
        ((w >> 24) & 0xFFF) * kpsp / 4095 + kplo,
        ((w >> 12) & 0xFFF) * kdsp / 4095 + kdlo,
        (w & 0xFFF) * tsp / 4095 + tlo,
    )


# -- special frames -----------------------------------------------------------------------
def special_frame(kind: Special) -> bytes:
    return SPECIAL_PREFIX + bytes((int(kind),))


def special_kind(data) -> Special | None:
    """The special frame ``data`` is, or None for anything else (including unknown ``FF…FF xx``)."""
    if len(data) != COMMAND_LENGTH or data[:7] != SPECIAL_PREFIX:
        return None
    try:
        return Special(data[7])
    except ValueError:
        return None


def is_special_prefix(data) -> bool:
    """True for any ``FF FF FF FF FF FF FF xx`` frame, known or not."""
    return len(data) == COMMAND_LENGTH and data[:7] == SPECIAL_PREFIX


# -- replies ------------------------------------------------------------------------------
class MitReply(NamedTuple):
    drive_id: int
    position: float
    velocity: float
    effort: float
    temperature: float  # °C; NaN when the format has none
    error: int  # 0 = no error


def pack_reply_into(
    buf,
    model: MitDriveModel,
    drive_id: int,
    p: float,
    v: float,
    effort: float,
    temperature: float = 25.0,
    error: int = 0,
    enabled: bool = True,
) -> int:
    """Write a reply (drive side) into ``buf``; returns its length (6 or 8)."""
    (plo, phi, psp), (vlo, vhi, vsp), _, _, _, (elo, ehi, esp) = model._q
    p_int = int(((plo if p < plo else (phi if p > phi else p)) - plo) * 65535 / psp)
    v_int = int(((vlo if v < vlo else (vhi if v > vhi else v)) - vlo) * 4095 / vsp)
    i_int = int(((elo if effort < elo else (ehi if effort > ehi else effort)) - elo) * 4095 / esp)
    fmt = model.reply_format
    if fmt is ReplyFormat.DAMIAO:
        state = error if error else int(enabled)
        head = (drive_id & 0x0F) | ((state & 0x0F) << 4)
    else:
        head = drive_id & 0xFF
    word = (head << 40) | (p_int << 24) | (v_int << 12) | i_int  # b0..b5
    _U16_U32.pack_into(buf, 0, word >> 32, word & 0xFFFF_FFFF)
    if fmt is ReplyFormat.KATZ:
        return 6
    temp = max(-128, min(127, int(temperature))) if fmt is ReplyFormat.CUBEMARS else max(0, min(255, int(temperature)))
    if fmt is ReplyFormat.CUBEMARS:
        buf[6] = temp & 0xFF
        buf[7] = error & 0xFF
    else:
        buf[6] = temp  # MOS temperature: the emulation reports one temperature for both
        buf[7] = temp
    return 8


def pack_reply(model: MitDriveModel, drive_id: int, p: float, v: float, effort: float, **kw) -> bytes:
    buf = bytearray(8)
    n = pack_reply_into(buf, model, drive_id, p, v, effort, **kw)
    return bytes(buf[:n])


def reply_drive_id(data, model: MitDriveModel) -> int:
    """The joint a reply belongs to (master side); ProtocolError on a wrong length."""
    if len(data) != REPLY_LENGTH[model.reply_format]:
        raise ProtocolError(
            f"MIT reply ({model.reply_format.value}): expected {REPLY_LENGTH[model.reply_format]} bytes, got {len(data)}"
        )
    return data[0] & 0x0F if model.reply_format is ReplyFormat.DAMIAO else data[0]


def unpack_reply_into(data, model: MitDriveModel, out, row: int) -> None:
    """Decode a reply into ``out[row, 0:5]`` (columns ``REPLY_*``); call :func:`reply_drive_id`
    first, which checks the length and tells which row."""
    (plo, _, psp), (vlo, _, vsp), _, _, _, (elo, _, esp) = model._q
    hi, lo = _U16_U32.unpack_from(data)  # b0..b5
    r = out[row]
    r[REPLY_POSITION] = (((hi & 0xFF) << 8) | (lo >> 24)) * psp / 65535 + plo
    r[REPLY_VELOCITY] = ((lo >> 12) & 0xFFF) * vsp / 4095 + vlo
    r[REPLY_EFFORT] = (lo & 0xFFF) * esp / 4095 + elo
    fmt = model.reply_format
    if fmt is ReplyFormat.KATZ:
        r[REPLY_TEMPERATURE] = math.nan
        r[REPLY_ERROR] = 0
    elif fmt is ReplyFormat.CUBEMARS:
        r[REPLY_TEMPERATURE] = data[6] - 256 if data[6] > 127 else data[6]
        r[REPLY_ERROR] = data[7]
    else:
        state = data[0] >> 4
        r[REPLY_TEMPERATURE] = data[7]
        r[REPLY_ERROR] = state if state > 1 else 0  # 0/1: disabled/enabled; 8…14 errors, the rest undefined


def reply_says_motor_on(data, model: MitDriveModel) -> bool:
    """True when the reply says the drive's motor is on — only the Damiao format says (state 1
    in b0's high nibble; 0 is off, 8 and above an error, the motor off); False for the others."""
    return model.reply_format is ReplyFormat.DAMIAO and data[0] >> 4 == 1


def reply_half_steps(model: MitDriveModel) -> tuple[float, float, float]:
    """Half a step of the reply's position, velocity and effort fields: what a host adds to the
    firmware's decoding to get the centre of the interval the drive's value lay in.

    The drive truncates, so a code ``x_int`` stands for every value in
    ``[x_int, x_int + 1)·step + x_min``: decoded as the firmware does, the reading is low by half
    a step on average. That bias matters where a controller acts on its sign: with a symmetric
    velocity range a joint at rest truncates to ``2^11 − 1`` and reads −step/2 (−6.3 mrad/s on
    an AK80-9), which a Coulomb feed-forward ``tanh(q̇/v_c)`` turns into a steady push."""
    (_, _, psp), (_, _, vsp), _, _, _, (_, _, esp) = model._q
    return 0.5 * psp / 65535, 0.5 * vsp / 4095, 0.5 * esp / 4095


def unpack_reply(data, model: MitDriveModel) -> MitReply:
    """Allocating convenience form of :func:`reply_drive_id` + :func:`unpack_reply_into`."""
    drive_id = reply_drive_id(data, model)
    row = [[0.0] * REPLY_COLUMNS]
    unpack_reply_into(data, model, row, 0)
    p, v, e, temp, err = row[0]
    return MitReply(drive_id, p, v, e, temp, int(err))
