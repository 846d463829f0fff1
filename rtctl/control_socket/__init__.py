"""The control socket (docs/architecture.md, docs/operations.md): a Unix-domain socket, mode 0600, speaking msgpack.

Wire format, both directions: every message is a 4-byte big-endian unsigned length ``N``
followed by ``N`` bytes of msgpack encoding one map. A request is ``{"cmd": ..., **fields}``
(see :mod:`rtctl.control_socket.requests` for the commands and their fields); a reply is
``{"ok": True, ...}`` or ``{"ok": False, "error": "..."}``. Requests above 64 KiB, truncated
frames, malformed msgpack, unknown commands and wrong fields get an error reply and change
nothing. A connection may carry several requests in sequence.

The daemon serves it with :class:`ControlServer` (``poll()`` once per tick, in the loop
thread); scripts and the CLI call :func:`request`.
"""
from rtctl.control_socket.client import request
from rtctl.control_socket.requests import COMMANDS, MAX_REQUEST_BYTES
from rtctl.control_socket.server import ControlServer

__all__ = ["COMMANDS", "MAX_REQUEST_BYTES", "ControlServer", "request"]
