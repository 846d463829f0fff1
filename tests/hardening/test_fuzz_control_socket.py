"""Fuzzing the control socket: random byte streams, random msgpack values, frames cut short,
stalled, oversized or pipelined, and connection storms (idle, slow, garbage, reconnecting).
Throughout, the handler only ever sees valid requests, `estop` always gets through, and a
daemon under the storm keeps its rate (its overrun policy never trips) and latches the e-stop."""
from __future__ import annotations

import json
import math
import socket
import struct
import threading
import time

import msgpack
import numpy as np
import pytest
from hypothesis import given, strategies as st

from fuzz_helpers import FUZZ
from polled_server import PolledServer, connect
from rtctl.control_socket import COMMANDS, request
from runtime_helpers import BASE

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

N = 6
msgpack_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**63, 2**64 - 1) | st.floats() | st.text(max_size=8)
    | st.binary(max_size=8),
    lambda inner: st.lists(inner, max_size=6)
    | st.dictionaries(st.text(max_size=8) | st.integers(-2**63, 2**63 - 1), inner, max_size=6),
    max_leaves=20)
requests = st.one_of(
    msgpack_values,
    st.fixed_dictionaries({"cmd": st.sampled_from(sorted(COMMANDS) + ["nope", ""])},
                          optional={"q": msgpack_values | st.lists(st.floats(), min_size=N, max_size=N),
                                    "waypoints": msgpack_values, "times": msgpack_values, "duration": msgpack_values,
                                    "deg": msgpack_values, "extra": msgpack_values}))


def frame(value) -> bytes:
    body = msgpack.packb(value)
    return struct.pack(">I", len(body)) + body


chunks = st.one_of(
    requests.map(frame),
    st.binary(max_size=64),
    requests.map(frame).map(lambda f: f[:max(1, len(f) // 2)]),  # cut short
    st.integers(65537, 2**32 - 1).map(lambda n: struct.pack(">I", n) + b"x"),  # announces too much
    st.lists(requests.map(frame), min_size=2, max_size=4).map(b"".join),  # pipelined
)


def valid(req) -> bool:
    """What the handler may see: a known command, and for move finite targets of N joints."""
    ok = isinstance(req, dict) and req.get("cmd") in COMMANDS
    if req.get("cmd") == "move":
        points = req["q"] if req["q"] is not None else req["waypoints"]
        ok &= isinstance(points, np.ndarray) and points.shape[-1] == N and bool(np.all(np.isfinite(points)))
        ok &= req["duration"] is None or (math.isfinite(req["duration"]) and req["duration"] > 0)
    return ok


def test_fuzz_control_socket_streams(tmp_path):
    path = str(tmp_path / "ctl.sock")
    served = PolledServer(path, valid, request_timeout=0.2, idle_timeout=0.5)
    hogs = []
    try:
        @FUZZ
        @given(st.lists(st.tuples(st.integers(0, 2), chunks, st.sampled_from(["keep", "close", "shutdown"])),
                        min_size=1, max_size=6), st.integers(0, 12))
        def case(actions, idle):
            while len(hogs) < idle:  # idle connections held across examples (the server drops them)
                hogs.append(connect(path))
            conns = {}
            for k, data, then in actions:
                s = conns.get(k) or conns.setdefault(k, connect(path))
                try:
                    s.sendall(data)
                    if then == "shutdown":
                        s.shutdown(socket.SHUT_WR)
                except OSError:  # the server may have closed it (a framing error, or evicted)
                    pass
                if then == "close":
                    s.close()
                    conns.pop(k)
            assert request(path, "estop", timeout=2.0) == {"ok": True}  # answered within 2 s
            for s in conns.values():
                s.close()
            assert not served.bad, served.bad

        case()
    finally:
        for s in hogs:
            s.close()
        served.close()
    assert served.calls.count("estop") >= 1


PACED = BASE.replace("realtime_factor = 0.0", "realtime_factor = 1.0").replace("rate_hz = 1000.0", "rate_hz = 500.0")


@pytest.mark.timeout(120)
def test_fuzz_control_socket_storm_on_a_running_daemon(write_config, daemon):
    """2 s of storm — idle and trickling connections, garbage, connect-and-close, a status
    flood — then `estop`: it is answered and latched, and the run ends (exit 3) with the e-stop
    as its only fault: the overrun policy never tripped."""
    d = daemon(write_config(PACED))
    d.wait_ready()
    path = str(d.socket)
    stop = threading.Event()
    rng = np.random.default_rng(1)
    garbage = [bytes(rng.integers(0, 256, size=int(rng.integers(1, 200)), dtype=np.uint8)) for _ in range(64)]

    def storm(kind):
        held = []
        while not stop.is_set():
            try:
                s = connect(path, timeout=2.0)
            except OSError:
                continue
            try:
                if kind == "garbage":
                    s.sendall(garbage[int(rng.integers(len(garbage)))])
                elif kind == "trickle":
                    s.sendall(b"\x00\x00")  # a frame that never completes
                elif kind == "status":
                    s.sendall(frame({"cmd": "status"}))
                    s.recv(65536)
            except OSError:
                pass
            if kind in ("idle", "trickle"):
                held.append(s)
                if len(held) > 30:
                    held.pop(0).close()
            else:
                s.close()
            time.sleep(0.001)  # ~5 × 700 connections/s: a storm that leaves the daemon a core
        for s in held:
            s.close()

    threads = [threading.Thread(target=storm, args=(k,)) for k in ("idle", "trickle", "garbage", "status", "status")]
    for t in threads:
        t.start()
    try:
        time.sleep(2.0)
        t0 = time.monotonic()
        reply = request(path, "estop", timeout=5.0)
        latency = time.monotonic() - t0
    finally:
        stop.set()
        for t in threads:
            t.join()
    assert reply["ok"] is True and set(reply) == {"ok", "t"}, reply
    status = request(path, "status")
    assert status["estopped"] and status["faults"] == ["operator e-stop"] and not status["stopping"], status
    assert request(path, "stop")["ok"]
    code, out, err = d.finish()
    summary = json.loads(d.summary.read_text())
    assert code == 3, (code, summary["stop_reason"], err[-2000:])  # the e-stop was not reset
    assert [f["kind"] for f in summary["safety"]["faults"]] == ["estop"]  # no overrun stop, no other fault
    print(f"estop answered in {latency * 1e3:.1f} ms during the storm; "
          f"overruns {summary['timing']['overruns']} of {summary['timing']['ticks']} ticks")
