"""Control socket: round trips, refusal of bad requests without side effects, permissions,
stale sockets, client errors. The server is polled from a thread standing in for the loop."""
import os
import socket
import stat
import struct
import threading
import time

import msgpack
import numpy as np
import pytest

from rtctl.control_socket import ControlServer, request
from rtctl.control_socket.connection import Deferred
from rtctl.errors import ControlSocketError, RtctlError

pytestmark = pytest.mark.realtime  # (tests/conftest.py)


class Loop:
    """Polls the server every millisecond, as the daemon's loop would, and logs handled requests."""

    def __init__(self, path, replies=None, **kwargs):
        self.calls = []
        self.replies = replies or {}
        self.server = ControlServer(path, self.handle, **kwargs)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def handle(self, req):
        self.calls.append(req)
        reply = self.replies.get(req["cmd"], {})
        if isinstance(reply, Exception):
            raise reply
        return reply

    def _run(self):
        while not self._stop.is_set():
            self.server.poll()
            time.sleep(0.001)

    def close(self):
        self._stop.set()
        self._thread.join()
        self.server.close()


@pytest.fixture
def sock_path(tmp_path):
    return str(tmp_path / "ctl.sock")


@pytest.fixture
def loop(sock_path):
    lp = Loop(sock_path, n_joints=6, request_timeout=0.3,
              replies={"status": {"state": "running", "ticks": np.int64(12), "q": np.arange(6.0)}})
    yield lp
    lp.close()


def raw_connect(path):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(5)
    s.connect(path)
    return s


def frame(body: bytes, length=None) -> bytes:
    return struct.pack(">I", len(body) if length is None else length) + body


def read_reply(s):
    header = b""
    while len(header) < 4:
        chunk = s.recv(4 - len(header))
        assert chunk, "server closed without replying"
        header += chunk
    (n,) = struct.unpack(">I", header)
    body = b""
    while len(body) < n:
        body += s.recv(n - len(body))
    return msgpack.unpackb(body)


def test_status_round_trip(loop, sock_path):
    reply = request(sock_path, "status")
    assert reply == {"ok": True, "state": "running", "ticks": 12, "q": [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]}
    assert loop.calls == [{"cmd": "status"}]


@pytest.mark.parametrize("cmd", ["stop", "estop", "reset"])
def test_plain_commands_reach_the_handler(loop, sock_path, cmd):
    assert request(sock_path, cmd) == {"ok": True}
    assert loop.calls == [{"cmd": cmd}]


def test_move_fields_arrive_as_arrays(loop, sock_path):
    assert request(sock_path, "move", q=np.linspace(0, 1, 6), duration=2)["ok"]
    assert request(sock_path, "move", waypoints=[[0] * 6, [1] * 6], times=[1.0, 2.5], deg=True)["ok"]
    first, second = loop.calls
    np.testing.assert_array_equal(first["q"], np.linspace(0, 1, 6))
    assert first["q"].dtype == np.float64 and first["duration"] == 2.0 and first["deg"] is False
    assert first["waypoints"] is None and first["times"] is None
    assert second["waypoints"].shape == (2, 6) and second["times"].tolist() == [1.0, 2.5] and second["deg"]


BAD_BODIES = [
    (b"\xc1", "malformed msgpack"),
    (msgpack.packb({"cmd": "status"}) + b"\x01", "malformed msgpack"),
    (msgpack.packb(["status"]), "expected a map"),
    (msgpack.packb({"cmd": "launch"}), "unknown cmd 'launch'"),
    (msgpack.packb({"command": "status"}), "unknown cmd None"),
    (msgpack.packb({1: "status"}), "malformed msgpack"),
    (msgpack.packb({"cmd": "status", "verbose": True}), "unknown field(s) verbose; allowed: none"),
    (msgpack.packb({"cmd": "move"}), "exactly one of 'q'"),
    (msgpack.packb({"cmd": "move", "q": [0] * 6, "waypoints": [[0] * 6]}), "exactly one of 'q'"),
    (msgpack.packb({"cmd": "move", "q": [0] * 5}), "expected 6 joint positions, got 5"),
    (msgpack.packb({"cmd": "move", "q": [0, 0, float("nan"), 0, 0, 0]}), "move.q[2]: expected a finite number"),
    (msgpack.packb({"cmd": "move", "q": [0, 0, True, 0, 0, 0]}), "move.q[2]"),
    (msgpack.packb({"cmd": "move", "q": "home"}), "non-empty list"),
    (msgpack.packb({"cmd": "move", "q": [0] * 6, "duration": -1}), "expected > 0 s"),
    (msgpack.packb({"cmd": "move", "q": [0] * 6, "times": [1]}), "only with 'waypoints'"),
    (msgpack.packb({"cmd": "move", "q": [0] * 6, "deg": 1}), "move.deg"),
    (msgpack.packb({"cmd": "move", "waypoints": [[0] * 6, [0] * 6], "times": [2, 1]}), "strictly increasing"),
    (msgpack.packb({"cmd": "move", "waypoints": [[0] * 6], "times": [1, 2]}), "list of 1 numbers"),
    (msgpack.packb({"cmd": "move", "waypoints": [[0] * 6], "duration": 1}), "only with 'q'"),
    (msgpack.packb({"cmd": "move", "waypoints": []}), "non-empty list of joint-position lists"),
]


@pytest.mark.parametrize("body, error", BAD_BODIES, ids=[e for _, e in BAD_BODIES])
def test_bad_request_gets_an_error_and_changes_nothing(loop, sock_path, body, error):
    with raw_connect(sock_path) as s:
        s.sendall(frame(body))
        reply = read_reply(s)
        assert reply["ok"] is False and error in reply["error"]
        s.sendall(frame(msgpack.packb({"cmd": "status"})))  # the framing is intact: same connection
        assert read_reply(s)["ok"] is True
    assert loop.calls == [{"cmd": "status"}]


def test_ragged_waypoints_without_known_joint_count(sock_path):
    lp = Loop(sock_path)
    try:
        reply = request(sock_path, "move", waypoints=[[0, 0], [0, 0, 0]])
        assert not reply["ok"] and "same number of joints" in reply["error"]
        assert request(sock_path, "move", q=[1, 2, 3])["ok"]
        assert lp.calls[0]["q"].tolist() == [1.0, 2.0, 3.0]
    finally:
        lp.close()


def test_oversized_request_is_refused_and_the_server_keeps_serving(loop, sock_path):
    with raw_connect(sock_path) as s:  # only the length prefix: the server must not wait for the body
        s.sendall(struct.pack(">I", 10_000_000))
        reply = read_reply(s)
        assert not reply["ok"] and "10000000 bytes exceeds the 65536-byte limit" in reply["error"]
        assert s.recv(1) == b""  # and the connection is closed
    with raw_connect(sock_path) as s:  # a real 70 KB request
        body = msgpack.packb({"cmd": "move", "q": [0.5] * 8000})
        assert len(body) > 65536
        try:
            s.sendall(frame(body))
        except (BrokenPipeError, ConnectionResetError):
            pass  # the server may close before reading it all; its reply is already queued
        reply = read_reply(s)
        assert not reply["ok"] and "exceeds" in reply["error"]
    assert request(sock_path, "status")["ok"] and loop.calls == [{"cmd": "status"}]


@pytest.mark.parametrize("data, error", [
    (frame(msgpack.packb({"cmd": "stop"}))[:-3], "truncated request: 7 of 10 bytes"),
    (b"\x00\x00", "truncated request: 2 of the 4 length bytes"),
])
def test_truncated_request_is_refused(loop, sock_path, data, error):
    with raw_connect(sock_path) as s:
        s.sendall(data)
        s.shutdown(socket.SHUT_WR)
        reply = read_reply(s)
        assert not reply["ok"] and error in reply["error"]
    assert request(sock_path, "status")["ok"] and loop.calls == [{"cmd": "status"}]


def test_stalled_partial_request_times_out(loop, sock_path):
    with raw_connect(sock_path) as s:
        s.sendall(frame(msgpack.packb({"cmd": "stop"}))[:6])
        reply = read_reply(s)  # request_timeout = 0.3 s in the fixture
        assert not reply["ok"] and "truncated request: 2 of 10 bytes after 0.3 s" in reply["error"]
    assert loop.calls == []


def test_pipelined_requests_are_all_answered_in_order(loop, sock_path):
    with raw_connect(sock_path) as s:
        s.sendall(b"".join(frame(msgpack.packb({"cmd": c})) for c in ("reset", "status", "stop")))
        replies = [read_reply(s) for _ in range(3)]
    assert [r["ok"] for r in replies] == [True, True, True] and replies[1]["state"] == "running"
    assert [c["cmd"] for c in loop.calls] == ["reset", "status", "stop"]


def test_handler_errors_become_error_replies(sock_path):
    lp = Loop(sock_path, replies={"estop": RtctlError("drives unreachable"), "reset": KeyError("bug")})
    try:
        assert request(sock_path, "estop") == {"ok": False, "error": "drives unreachable"}
        reply = request(sock_path, "reset")
        assert not reply["ok"] and "internal error handling 'reset'" in reply["error"]
        assert request(sock_path, "status") == {"ok": True}
    finally:
        lp.close()


def test_a_newcomer_displaces_the_idlest_connection(sock_path):
    lp = Loop(sock_path, max_clients=1)
    try:
        with raw_connect(sock_path) as first:
            first.sendall(frame(msgpack.packb({"cmd": "status"})))
            assert read_reply(first)["ok"]
            assert request(sock_path, "status")["ok"]  # full: the idle first connection makes room
            assert first.recv(1) == b""  # ... and was closed
    finally:
        lp.close()


def test_socket_is_0600_even_with_a_permissive_umask(sock_path):
    old = os.umask(0)
    try:
        server = ControlServer(sock_path, lambda r: {})
    finally:
        os.umask(old)
    try:
        mode = os.stat(sock_path).st_mode
        assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o600
    finally:
        server.close()
    assert not os.path.exists(sock_path)  # removed at shutdown


def test_stale_socket_is_replaced(sock_path):
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(sock_path)  # a daemon that died: the file stays, nobody listens
    dead.close()
    with pytest.raises(ControlSocketError, match="stale socket file"):
        request(sock_path, "status")
    lp = Loop(sock_path)
    try:
        assert request(sock_path, "status")["ok"]
    finally:
        lp.close()


def test_live_daemon_is_not_replaced(loop, sock_path):
    with pytest.raises(ControlSocketError, match="another rtctl daemon is already listening"):
        ControlServer(sock_path, lambda r: {})
    assert request(sock_path, "status")["ok"]  # the first one is untouched


def test_regular_file_is_not_replaced(sock_path):
    with open(sock_path, "w") as f:
        f.write("precious")
    with pytest.raises(ControlSocketError, match="is not a socket"):
        ControlServer(sock_path, lambda r: {})
    assert open(sock_path).read() == "precious"


def test_close_leaves_a_successors_socket_alone(sock_path):
    first = ControlServer(sock_path, lambda r: {})
    os.unlink(sock_path)  # e.g. removed by hand, and a new daemon started on the same path
    second = Loop(sock_path)
    try:
        first.close()
        assert request(sock_path, "status")["ok"]
    finally:
        second.close()


def test_client_errors_when_no_daemon(tmp_path, sock_path):
    with pytest.raises(ControlSocketError, match="does not exist"):
        request(sock_path, "status")
    server = ControlServer(sock_path, lambda r: {})  # listening, but nobody polls it
    try:
        with pytest.raises(ControlSocketError, match="did not answer 'status' within 0.2 s"):
            request(sock_path, "status", timeout=0.2)
    finally:
        server.close()
    with pytest.raises(ControlSocketError, match="cannot create control socket"):
        ControlServer(tmp_path / "missing-dir" / "ctl.sock", lambda r: {})


def test_idle_poll_does_nothing(sock_path):
    calls = []
    server = ControlServer(sock_path, calls.append)
    try:
        assert [server.poll() for _ in range(100)] == [0] * 100 and calls == []
    finally:
        server.close()


def test_a_request_racing_the_daemons_exit_is_answered_not_reset(sock_path):
    """At exit every request already sent gets a reply naming why the daemon stops — on a
    connection accepted before its request arrived, one still in the accept queue, a move whose
    reply was resolved after the last poll — and stop/estop are simply done. Closed without
    reading them, each of these clients would see ECONNRESET (planted: close() without stopping)."""
    pending = Deferred()
    server = ControlServer(sock_path, lambda r: pending if r["cmd"] == "move" else {}, n_joints=6)
    try:
        mover, early = raw_connect(sock_path), raw_connect(sock_path)
        mover.sendall(frame(msgpack.packb({"cmd": "move", "q": [0.0] * 6})))
        time.sleep(0.05)
        while server.poll() < 1:  # the move is handled (answered later); `early` accepted, silent
            time.sleep(0.001)
        early.sendall(frame(msgpack.packb({"cmd": "status"})))
        queued, stopper = raw_connect(sock_path), raw_connect(sock_path)  # never accepted
        queued.sendall(frame(msgpack.packb({"cmd": "get", "key": "ct.kp"})))
        stopper.sendall(frame(msgpack.packb({"cmd": "estop"})))
        idle = raw_connect(sock_path)  # asks nothing: closed with a plain EOF
        time.sleep(0.05)
        pending.resolve({"ok": False, "error": "move cancelled: the daemon is stopping"})
    finally:
        server.close(stopping="duration reached")
    refused = {"ok": False, "error": "the daemon is stopping (duration reached)", "stopping": True}
    assert read_reply(early) == refused and read_reply(queued) == refused
    assert read_reply(stopper) == {"ok": True, "stopping": True}
    assert read_reply(mover) == {"ok": False, "error": "move cancelled: the daemon is stopping"}
    for s in (mover, early, queued, stopper, idle):
        assert s.recv(1) == b""  # then closed, not reset
        s.close()


def test_requests_held_for_later_polls_are_served_though_their_clients_half_closed(sock_path):
    """Past the poll's budget a request waits for the next poll; its client may meanwhile shut its
    sending side (as scripts do after one request). The end of its stream is not a truncated
    frame: every request is answered (the third was failed as "truncated request")."""
    server = ControlServer(sock_path, lambda r: {"seen": r["cmd"]}, budget_s=0.0)
    try:
        clients = [raw_connect(sock_path) for _ in range(3)]
        time.sleep(0.05)
        server.poll()  # accepted, nothing to read yet
        for s in clients:
            s.sendall(frame(msgpack.packb({"cmd": "status"})))
            s.shutdown(socket.SHUT_WR)
        time.sleep(0.05)
        for _ in range(5):  # one request per poll (the budget is spent by the first)
            server.poll()
        assert [read_reply(s) for s in clients] == [{"ok": True, "seen": "status"}] * 3
    finally:
        server.close()


def test_while_the_daemon_starts_only_stop_and_estop_reach_the_handler(loop, sock_path):
    """``starting`` set: a status, a move or a get is answered at once that the daemon is starting
    and what it does, without the handler (the loop that owns it is not running); stop and estop
    are handled. Cleared: everything reaches the handler again."""
    loop.server.starting = "configuring drive1"
    for cmd, fields in (("status", {}), ("move", {"q": [0.0] * 6}), ("get", {"key": "safety.margin"})):
        reply = request(sock_path, cmd, timeout=2.0, **fields)
        assert not reply["ok"] and reply["starting"] == "configuring drive1", reply
        assert "starting (configuring drive1)" in reply["error"] and "stop and estop" in reply["error"]
    assert loop.calls == []
    for cmd in ("stop", "estop"):
        assert request(sock_path, cmd, timeout=2.0)["ok"] is not False
    assert [c["cmd"] for c in loop.calls] == ["stop", "estop"]
    loop.server.starting = None
    assert request(sock_path, "status", timeout=2.0)["state"] == "running"
