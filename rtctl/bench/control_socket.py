"""``rtctl bench control-socket``: what ``ControlServer.poll()`` costs the loop per call.

Idle (no connection), with one idle client connected (the sweep's clock read is added),
answering one ``status`` request (decode, validate, handler, encode, send) — the cost of the
tick in which a request arrives — and in a connection storm: every slot taken and, before
each poll, as many newcomers as a poll accepts, each with a frame of garbage (accept, drop the
stalest connection, read, answer the framing error): the most a poll does.
"""
from __future__ import annotations

import os
import socket
import tempfile
import time

import numpy as np

from rtctl.bench import percentiles_us
from rtctl.control_socket import ControlServer
from rtctl.control_socket.server import ACCEPTS_PER_POLL
from rtctl.control_socket.framing import encode


def _time_polls(server: ControlServer, n: int) -> dict:
    ns = np.zeros(n, np.int64)
    for k in range(n):
        a = time.perf_counter_ns()
        server.poll()
        ns[k] = time.perf_counter_ns() - a
    return percentiles_us(ns)


def bench_control_socket(polls: int = 20000, requests: int = 500) -> dict:
    status = {"state": "running", "ticks": 0, "q": [0.0] * 6}
    with tempfile.TemporaryDirectory(prefix="rtctl-bench-") as directory:
        server = ControlServer(os.path.join(directory, "ctl.sock"), lambda request: status)
        try:
            idle = _time_polls(server, polls)
            client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            client.connect(server.path)
            server.poll()  # accept
            connected = _time_polls(server, polls)
            frame, ns = encode({"cmd": "status"}), []
            for _ in range(requests):
                client.sendall(frame)
                a = time.perf_counter_ns()
                server.poll()
                ns.append(time.perf_counter_ns() - a)
                client.recv(65536)
            client.close()
            storm = _time_storm(server, requests)
        finally:
            server.close()
    return {"idle": idle, "idle_client": connected, "status_request": percentiles_us(ns), "storm": storm}


def _time_storm(server: ControlServer, polls: int) -> dict:
    rng = np.random.default_rng(0)
    held = []
    while len(server._clients) < server.max_clients:
        held.append(socket.socket(socket.AF_UNIX, socket.SOCK_STREAM))
        held[-1].connect(server.path)
        server.poll()
    ns = []
    for _ in range(polls):
        for _ in range(ACCEPTS_PER_POLL):
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.connect(server.path)
            s.sendall(b"\x00\x00\x00\x08" + rng.bytes(8))  # a frame of garbage
            held.append(s)
        a = time.perf_counter_ns()
        server.poll()
        ns.append(time.perf_counter_ns() - a)
        while len(held) > 4 * server.max_clients:
            held.pop(0).close()
    for s in held:
        s.close()
    return percentiles_us(ns)


def format_table(result: dict) -> str:
    lines = [f"{'ControlServer.poll() µs':<34}{'p50':>9}{'p99':>9}{'max':>10}"]
    for key, label in (("idle", "idle, no connection"), ("idle_client", "one idle client connected"),
                       ("status_request", "answering one status request"),
                       ("storm", f"storm: {ACCEPTS_PER_POLL} garbage newcomers/poll")):
        p = result[key]
        lines.append(f"{label:<34}{p['p50_us']:>9.2f}{p['p99_us']:>9.2f}{p['max_us']:>10.1f}")
    return "\n".join(lines)
