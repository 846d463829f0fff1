"""Length-prefixed msgpack frames: 4-byte big-endian length, then that many bytes of msgpack."""
from __future__ import annotations

import struct
import sys
from pathlib import PurePath

import msgpack

HEADER = struct.Struct(">I")


def _to_builtin(obj):
    """msgpack ``default``: numpy arrays and scalars and paths become plain values (numpy
    is not imported for it: a client that never loaded it has no numpy value to send)."""
    np = sys.modules.get("numpy")
    if np is not None and isinstance(obj, np.ndarray):
        return obj.tolist()
    if np is not None and isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, PurePath):
        return str(obj)
    raise TypeError(f"cannot encode {type(obj).__name__} in a control-socket message")


def encode(message: dict) -> bytes:
    body = msgpack.packb(message, default=_to_builtin)
    return HEADER.pack(len(body)) + body


def decode(body: bytes):
    """The msgpack value of one frame's body; raises ValueError with the reason if malformed."""
    try:
        return msgpack.unpackb(body, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises ExtraData, FormatError, StackError, ValueError, ...
        raise ValueError(f"malformed msgpack ({type(exc).__name__}: {exc})") from exc
