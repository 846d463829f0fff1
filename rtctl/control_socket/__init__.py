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
from importlib import import_module

# imported on first use (PEP 562): the clients (`rtctl estop`) need neither the server nor numpy
_HOME = {"request": "client", "default_socket_path": "client", "COMMANDS": "requests",
         "MAX_REQUEST_BYTES": "requests", "ControlServer": "server"}
__all__ = list(_HOME)


def __getattr__(name):
    if name not in _HOME:
        raise AttributeError(f"module 'rtctl.control_socket' has no attribute {name!r}")
    return getattr(import_module(f"rtctl.control_socket.{_HOME[name]}"), name)
