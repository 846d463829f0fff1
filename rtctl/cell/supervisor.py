"""``rtctl cell up``: every daemon of a cell and one bridge per robot, started, watched and
stopped together (docs/cell.md, "Processes").

Each daemon is an ordinary ``rtctl run`` with its own control socket, telemetry file, summary
and log in the cell's ``run_dir``; its bridge (:mod:`rtctl.cell.bridge`) is started once the
daemon answers on its socket; with shared zones, each daemon enforces them (``--cell``) and the
arbiter (:mod:`rtctl.cell.arbiter`) starts once every bridge runs. Every child gets its own session (a Ctrl-C at the terminal
reaches only this process, which then stops them in order) and SIGTERM should this process
die (Linux's parent-death signal): nothing is left running behind it.

The stop, on SIGINT/SIGTERM or once every daemon has ended (``rtctl cell stop``): a
controlled ``stop`` to each daemon still running, then SIGTERM to those that have not ended
within ``STOP_S``, then the bridges; SIGKILL only for a process that ignores SIGTERM.
"""
from __future__ import annotations

import ctypes
import json
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from rtctl.control_socket.client import request
from rtctl.errors import EXIT_HARDWARE, ControlSocketError, RtctlError

STOP_S = 10.0  # a daemon's controlled stop: damping, drives off, telemetry and summary written
TERM_S = 5.0
POLL_S = 0.1
_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:  # (in the child, between fork and exec)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the stop below still ends every child
        pass


@dataclass
class Member:
    """One robot's processes and files."""

    robot: object  # CellRobot
    socket: Path
    telemetry: Path
    summary: Path
    log: Path
    daemon: subprocess.Popen | None = None
    bridge: subprocess.Popen | None = None
    answered: bool = False  # its loop has served a request


def _spawn(argv, log: Path) -> subprocess.Popen:
    with log.open("ab") as out:
        return subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True, preexec_fn=_die_with_parent)


class CellProcesses:
    """The processes of ``robots`` (default: every robot of the cell; on several hosts, this host's)."""

    def __init__(self, cell, robots=None, *, say=print):
        self.cell, self.say = cell, say
        cell.run_dir.mkdir(parents=True, exist_ok=True)
        d = cell.run_dir
        self.members = [Member(r, d / f"{r.name}.sock", d / f"{r.name}.msgpack", d / f"{r.name}.summary.json",
                               d / f"{r.name}.log") for r in (cell.robots if robots is None else robots)]
        # the shared zones' arbiter: on the host that starts the whole cell (docs/cell.md)
        self.with_arbiter = bool(cell.zones) and len(self.members) == len(cell.robots)
        self.arbiter: subprocess.Popen | None = None
        self.arbiter_log = d / "arbiter.log"

    # -- start -------------------------------------------------------------------------
    def start(self, timeout_s: float, stop_requested=lambda: False, *, bridges: bool = True) -> None:
        """Each daemon in turn, the next once the previous answers on its socket (the first
        may compile the kernels the others then load: compiling beside a running loop would
        make it late), and its bridge (not with ``bridges=False``: the daemons alone, for a
        side-by-side measurement). RtctlError if a daemon exits or does not answer within
        ``timeout_s`` (what already runs is the caller's to stop); returns early once
        ``stop_requested()``."""
        for m in self.members:
            argv = [sys.executable, "-m", "rtctl.cli", "run", str(m.robot.config), "--socket", str(m.socket),
                    "--telemetry", str(m.telemetry), "--summary", str(m.summary), "--log-format", "json"]
            if self.cell.zones:  # its loop enforces the shared zones
                argv += ["--cell", str(self.cell.file), "--cell-robot", m.robot.name]
            m.daemon = _spawn(argv + (["--sim"] if m.robot.sim else []), m.log)
            self.say(f"{m.robot.name}: daemon pid {m.daemon.pid}, log {m.log}")
            if not self._wait_ready(m, time.monotonic() + timeout_s, timeout_s, stop_requested):
                return
            if not bridges:
                continue
            m.bridge = _spawn([sys.executable, "-m", "rtctl.cell.bridge",
                               json.dumps({"cell": str(self.cell.file), "robot": m.robot.name, "socket": str(m.socket)})],
                              m.log.with_suffix(".bridge.log"))
            self.say(f"{m.robot.name}: running; bridge pid {m.bridge.pid} on {m.robot.endpoint()}")
        if bridges and self.with_arbiter and not stop_requested():
            self.arbiter = _spawn([sys.executable, "-m", "rtctl.cell.arbiter", json.dumps({"cell": str(self.cell.file)})],
                                  self.arbiter_log)
            self.say(f"shared zones: arbiter pid {self.arbiter.pid}, log {self.arbiter_log}")

    def _wait_ready(self, m: Member, deadline: float, timeout_s: float, stop_requested) -> bool:
        while not stop_requested():
            if m.daemon.poll() is not None:
                raise RtctlError(f"cell {self.cell.name}: {m.robot.name}'s daemon exited with {m.daemon.returncode} "
                                 f"during start-up; its log: {m.log}\n{_tail(m.log)}")
            try:
                if request(m.socket, "status", timeout=0.5)["ok"]:
                    m.answered = True
                    return True
            except ControlSocketError:
                pass
            if time.monotonic() > deadline:
                raise RtctlError(f"cell {self.cell.name}: {m.robot.name}'s daemon did not answer within {timeout_s:g} s "
                                 f"(its log: {m.log})")
            time.sleep(POLL_S)
        return False

    # -- watch -------------------------------------------------------------------------
    def watch(self, stop_requested) -> str | None:
        """Until ``stop_requested()`` or every daemon has ended (None), or a bridge ends while
        its daemon runs: then the cell can no longer e-stop that robot, and the reason is
        returned for the caller to stop the cell. A daemon that ends alone is reported."""
        reported = set()
        while not stop_requested():
            if self.arbiter is not None and self.arbiter.poll() is not None and "arbiter" not in reported:
                reported.add("arbiter")  # (safe: a robot without a lease waits at the border, one inside stops)
                self.say(f"the shared zones' arbiter ended with exit code {self.arbiter.returncode}: no lease is "
                         f"granted any more (log {self.arbiter_log})")
            lost = self.lost_bridge()
            if lost is not None:
                return lost
            for m in self.members:
                if m.daemon.poll() is not None and m.robot.name not in reported:
                    reported.add(m.robot.name)
                    self.say(f"{m.robot.name}: daemon ended with exit code {m.daemon.returncode}")
            if all(m.daemon.poll() is not None for m in self.members):
                return None
            time.sleep(POLL_S)
        return None

    def lost_bridge(self) -> str | None:
        """Why a robot is out of the cell's reach (its bridge ended, its daemon still runs), or None."""
        for m in self.members:  # (a bridge ends with 0 when its daemon has closed its socket: it is ending)
            if m.bridge is not None and m.bridge.poll() not in (None, 0) and m.daemon.poll() is None:
                return (f"{m.robot.name}: its bridge ended with exit code {m.bridge.returncode} "
                        f"(log {m.log.with_suffix('.bridge.log')}): the cell cannot e-stop it")
        return None

    # -- stop --------------------------------------------------------------------------
    def stop(self) -> int:
        """Stop everything that runs; the exit code: 0, or the first daemon's that is not."""
        running = [m for m in self.members if m.daemon is not None and m.daemon.poll() is None]
        for m in running:
            try:
                request(m.socket, "stop", timeout=1.0)
            except ControlSocketError:
                if not m.answered:  # still starting: it stops at SIGTERM, before its drives are enabled
                    m.daemon.send_signal(signal.SIGTERM)
                # else it is ending already (`cell stop`): a signal now could cut its last steps short
        _wait_all([m.daemon for m in running], STOP_S)
        _wait_all([m.daemon for m in running if m.daemon.poll() is None], TERM_S, signal.SIGTERM)
        bridges = [m.bridge for m in self.members if m.bridge is not None] + \
            ([self.arbiter] if self.arbiter is not None else [])
        _wait_all(bridges, TERM_S, signal.SIGTERM)
        for proc in [m.daemon for m in self.members if m.daemon] + bridges:  # ignored SIGTERM
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        codes = [m.daemon.returncode for m in self.members if m.daemon is not None]
        for m in self.members:
            if m.daemon is not None:
                self.say(f"{m.robot.name}: daemon exit code {m.daemon.returncode}, summary {m.summary}")
        # a daemon killed by a signal never confirmed its drives off: as `rtctl run` says of that (4)
        return next((c if c > 0 else EXIT_HARDWARE for c in codes if c != 0), 0)

    def pids(self) -> list[int]:
        return [p.pid for m in self.members for p in (m.daemon, m.bridge) if p is not None] + \
            ([self.arbiter.pid] if self.arbiter is not None else [])


def _wait_all(procs, timeout_s: float, sig=None) -> None:
    for p in procs:
        if sig is not None and p.poll() is None:
            p.send_signal(sig)
    deadline = time.monotonic() + timeout_s
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass


def _tail(path: Path, lines: int = 5) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""
