"""A cell file in a temporary folder (free ports, its own run_dir and credentials) and a
running ``rtctl cell up`` for the cell's tests."""
from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
RUN_CONFIG = REPO / "configs" / "cell" / "puma560_cell_sim.toml"
USER, PASSWORD = "tester", "pw-for-tests"
OBSERVER, OBSERVER_PASSWORD = "viewer", "pw-viewer"  # may subscribe, not command
OTHER, OTHER_PASSWORD = "other", "pw-other"  # in the dictionary, in no policy


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def write_cell(folder: Path, n_robots: int = 2, *, extra: str = "", name: str = "testcell") -> Path:
    (folder / "users").write_text(f"{USER}:{PASSWORD}\n{OBSERVER}:{OBSERVER_PASSWORD}\n{OTHER}:{OTHER_PASSWORD}\n")
    robots = "".join(f'''
[[robots]]
name = "r{i}"
config = "{RUN_CONFIG}"
base = [0, {i}, 0, 0, 0, 0]
port = {free_port()}
sim = true
''' for i in range(n_robots))
    path = folder / "cell.toml"
    path.write_text(f'''[cell]
name = "{name}"
run_dir = "run"

[auth]
user = "{USER}"
dictionary_file = "users"
observers = ["{OBSERVER}"]
{robots}{extra}''')
    return path


def rtctl(*args, timeout=60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rtctl.cli", *args], capture_output=True, text=True,
                          timeout=timeout, env=os.environ | {"PYTHONPATH": str(REPO)})


class RunningCell:
    """``rtctl cell up CELLFILE`` in a process of its own; ``pids`` once it says "running"."""

    def __init__(self, cellfile: Path, start_timeout_s: float = 240.0, extra_args=()):
        self.cellfile = cellfile
        self.proc = subprocess.Popen([sys.executable, "-m", "rtctl.cli", "cell", "up", str(cellfile), *extra_args],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     env=os.environ | {"PYTHONPATH": str(REPO)})
        self.lines: list[str] = []
        deadline = time.monotonic() + start_timeout_s
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.lines.append(line)
            if line.startswith("running;"):
                break
        else:
            self.close()
        if not self.lines or not self.lines[-1].startswith("running;"):
            self.close()
            pytest.fail("rtctl cell up did not start:\n" + "".join(self.lines))
        self.pids = [int(p) for line in self.lines for p in re.findall(r"(?:daemon|bridge) pid (\d+)", line)]

    def finish(self, sig=None, timeout=60.0) -> tuple[int, str]:
        """(exit code, the rest of its output) after ``sig`` (None: wait for it to end)."""
        if sig is not None:
            self.proc.send_signal(sig)
        out, _ = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, out

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie — ended, not yet reaped — does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"
