"""Defect 1: idle or slow clients must never lock `estop`/`stop` out of the control socket."""
from __future__ import annotations

import socket
import threading
import time

import pytest

from rtctl.control_socket import ControlServer, request


class PolledServer:
    """A ControlServer polled every millisecond from a thread standing in for the loop."""

    def __init__(self, path, **kwargs):
        self.calls = []
        self.server = ControlServer(path, self._handle, n_joints=6, **kwargs)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _handle(self, req):
        self.calls.append(req["cmd"])
        return {}

    def _run(self):
        while not self._stop.is_set():
            self.server.poll()
            time.sleep(0.001)

    def close(self):
        self._stop.set()
        self._thread.join()
        self.server.close()


@pytest.fixture
def served(tmp_path):
    servers = []

    def start(**kwargs):
        s = PolledServer(str(tmp_path / "ctl.sock"), **kwargs)
        servers.append(s)
        return s

    yield start
    for s in servers:
        s.close()


def _connections(path, n, first_bytes=b""):
    socks = []
    for _ in range(n):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(5)
        while True:
            try:
                s.connect(path)
                break
            except BlockingIOError:  # the accept queue is full until the next poll
                time.sleep(0.001)
        if first_bytes:
            s.sendall(first_bytes)
        socks.append(s)
    return socks


@pytest.mark.parametrize("kind, first_bytes", [("idle", b""), ("slow, mid-frame", b"\x00\x00")])
def test_defect_01_idle_clients_do_not_lock_out_estop(served, kind, first_bytes):
    """Held connections filling every slot (the old server refused the 9th with "too many
    control connections (max 8)" for 60 s): estop and stop still get through at once."""
    srv = served()
    path = srv.server.path
    hogs = _connections(path, srv.server.max_clients + 2, first_bytes)
    try:
        time.sleep(0.05)  # every hog accepted
        for cmd in ("estop", "stop"):
            t0 = time.monotonic()
            reply = request(path, cmd, timeout=2.0)
            assert reply == {"ok": True}, (kind, reply)
            assert time.monotonic() - t0 < 1.0
        assert srv.calls == ["estop", "stop"]
    finally:
        for s in hogs:
            s.close()


def test_defect_01_idle_connections_time_out_quickly(served):
    srv = served(idle_timeout=0.2)
    path = srv.server.path
    (idle,) = _connections(path, 1)
    try:
        time.sleep(0.6)
        assert idle.recv(1) == b""  # the server closed it
    finally:
        idle.close()
    assert srv.server.idle_timeout <= 5.0 and ControlServer.__init__.__kwdefaults__["idle_timeout"] <= 5.0
