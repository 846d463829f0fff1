"""request(): one request to a running daemon over its control socket, one reply back."""
from __future__ import annotations

import os
import socket
import time

from rtctl.control_socket.framing import HEADER, decode, encode
from rtctl.errors import ControlSocketError


def default_socket_path():
    """``$XDG_RUNTIME_DIR/rtctl.sock``, or ``/tmp/rtctl-UID.sock`` without XDG_RUNTIME_DIR."""
    from pathlib import Path

    runtime = os.environ.get("XDG_RUNTIME_DIR")
    return Path(runtime, "rtctl.sock") if runtime else Path(f"/tmp/rtctl-{os.getuid()}.sock")


def _recv_exactly(sock: socket.socket, n: int, path: str) -> bytes:
    data = bytearray()
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ControlSocketError(f"the daemon on {path} closed the connection without a complete reply")
        data += chunk
    return bytes(data)


def _connect(sock: socket.socket, path: str, deadline: float) -> None:
    """connect(), retried while the daemon's accept queue is full (EAGAIN: a connection
    storm; the daemon drains it every tick) until ``deadline``."""
    while True:
        try:
            sock.connect(path)
            return
        except BlockingIOError:
            if time.monotonic() >= deadline:
                raise socket.timeout("the daemon's connection queue stayed full") from None
            time.sleep(0.002)


def request(path, cmd: str, *, timeout: float = 5.0, **fields) -> dict:
    """Send ``{"cmd": cmd, **fields}`` and return the reply map (check ``reply["ok"]``).

    numpy arrays in ``fields`` are sent as lists. Raises :class:`ControlSocketError` when
    no daemon answers (socket missing, connection refused, timeout) or the reply is garbled;
    a daemon's refusal is not an exception but ``{"ok": False, "error": ...}``.
    """
    path = os.fspath(path)
    try:
        frame = encode({"cmd": cmd, **fields})
    except (TypeError, ValueError) as exc:
        raise ControlSocketError(f"cannot encode the {cmd!r} request: {exc}") from exc
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(timeout)
    try:
        try:
            _connect(sock, path, time.monotonic() + timeout)
        except FileNotFoundError:
            raise ControlSocketError(f"no rtctl daemon: control socket {path} does not exist "
                                     "(is `rtctl run` running, with this --socket?)") from None
        except ConnectionRefusedError:
            raise ControlSocketError(f"no rtctl daemon listening on {path} (stale socket file: "
                                     "the daemon exited without removing it)") from None
        except PermissionError:
            raise ControlSocketError(f"permission denied on {path}: the socket is mode 0600, "
                                     "run as the daemon's user") from None
        except socket.timeout:
            raise ControlSocketError(f"the daemon on {path} did not accept a connection within {timeout:g} s") from None
        except OSError as exc:
            raise ControlSocketError(f"cannot connect to control socket {path}: {exc}") from None
        try:
            sock.sendall(frame)
            (length,) = HEADER.unpack(_recv_exactly(sock, HEADER.size, path))
            reply = decode(_recv_exactly(sock, length, path))
        except socket.timeout:
            raise ControlSocketError(f"the daemon on {path} did not answer {cmd!r} within {timeout:g} s") from None
        except ValueError as exc:
            raise ControlSocketError(f"garbled reply from {path}: {exc}") from None
        except OSError as exc:
            raise ControlSocketError(f"control socket {path}: {exc}") from None
    finally:
        sock.close()
    if not isinstance(reply, dict) or not isinstance(reply.get("ok"), bool):
        raise ControlSocketError(f"garbled reply from {path}: expected a map with 'ok', got {reply!r}")
    return reply
