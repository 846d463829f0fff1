"""`rtctl run` end to end, as subprocesses: control socket, signals, telemetry, summary."""
from __future__ import annotations

import json
import signal
import socket
import struct
import time

import msgpack
import numpy as np
import pytest

from rtctl.telemetry import read
from runtime_helpers import BASE, rtctl

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

PACED = BASE.replace("realtime_factor = 0.0", "realtime_factor = 1.0")


def raw_request(path, payload: bytes, timeout=5.0):
    """Send raw bytes on the control socket; return the decoded reply (or None if closed)."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(timeout)
        s.connect(str(path))
        s.sendall(payload)
        s.shutdown(socket.SHUT_WR)
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    if len(data) < 4:
        return None
    (n,) = struct.unpack(">I", data[:4])
    return msgpack.unpackb(data[4:4 + n])


def frame(obj) -> bytes:
    body = msgpack.packb(obj)
    return struct.pack(">I", len(body)) + body


def test_status_move_stop_over_the_socket(write_config, daemon):
    d = daemon(write_config(PACED))
    d.wait_ready()
    status = rtctl("status", "--socket", d.socket)
    assert status.returncode == 0, status.stderr
    reply = json.loads(status.stdout)
    assert reply["ok"] and reply["robot"] == "puma560" and len(reply["q"]) == 6

    moved = rtctl("move", "--deg", "--socket", d.socket, 10, 40, -170, 5, 50, 5)
    assert moved.returncode == 0, moved.stdout + moved.stderr
    assert json.loads(moved.stdout)["t_end"] > json.loads(moved.stdout)["t_start"]

    stop = rtctl("stop", "--socket", d.socket)
    assert stop.returncode == 0
    code, out, err = d.finish()
    assert code == 0, err
    summary = json.loads(d.summary.read_text())
    assert summary["stop_reason"] == "stop requested"
    assert summary["timing"]["ticks"] > 0
    assert not d.socket.exists()  # removed at shutdown


def test_malformed_requests_get_an_error_and_change_nothing(write_config, daemon):
    d = daemon(write_config(PACED))
    d.wait_ready()
    bad = [
        b"\x00\x00\x00\x05\xc1\xc1\xc1\xc1\xc1",  # not msgpack
        frame({"cmd": "status"})[:-2],  # truncated frame
        struct.pack(">I", 10_000_000) + b"x" * 100,  # announces an oversized request
        frame({"cmd": "self-destruct"}),  # unknown command
        frame({"cmd": "move", "q": "not numbers"}),  # wrong field type
        frame({"cmd": "move", "q": [0.0, 1.0]}),  # wrong number of joints
        frame([1, 2, 3]),  # not a map
    ]
    for payload in bad:
        reply = raw_request(d.socket, payload)
        assert reply is not None, f"no reply to {payload[:20]!r}"  # an error reply, never a silent close
        assert reply["ok"] is False and reply["error"], reply
    assert d.proc.poll() is None  # still running
    reply = raw_request(d.socket, frame({"cmd": "status"}))
    assert reply["ok"] and not reply["faults"]
    rtctl("stop", "--socket", d.socket)
    assert d.finish()[0] == 0


def test_sigterm_keeps_every_recorded_tick(write_config, daemon, tmp_path):
    telemetry = tmp_path / "run.msgpack"
    d = daemon(write_config(PACED), "--telemetry", telemetry)
    d.wait_ready()
    time.sleep(1.5)
    d.proc.send_signal(signal.SIGTERM)
    code, out, err = d.finish()
    assert code == 0, err
    summary = json.loads(d.summary.read_text())
    run = read(telemetry)
    assert not run.truncated
    assert run.rows == summary["timing"]["ticks"] == summary["telemetry"]["rows"] > 500
    assert np.all(np.diff(run["t"]) > 0)
    assert summary["stop_reason"] == "signal SIGTERM"
    busy = summary["timing"]["core_busy"]  # the loop's thread: its compute and spin, never more than the wall time
    assert 0 < busy["mean"] <= 1 and 0 < busy["max"] <= 1


def test_as_fast_as_possible_is_bit_for_bit_reproducible(write_config, tmp_path):
    config = write_config()
    runs = []
    for k in range(2):
        path = tmp_path / f"run{k}.msgpack"
        result = rtctl("run", config, "--duration", "1.0", "--telemetry", path, "--socket", tmp_path / f"s{k}")
        assert result.returncode == 0, result.stderr
        runs.append(read(path))
    a, b = runs
    assert a.rows == b.rows > 1000
    for column in ("t", "q", "qd", "q_des", "tau"):
        assert np.array_equal(a[column], b[column]), column


def test_daemon_not_running_is_a_clear_error(tmp_path):
    result = rtctl("status", "--socket", tmp_path / "none.sock")
    assert result.returncode == 6
    assert "Traceback" not in result.stderr and "none.sock" in result.stderr


def wait_for_status(socket_path, predicate, timeout=10.0):
    """Poll status in-process (a CLI subprocess per poll would load the machine the paced loop runs on)."""
    from rtctl.control_socket import request

    end = time.monotonic() + timeout
    while time.monotonic() < end:
        reply = request(socket_path, "status")
        if predicate(reply):
            return reply
        time.sleep(0.1)
    raise AssertionError(f"status never matched: {reply}")


def test_estop_stops_the_robot_not_the_daemon_and_reset_resumes(write_config, daemon, tmp_path):
    telemetry = tmp_path / "estop.msgpack"
    # damping suited to the PUMA's reflected inertia (≈2–5 kg·m²: time constant ≈ 0.1 s)
    # overruns are not the point here: a loaded machine must not end the run while it is e-stopped
    config = PACED.replace("rate_hz = 1000.0", "rate_hz = 1000.0\noverrun_limit = 1000000")
    config += "\n[safety]\ndamping = 40.0\nestop_off_delay = 0.5\n"
    d = daemon(write_config(config), "--telemetry", telemetry)
    d.wait_ready()
    time.sleep(0.5)
    assert rtctl("estop", "--socket", d.socket).returncode == 0
    # the drives go off, the daemon stays up and says why
    stopped = wait_for_status(d.socket, lambda r: r["verdict"] == "DEACTIVATE")
    assert stopped["estopped"] and stopped["faults"] == ["operator e-stop"] and not stopped["stopping"]
    moved = rtctl("move", "--socket", d.socket, 0, 0.7854, -3.1416, 0, 0.7854, 0)
    assert moved.returncode != 0 and "reset" in moved.stdout  # no motion while e-stopped
    reset = rtctl("reset", "--socket", d.socket)
    assert reset.returncode == 0, reset.stdout
    resumed = wait_for_status(d.socket, lambda r: r["verdict"] == "OK")
    assert not resumed["estopped"] and resumed["faults"] == []
    assert d.proc.poll() is None
    assert rtctl("stop", "--socket", d.socket).returncode == 0
    code, out, err = d.finish()
    assert code == 0, err  # the e-stop was cleared by the reset: a clean end
    summary = json.loads(d.summary.read_text())
    events = summary["safety"]["events"]
    assert [e["event"] for e in events] == ["fault", "deactivate", "reset", "stop", "deactivate"]
    assert events[0]["kind"] == "estop" and events[0]["reason"] == "operator e-stop"
    assert summary["safety"]["faults"] == [] and not summary["safety"]["faulted"]
    assert summary["stop_reason"] == "stop requested"
    assert all(dev["lifecycle"] == "closed" for dev in summary["devices"].values())
    run = read(telemetry)
    assert run.rows == summary["timing"]["ticks"]
    # the e-stop damps the motion while carrying the arm's weight, then cuts the drives when every
    # joint is below stop_velocity (0.01 rad/s) or after estop_off_delay (measured: ≤ 0.01 rad/s;
    # with damping alone and no gravity torque the shoulder sagged at 1 rad/s)
    off = int(np.searchsorted(run["t"], events[1]["t"]))
    assert np.abs(run["qd"][off]).max() < 0.02


def test_a_normal_end_is_a_stop_not_a_fault(write_config, tmp_path):
    summary_path = tmp_path / "summary.json"
    result = rtctl("run", write_config(), "--duration", "0.3", "--socket", tmp_path / "s",
                   "--summary", summary_path, "--log-format", "json")
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    stop = [e for e in lines if e["event"] == "stop"]
    assert len(stop) == 1 and stop[0]["level"] == "info" and stop[0]["reason"] == "duration reached"
    assert not [e for e in lines if e["level"] in ("warning", "error") and e["event"] != "rt knob"]
    summary = json.loads(summary_path.read_text())
    line = lines[-1]
    assert line["event"] == "summary" and line["faults"] == len(summary["safety"]["faults"]) == 0
    assert summary["safety"]["faulted"] is False and summary["safety"]["stop"]["reason"] == "duration reached"
    assert summary["safety"]["deactivated"]


def test_the_real_time_knobs_apply_after_the_kernels_and_a_lock_step_run_says_once_why_not_fifo(write_config, tmp_path):
    """Issue 26 items 13 and 14: the knobs apply once the compile workers are gone (the loop at
    SCHED_FIFO must not take a core from them), before the drives are enabled; a lock-step run
    says once that it will not take SCHED_FIFO (it said it twice: a warning, then "not requested")."""
    config = write_config(BASE + "\n[loop.rt]\npriority = 80\n")
    result = rtctl("run", config, "--duration", "0.05", "--socket", tmp_path / "s", "--log-format", "json")
    assert result.returncode == 0, result.stderr
    events = [json.loads(line)["event"] for line in result.stdout.splitlines()]
    fifo = [json.loads(line) for line in result.stdout.splitlines() if '"sched_fifo"' in line]
    assert len(fifo) == 1 and fifo[0]["level"] == "warning" and "lock-step" in fifo[0]["detail"], fifo
    knobs = [i for i, e in enumerate(events) if e == "rt knob"]
    assert knobs and events.index("kernels loaded") < knobs[0] and knobs[-1] < events.index("started")


@pytest.mark.parametrize("cmd, code, reason", [("stop", 0, "stop requested"),
                                               ("estop", 3, "operator e-stop before start: no drive was enabled")])
def test_a_stop_while_the_kernels_compile_is_answered_then_and_enables_no_drive(write_config, tmp_path, cmd, code,
                                                                                 reason):
    """A first run compiles its kernels for tens of seconds with the socket open; `stop` and
    `estop` are served meanwhile (they waited for the first tick, and the CLI gives up after 5 s):
    the workers stop, no drive is enabled, the run ends — `estop` as a fault (exit 3). Without the
    serving, the reply came only after the loop had started ("started" logged, drives enabled)."""
    import os
    import subprocess
    import sys

    from rtctl.control_socket import request
    from runtime_helpers import ROOT

    sock, summary = tmp_path / "s.sock", tmp_path / "summary.json"
    env = os.environ | {"NUMBA_CACHE_DIR": str(tmp_path / "kernels")}  # empty: this run compiles
    proc = subprocess.Popen([sys.executable, "-m", "rtctl.cli", "run", str(write_config(PACED)), "--socket", str(sock),
                             "--summary", str(summary), "--log-format", "json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT, env=env)
    try:
        before = []  # the log up to the workers' start: the stop is sent while they compile
        for line in proc.stdout:
            before.append(line)
            if json.loads(line)["event"] == "preparing kernels":
                break
        reply = request(sock, cmd, timeout=120)
        out, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert reply["ok"], reply
    events = [json.loads(line) for line in before + out.splitlines()]
    names = [e["event"] for e in events]
    assert "preparing kernels" in names and "started" not in names, names  # answered while compiling
    assert proc.returncode == code, err
    assert json.loads(summary.read_text())["stop_reason"] == reason
