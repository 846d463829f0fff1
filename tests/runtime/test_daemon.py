"""`rtctl run` end to end, as subprocesses: control socket, signals, telemetry, summary."""
from __future__ import annotations

import json
import signal
import socket
import struct
import time

import msgpack
import numpy as np

from rtctl.telemetry import read
from runtime_helpers import BASE, rtctl

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


def test_estop_is_a_controlled_stop_then_drives_off_and_exit_3(write_config, daemon, tmp_path):
    telemetry = tmp_path / "estop.msgpack"
    # damping suited to the PUMA's reflected inertia (≈2–5 kg·m²: time constant ≈ 0.1 s)
    config = PACED + "\n[safety]\ndamping = 40.0\nestop_off_delay = 0.5\n"
    d = daemon(write_config(config), "--telemetry", telemetry)
    d.wait_ready()
    time.sleep(0.5)
    assert rtctl("estop", "--socket", d.socket).returncode == 0
    code, out, err = d.finish()
    assert code == 3, err
    summary = json.loads(d.summary.read_text())
    assert any(f["reason"] == "operator e-stop" for f in summary["safety"]["faults"])
    assert summary["safety"]["deactivated"]
    assert all(dev["lifecycle"] == "closed" for dev in summary["devices"].values())
    run = read(telemetry)
    assert run.rows == summary["timing"]["ticks"]
    # the stop damps the motion while carrying the arm's weight, then cuts the drives when every
    # joint is below stop_velocity (0.01 rad/s) or after estop_off_delay (measured: ≤ 0.01 rad/s;
    # with damping alone and no gravity torque the shoulder sagged at 1 rad/s)
    assert np.abs(run["qd"][-1]).max() < 0.02
