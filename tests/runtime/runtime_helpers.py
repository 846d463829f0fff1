"""Run configurations written into a temporary directory, and a daemon started as a subprocess."""
from __future__ import annotations

import os
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import msgpack
import pytest

ROOT = Path(__file__).resolve().parents[2]
PUMA = ROOT / "configs" / "robots" / "puma560.toml"

BASE = f"""
[robot]
description = "{PUMA}"

[loop]
rate_hz = 1000.0
realtime_factor = 0.0

[sim]
substeps = 4
initial_q = [0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0]

[[controllers]]
name = "ct"
type = "computed_torque"
kp = 400.0
kd = 40.0

[trajectory]
unit = "deg"
waypoints = [[0, 45, -180, 0, 45, 0], [30, 30, -160, 20, 60, 30], [0, 45, -180, 0, 45, 0]]
velocity_scale = 0.4
"""


def rtctl(*args, timeout=120, **kw):
    """Run the CLI as a user would (a subprocess), return CompletedProcess."""
    return subprocess.run([sys.executable, "-m", "rtctl.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=kw.pop("cwd", ROOT), **kw)


@pytest.fixture
def write_config(tmp_path):
    def write(text=BASE, name="run.toml"):
        path = tmp_path / name
        path.write_text(text)
        return path

    return write


class Daemon:
    def __init__(self, config, tmp_path, *extra):
        self.socket = tmp_path / "rtctl.sock"
        self.summary = tmp_path / "summary.json"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "rtctl.cli", "run", str(config), "--socket", str(self.socket),
             "--summary", str(self.summary), *map(str, extra)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)

    def wait_ready(self, timeout=60.0):
        """Until the loop answers ``status`` ok: the socket exists before the loop runs (the
        kernels may still be compiling), and a status then is answered "starting"."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.socket.exists() and self.proc.poll() is None and self._answers():
                return
            if self.proc.poll() is not None:
                raise AssertionError(f"daemon exited {self.proc.returncode}: {self.proc.stderr.read()}")
            time.sleep(0.05)
        raise AssertionError("daemon did not open its socket")

    def _answers(self) -> bool:
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
                s.settimeout(0.5)
                s.connect(str(self.socket))
                body = msgpack.packb({"cmd": "status"})
                s.sendall(struct.pack(">I", len(body)) + body)
                head = s.recv(4)
                if len(head) < 4:
                    return False
                (n,) = struct.unpack(">I", head)
                body = b""
                while len(body) < n:
                    chunk = s.recv(n - len(body))
                    if not chunk:
                        return False
                    body += chunk
                return bool(msgpack.unpackb(body).get("ok"))
        except OSError:
            return False

    def finish(self, timeout=60.0):
        out, err = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, out, err

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


@pytest.fixture
def daemon(tmp_path):
    started = []

    def start(config, *extra):
        d = Daemon(config, tmp_path, *extra)
        started.append(d)
        return d

    yield start
    for d in started:
        d.kill()


os.environ.setdefault("PYTHONUNBUFFERED", "1")
