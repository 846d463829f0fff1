"""The live view: a running robot in Foxglove, on the channels of its MCAP export.

Opt-in: ``rtctl run CONFIG --live [[HOST:]PORT]`` or a ``[live]`` table (``host``, ``port``) in
the configuration. A process of its own (:mod:`rtctl.telemetry.live_server`) maps the shared
telemetry ring beside the writer, reads the rows the loop has committed every few ms and
serves them with ``foxglove-sdk`` (the optional extra ``live``). The loop never learns of it:
it writes no byte for it while running, reads no counter of it, never waits on it; a slow
viewer loses messages in the SDK's per-client queue, a slow live process skips rows.

Listens on loopback (127.0.0.1:8765) unless told otherwise. A port that cannot be had is a
configuration error (exit 2) found before any file is truncated or device touched.
"""
from __future__ import annotations

import errno
import importlib.util
import os
import select
import socket
import subprocess
from dataclasses import dataclass

from rtctl.errors import ConfigError, RtctlError
from rtctl.telemetry.schema import schema_to_wire
from rtctl.telemetry.ring_reader import close_message, spawn_ring_reader

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8765
READY_TIMEOUT_S = 30.0  # importing numpy and the SDK, binding the port
CLOSE_TIMEOUT_S = 5.0  # the last rows and the end of the run reach the viewers first
COMMAND_LINE = "<command line>"


@dataclass(frozen=True)
class LiveConfig:
    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT
    file: str = COMMAND_LINE  # where it was configured, for the errors: the file and its keys
    host_key: str = "--live"
    port_key: str = "--live"

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"


def from_table(t) -> LiveConfig | None:
    """The configuration's ``[live]`` table (None when absent: the live view is opt-in)."""
    if t is None:
        return None
    host = t.str("host", DEFAULT_HOST)
    if not host.strip():
        raise t.error("host", "a host name or address to listen on, e.g. 127.0.0.1 (loopback)")
    live = LiveConfig(host, t.int("port", DEFAULT_PORT, min=0, max=65535), str(t.file), t.key("host"),
                      t.key("port"))
    t.done()
    return live


def from_argument(value: str | None, configured: LiveConfig | None) -> LiveConfig | None:
    """``--live`` (``value`` ""), ``--live PORT`` or ``--live HOST:PORT`` over the ``[live]`` table."""
    if value is None:
        return configured
    if value == "":
        return configured or LiveConfig()
    host, _, port = value.rpartition(":")
    host = host.strip("[]") or (configured.host if configured else DEFAULT_HOST)
    if not port.isdigit() or int(port) > 65535:
        raise ConfigError(COMMAND_LINE, "--live", f"[HOST:]PORT with PORT in 0-65535, got {value!r}")
    return LiveConfig(host, int(port))


def check_port(live: LiveConfig) -> None:
    """ConfigError (exit 2) unless ``live.host:live.port`` can be listened on now, bound as the
    server binds it (SO_REUSEADDR): asked before anything is truncated or touched. RtctlError
    if foxglove-sdk is not installed."""
    if importlib.util.find_spec("foxglove") is None:
        raise RtctlError("the live view needs foxglove-sdk, the optional extra `live`: in the clone, "
                         ".venv/bin/pip install -e '.[live]'")
    try:
        family, kind, proto, _, address = socket.getaddrinfo(live.host, live.port, type=socket.SOCK_STREAM)[0]
    except socket.gaierror as e:
        raise ConfigError(live.file, live.host_key, f"a host name or address of this machine; "
                                                    f"{live.host!r}: {e.strerror}") from None
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as e:
            raise _bind_error(live, e.errno, e.strerror) from None


def _bind_error(live: LiveConfig, code, why: str) -> ConfigError:
    if code == errno.EADDRINUSE:
        return ConfigError(live.file, live.port_key, f"a free TCP port on {live.host}; {live.port} is in use "
                                                     "(another rtctl run --live, or another program)")
    if code == errno.EACCES:
        return ConfigError(live.file, live.port_key, f"a port this user may listen on; {live.port}: {why}")
    return ConfigError(live.file, live.host_key, f"an address of this machine to listen on; {live.host}: {why}")


class LiveView:
    """The live view's process, attached to ``recorder``'s ring: started by :meth:`start`, told
    the run's summary and waited for by :meth:`close`."""

    def __init__(self, proc: subprocess.Popen, pipe_fd: int, live: LiveConfig, port: int):
        self._proc, self._pipe_fd = proc, pipe_fd
        self.live = live
        self.port = port  # the one it listens on (``port = 0`` picks a free one)
        self._closed = False

    @property
    def url(self) -> str:
        return LiveConfig(self.live.host, self.port).url

    @classmethod
    def start(cls, recorder, live: LiveConfig) -> "LiveView":
        """Start serving the rows of ``recorder``; ConfigError (exit 2) if the port cannot be had."""
        command_r, command_w = os.pipe()
        status_r, status_w = os.pipe()
        config = {"schema": schema_to_wire(recorder.schema), "block_rows": recorder.block_rows,
                  "n_blocks": recorder.n_blocks, "ring_fd": recorder.ring_fd, "pipe_fd": command_r,
                  "status_fd": status_w, "host": live.host, "port": live.port, "meta": recorder.meta}
        try:
            proc = spawn_ring_reader("rtctl.telemetry.live_server", config, (recorder.ring_fd, command_r, status_w))
        except OSError as e:
            for fd in (command_w, status_r):
                os.close(fd)
            raise RtctlError(f"cannot start the live view's process: {e}") from e
        finally:
            os.close(command_r)
            os.close(status_w)
        try:
            status = _read_status(status_r)
        finally:
            os.close(status_r)
        if not status.startswith("ok "):
            os.close(command_w)
            _stop(proc)
            code, _, why = status.removeprefix("error ").partition(" ") if status.startswith("error ") else ("", "", status)
            if code.isdigit():
                raise _bind_error(live, int(code), why)
            raise RtctlError(f"the live view did not start: {why or 'its process exited'}")
        return cls(proc, command_w, live, int(status.split()[1]))

    def close(self, summary=None) -> None:
        """Hand the live view the run's summary (the end events) and wait for it; safe twice."""
        if self._closed:
            return
        self._closed = True
        try:
            os.write(self._pipe_fd, close_message(summary))
        except BrokenPipeError:
            pass  # it is gone already: nothing to wait for
        finally:
            os.close(self._pipe_fd)
        _stop(self._proc, CLOSE_TIMEOUT_S)


def _read_status(fd: int) -> str:
    """The live process's first line: ``ok PORT`` or ``error ERRNO TEXT`` ("" if it died first)."""
    data = b""
    while not data.endswith(b"\n"):
        if not select.select([fd], [], [], READY_TIMEOUT_S)[0]:
            return f"no answer within {READY_TIMEOUT_S:g} s"
        chunk = os.read(fd, 4096)
        if not chunk:
            break
        data += chunk
    return data.decode(errors="replace").strip()


def _stop(proc: subprocess.Popen, timeout: float = 0.0) -> None:
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
