"""Defect 1: idle or slow clients must never lock `estop`/`stop` out of the control socket."""
from __future__ import annotations

import time

import pytest

from polled_server import PolledServer, connect
from rtctl.control_socket import ControlServer, request

pytestmark = pytest.mark.realtime  # (tests/conftest.py)


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
    socks = [connect(path) for _ in range(n)]
    for s in socks:
        if first_bytes:
            s.sendall(first_bytes)
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
            reply = request(path, cmd, timeout=2.0)  # the old server refused it for 60 s
            assert reply == {"ok": True}, (kind, reply)
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
