"""`hil-sim` as a separate process, run configurations derived from the shipped HIL ones, and
`rtctl run` against them (reusing tests/runtime/runtime_helpers)."""
from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
from runtime_helpers import Daemon, rtctl  # noqa: E402,F401  (re-exported)
from stalls import VmStall  # noqa: E402  (what unless_stalled raises; the HIL tests import it here)

from rtctl.control_socket import request  # noqa: E402
from rtctl.telemetry import read  # noqa: E402

CONFIGS = ROOT / "configs"
# This shared 2-core VM stalls a process now and then, even at SCHED_FIFO (the host takes the
# CPU: ~90 ms of steal time in 10 s measured; hil-sim then sends nothing for 5–20 ms). A run
# whose test is about something else gives the drives (and the driver's gap check) a 250 ms
# watchdog (hil-sim's MIT drives take their device's) and the stale-data checks 50 ticks, as the soak does, so that such a stall is not a
# fault; the 20 ms watchdog and the shipped 3-tick stale limit are exercised by the fault tests.
STALL_TOLERANT = {"drive_timeout": 0.25, "stale_limit": 50, "stale_ticks": 50}


def check_turned_off_by_exit(sim, sim_exit) -> None:
    """Every drive ended out of motor mode because it heard exit motor mode, not by its own
    watchdog: a drive whose exit frames were lost (the daemon closed its link on a late reply
    taken for the answer) passes "not enabled" once its watchdog fired before hil-sim stopped."""
    assert not any(d["enabled"] for d in sim_exit["drives"]), "a drive was left in motor mode"
    last = {e["drive"]: (e["event"], e["cause"]) for e in sim.events if e.get("event") in ("motor_on", "motor_off")}
    assert last and all(last.get(d["drive"]) == ("motor_off", "command") for d in sim_exit["drives"]), last


class HilSim:
    """``hil-sim CONFIG ARGS…`` in its own process; ``info`` is its first JSON line."""

    def __init__(self, config, *args, timeout: float = 60.0):
        # the drives at SCHED_FIFO below the loop's 80 (where permitted): as on a real bench, a
        # drive answers whatever else the machine is doing
        self.proc = subprocess.Popen([sys.executable, "-m", "hil_sim.cli", str(config), "--rt-priority", "70",
                                      *map(str, args)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        self.events: list[dict] = []
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line:
            self.proc.kill()
            _, err = self.proc.communicate()
            raise AssertionError(f"hil-sim did not announce itself: {err}")
        self.info = json.loads(line)

    def env(self) -> dict:
        return {**os.environ, **self.info["env"]}

    def stop(self, timeout: float = 15.0) -> dict:
        """SIGTERM, then its events; returns the exit event."""
        self.proc.send_signal(signal.SIGTERM)
        out, err = self.proc.communicate(timeout=timeout)
        assert self.proc.returncode == 0, err
        self.events = [json.loads(line) for line in out.splitlines() if line.strip()]
        exits = [e for e in self.events if e.get("event") == "exit"]
        assert exits, f"no exit event from hil-sim: {out[-2000:]} {err[-2000:]}"
        return exits[-1]

    def of(self, kind: str) -> list[dict]:
        return [e for e in self.events if e.get("event") == kind]

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


def variant(tmp_path: Path, shipped: str, name: str = "run.toml", **settings) -> Path:
    """A copy of ``configs/<shipped>`` in ``tmp_path``: robot path made absolute, telemetry
    dropped (the tests pass --telemetry), and ``key = value`` lines replaced by ``settings``.
    A setting the shipped file does not have is an error (it would silently not apply)."""
    text = (CONFIGS / shipped).read_text()
    text = text.replace('description = "robots/', f'description = "{CONFIGS}/robots/')
    lines, applied = [], set()
    for line in text.splitlines():
        key = line.split("=", 1)[0].strip()
        if key in settings:
            line = f"{key} = {settings[key]}"
            applied.add(key)
        if not line.startswith("path = "):
            lines.append(line)
    missing = sorted(set(settings) - applied)
    if missing:
        raise KeyError(f"configs/{shipped} has no {', '.join(missing)} to set")
    path = tmp_path / name
    path.write_text("\n".join(lines).replace("[telemetry]", "") + "\n")
    return path


def run(config, tmp_path: Path, env: dict, *extra, duration: float = 3.0, timeout: float = 90.0):
    """``rtctl run`` to the end; (returncode, summary, telemetry, stderr)."""
    telemetry, summary = tmp_path / "run.msgpack", tmp_path / "summary.json"
    result = rtctl("run", config, "--duration", duration, "--telemetry", telemetry, "--summary", summary,
                   "--socket", tmp_path / "rtctl.sock", *extra, env=env, timeout=timeout)
    assert summary.exists(), result.stderr[-3000:]
    return result.returncode, json.loads(summary.read_text()), read(telemetry), result.stderr


def stall_in(summary: dict) -> str | None:
    """What in the run's own record shows a stall of this (shared, virtual) machine: an
    overrun of the loop, a wake-up later than half a period, or replies the simulator's process
    did not send in time (the CAN drives' missing replies, the leg board's late ones), or
    telemetry rows the recorder dropped because its writer fell behind. None when the run was quiet."""
    timing = summary["timing"]
    late_us = (timing.get("wake_lateness_us") or {}).get("max") or 0.0
    devices = summary.get("devices", {}).values()
    missing = sum((d.get("counters") or {}).get("missing_replies", 0) + d.get("late_replies", 0) for d in devices)
    signs = []
    if timing["overruns"]:
        signs.append(f"{timing['overruns']} overrun(s)")
    if late_us > timing["period_us"] / 2:
        signs.append(f"a wake-up {late_us:.0f} µs late")
    if missing:
        signs.append(f"{missing} missing or late repl(ies)")
    if (dropped := (summary.get("telemetry") or {}).get("dropped_rows")):
        signs.append(f"{dropped} telemetry row(s) dropped")
    return ", ".join(signs) or None


@contextmanager
def unless_stalled(summary: dict):
    """Check bounds inside: a failed one is a VmStall (retried) when the run's record shows a
    stall, and a plain failure (not retried) when the run was quiet."""
    try:
        yield
    except AssertionError as e:
        stall = stall_in(summary)
        if stall is None:
            raise
        raise VmStall(f"machine stall ({stall}): {e}") from e


def wait_for(predicate, timeout: float = 30.0, step: float = 0.05) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return False


def loop_time(daemon) -> float:
    """The running loop's time (−1 before it runs: the control socket answers from the loop only)."""
    try:
        return request(daemon.socket, "status", timeout=0.5)["t"]
    except Exception:
        return -1.0


def run_with_a_frozen_loop(config, tmp_path: Path, env: dict, pause: float = 0.3):
    """``rtctl run`` stopped (SIGSTOP) for ``pause`` s once its loop has run 0.5 s with the drives
    enabled, then resumed to its end; (returncode, summary, telemetry, stderr)."""
    telemetry = tmp_path / "run.msgpack"
    saved = dict(os.environ)
    os.environ.update(env)  # the Daemon helper inherits the environment
    try:
        d = Daemon(config, tmp_path, "--duration", 20, "--telemetry", telemetry)
    finally:
        os.environ.clear()
        os.environ.update(saved)
    try:
        assert wait_for(lambda: loop_time(d) > 0.5 or d.proc.poll() is not None)
        d.proc.send_signal(signal.SIGSTOP)  # the loop freezes mid-run
        time.sleep(pause)
        d.proc.send_signal(signal.SIGCONT)
        code, out, err = d.finish(timeout=60)
    finally:
        d.kill()
    return code, json.loads(d.summary.read_text()), read(telemetry), err


def check_reopened_and_stopped(summary, device: str = "arm", within: float = 2.0) -> tuple[float, float]:
    """After a dropped link: ``device`` lost its bus, reopened it, and the safety stage turned the
    drives off within ``within`` s of the loss (loop time); (reopened after, off after)."""
    dev = summary["devices"][device]
    events = {e["event"]: e for e in reversed(dev["events"])}  # the first of each kind
    assert dev["counters"]["bus_errors"] >= 1 and dev["counters"]["reconnects"] >= 1, dev["counters"]
    assert events["bus_back"]["t"] > events["bus_lost"]["t"]
    stop = [e for e in summary["safety"]["events"] if e["event"] == "deactivate"][0]
    reopened, off = events["bus_back"]["t"] - events["bus_lost"]["t"], stop["t"] - events["bus_lost"]["t"]
    print(f"link lost → reopened after {reopened:.3f} s, drives off after {off:.3f} s (loop time)")
    assert off <= within
    return reopened, off
