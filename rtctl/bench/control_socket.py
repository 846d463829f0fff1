"""``rtctl bench control-socket``: what ``ControlServer.poll()`` costs the loop per call.

Idle (no connection), with one idle client connected (the sweep's clock read is added),
answering one ``status`` request (decode, validate, handler, encode, send) — the cost of the
tick in which a request arrives — and in a connection storm: every slot taken and, before
each poll, as many newcomers as a poll accepts, each with a frame of garbage (accept, drop the
stalest connection, read, answer the framing error): the most a poll does.

Then the operator's side: the wall time of ``rtctl status`` and ``rtctl estop`` as a user runs
them (a new process each, 20 times, against a server polled every millisecond as the loop
does), and of ``rtctl estop`` when no daemon listens — what an e-stop costs before it reaches
the loop. Last, a ``stop`` sent while a daemon starts (``rtctl run`` of the C* job, its kernels
cached): the round trip of the request, sent at a different moment of the start each time —
loading kernels, configuring, activating — and whether the start ended before the loop.
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from rtctl.bench import percentiles_us
from rtctl.control_socket import ControlServer, request
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
            clients = _time_clients(server)
        finally:
            server.close()
        starting = _time_stops_while_starting(directory)
    return {"idle": idle, "idle_client": connected, "status_request": percentiles_us(ns), "storm": storm,
            "client_wall_ms": clients, "stop_while_starting": starting}


def _time_stops_while_starting(directory: str, runs: int = 8, config: str = "puma560_cstar_sim.toml") -> dict:
    path = Path(__file__).resolve().parents[2] / "configs" / config
    ms, status_ms, answered_starting, started = [], [], 0, 0
    for k in range(runs):
        sock = os.path.join(directory, f"start{k}.sock")
        proc = subprocess.Popen([sys.executable, "-m", "rtctl.cli", "run", str(path), "--socket", sock, "--duration",
                                 "5", "--log-format", "json"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            while not os.path.exists(sock) and proc.poll() is None:
                time.sleep(0.001)
            time.sleep(0.1 * k)  # a later moment of the start each time (it takes about a second)
            a = time.perf_counter()
            answered_starting += "starting" in request(sock, "status", timeout=10.0)
            status_ms.append((time.perf_counter() - a) * 1e3)
            a = time.perf_counter()
            request(sock, "stop", timeout=10.0)
            ms.append((time.perf_counter() - a) * 1e3)
            out, _ = proc.communicate(timeout=120)
            started += '"started"' in out
        finally:
            proc.kill()
            proc.wait()
    return {"median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)), "max_ms": max(ms),
            "runs": runs, "loop_started": started,
            "status": {"median_ms": float(np.median(status_ms)), "p90_ms": float(np.percentile(status_ms, 90)),
                       "max_ms": max(status_ms), "answered_starting": answered_starting}}


def _time_clients(server: ControlServer, runs: int = 20) -> dict:
    stop = threading.Event()
    poller = threading.Thread(target=lambda: [server.poll() or time.sleep(0.001) for _ in iter(stop.is_set, True)])
    poller.start()
    try:
        cases = {"status": ["status", "--socket", server.path], "estop": ["estop", "--socket", server.path],
                 "estop, no daemon": ["estop", "--socket", server.path + ".none"]}
        out = {}
        for name, argv in cases.items():
            ms = []
            for _ in range(runs):
                a = time.perf_counter()
                subprocess.run([sys.executable, "-m", "rtctl.cli", *argv], capture_output=True)
                ms.append((time.perf_counter() - a) * 1e3)
            out[name] = {"median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)), "max_ms": max(ms)}
        return out
    finally:
        stop.set()
        poller.join()


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
    lines.append(f"{'rtctl client, wall ms (20 runs)':<34}{'median':>9}{'p90':>9}{'max':>10}   goal: median ≤ 100 ms")
    for name, c in result["client_wall_ms"].items():
        lines.append(f"{name:<34}{c['median_ms']:>9.1f}{c['p90_ms']:>9.1f}{c['max_ms']:>10.1f}"
                     + ("   yes" if c["median_ms"] <= 100 else "   NO"))
    c = result["stop_while_starting"]
    lines.append(f"{'stop while the daemon starts, ms':<34}{c['median_ms']:>9.1f}{c['p90_ms']:>9.1f}{c['max_ms']:>10.1f}"
                 f"   (round trip; the loop started in {c['loop_started']} of {c['runs']} runs)")
    st = c["status"]
    lines.append(f"{'status while the daemon starts, ms':<34}{st['median_ms']:>9.1f}{st['p90_ms']:>9.1f}"
                 f"{st['max_ms']:>10.1f}   (sent just before the stop; {st['answered_starting']} answered \"starting\")")
    return "\n".join(lines)
