"""``rtctl bench cell``: a cell of 1, 2 and 4 PUMAs on the embedded simulator (the shipped
configs/cell/puma560_cell_sim.toml at 500 Hz — four of them at 250 Hz, what two shared cores
hold — or ``--config``) on this machine, over loopback, with the cell on and off, side by side.

Per cell size and variant: ``trials`` e-stops of every robot, each followed by a ``reset``.
With the cell on, one Zenoh query reaches every bridge, as ``rtctl cell estop`` does; with it
off, the daemons run alone (no bridge, no Zenoh) and each e-stop goes straight to each control
socket in turn, as ``rtctl estop`` does. The latency of one robot's e-stop is measured on one
clock, CLOCK_MONOTONIC: from the moment the command is sent to the start of the tick that acts
on it — the tick after the one whose safety event latched the e-stop (the daemon serves its
control socket after each tick; the safety stage acts at the next check), placed on the clock
by the daemon's own ``clock.tick0_monotonic_ns`` in its summary. That tick's compute comes on
top. Also: the command's round trip (every robot answered), the state messages per second
the bridges published, and each loop's compute and wake-lateness p99 over its run.
"""
from __future__ import annotations

import json
import re
import secrets
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from rtctl.errors import RtctlError

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "cell" / "puma560_cell_sim.toml"
GOAL_P99_MS = 20.0
# (robots, loop rate override): four PUMAs at 500 Hz, each with its bridge, do not fit two cores
# that the machine shares (overruns in every loop); at 250 Hz they do
SIZES = ((1, None), (2, None), (4, 250.0))
SETTLE_S = 0.05  # between an e-stop and its reset, and after the reset


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _at_rate(config: Path, rate: float | None, folder: Path) -> Path:
    """``config`` as it is, or a copy in ``folder`` whose loop runs at ``rate`` (its robot
    description made absolute, so that the copy loads the same robot)."""
    if rate is None:
        return config
    text = config.read_text()
    text, n_rate = re.subn(r"^rate_hz\s*=.*$", f"rate_hz = {rate!r}", text, count=1, flags=re.M)
    description = re.search(r'^description\s*=\s*"([^"]+)"', text, flags=re.M)
    if not n_rate or description is None:
        raise RtctlError(f"bench cell: {config} has no [loop] rate_hz or [robot] description to adapt")
    target = (config.parent / description.group(1)).resolve()
    text = text.replace(description.group(0), f'description = "{target}"', 1)
    path = folder / f"robot_{rate:g}hz.toml"
    path.write_text(text)
    return path


def _write_cell(folder: Path, config: Path, n: int, bridge_priority: int | None = None) -> Path:
    (folder / "users").write_text(f"bench:{secrets.token_hex(16)}\n")
    robots = "".join(f'\n[[robots]]\nname = "r{i}"\nconfig = "{config}"\nport = {_free_port()}\nsim = true\n'
                     for i in range(n))
    path = folder / "cell.toml"
    priority = "" if bridge_priority is None else f"bridge_priority = {bridge_priority}\n"
    path.write_text(f'[cell]\nname = "bench{n}"\nrun_dir = "run"\n{priority}\n[auth]\nuser = "bench"\n'
                    f'dictionary_file = "users"\n{robots}')
    return path


class _Zenoh:
    """Commands as ``rtctl cell …`` sends them, and a count of the state messages."""

    def __init__(self, cell):
        from rtctl.cell.session import open_client_session

        self.cell = cell
        self.session, peers = open_client_session(cell, wait_s=15.0)
        if peers < len(cell.robots):
            raise RtctlError(f"bench cell: {peers} of {len(cell.robots)} bridges reachable")
        self.states, self.lock = 0, threading.Lock()
        self.sub = self.session.declare_subscriber(cell.key("*", "state"), self._count)

    def _count(self, _) -> None:
        with self.lock:
            self.states += 1

    def send(self, name: str) -> list[dict]:
        from rtctl.cell.commands import query_all

        return list(query_all(self.cell, self.session, name).values())

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()


class _Sockets:
    """Commands as ``rtctl estop`` sends them, to each daemon in turn."""

    states = None

    def __init__(self, members):
        self.members = members

    def send(self, name: str) -> list[dict]:
        from rtctl.control_socket.client import request

        return [request(m.socket, name) for m in self.members]

    def close(self) -> None:
        pass


def _run_cell(config: Path, n: int, trials: int, cell_on: bool, rate: float | None = None,
              bridge_priority: int | None = None) -> dict:
    from rtctl.cell.config import load_cell
    from rtctl.cell.supervisor import CellProcesses

    with tempfile.TemporaryDirectory(prefix="rtctl-bench-cell-") as folder:
        config = _at_rate(config, rate, Path(folder))
        rate_hz = _rate(config)
        cell = load_cell(_write_cell(Path(folder), config, n, bridge_priority))
        procs = CellProcesses(cell, say=lambda _: None)
        sent_ns, round_trip_ns, refused = [], [], 0
        try:
            procs.start(600.0, bridges=cell_on)
            link = _Zenoh(cell) if cell_on else _Sockets(procs.members)
            t_start = time.monotonic()
            if cell_on:
                link.states = 0
            for _ in range(trials):
                t0 = time.monotonic_ns()
                replies = link.send("estop")
                round_trip_ns.append(time.monotonic_ns() - t0)
                sent_ns.append(t0)
                refused += sum(not r["ok"] for r in replies)
                time.sleep(SETTLE_S)
                refused += sum(not r["ok"] for r in link.send("reset"))
                time.sleep(SETTLE_S)
            elapsed = time.monotonic() - t_start
            states = link.states
            link.close()
        finally:
            code = procs.stop()
        summaries = [json.loads(m.summary.read_text()) for m in procs.members]
    period_ns = 1e9 / rate_hz
    latencies = []
    for m, s in zip(procs.members, summaries):
        ticks = [e["tick"] for e in s["safety"]["events"]
                 if e["event"] == "fault" and e.get("reason") == "operator e-stop"]
        if len(ticks) != trials:
            raise RtctlError(f"bench cell: {m.robot.name} latched {len(ticks)} e-stops of {trials} "
                             f"(exit code {s['exit_code']}: {s['stop_reason']})")
        tick0 = s["clock"]["tick0_monotonic_ns"]
        latencies += [(tick0 + (k + 1) * period_ns - t0) / 1e6 for k, t0 in zip(ticks, sent_ns)]
    lat = np.array(latencies)
    return {"robots": n, "rate_hz": rate_hz, "cell": "on" if cell_on else "off", "trials": trials, "exit_code": code,
            "refused_replies": refused,
            "estop_ms": {"p50": float(np.percentile(lat, 50)), "p99": float(np.percentile(lat, 99)),
                         "max": float(lat.max())},
            "estop_ms_each": [round(x, 3) for x in latencies],  # robot by robot, trial by trial
            "round_trip_ms_p99": float(np.percentile(round_trip_ns, 99)) / 1e6,
            "state_msgs_per_s": None if states is None else states / elapsed,
            "loops": [{"robot": m.robot.name, "rate_hz": s["timing"].get("achieved_rate_hz"),
                       "compute_p99_us": ((s["timing"].get("compute_us") or {}).get("tick") or {}).get("p99"),
                       "lateness_p99_us": (s["timing"].get("wake_lateness_us") or {}).get("p99"),
                       "overruns": s["timing"].get("overruns")} for m, s in zip(procs.members, summaries)]}


def _rate(config: Path) -> float:
    from rtctl.config import load_config

    return load_config(config, sim=True).loop.rate_hz


def bench_cell(config=None, trials: int = 100, sizes=SIZES) -> dict:
    """Per size: the cell off, then on (alternating, so that a change in the machine's load
    falls on both)."""
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise ValueError(f"trials: expected an integer ≥ 1, got {trials!r}")
    config = Path(config or SHIPPED).resolve()
    label = str(config.relative_to(Path.cwd())) if config.is_relative_to(Path.cwd()) else str(config)
    return {"config": label, "rate_hz": _rate(config), "goal_estop_p99_ms": GOAL_P99_MS,
            "cells": [_run_cell(config, n, trials, on, rate) for n, rate in sizes for on in (False, True)]}


def format_table(result: dict) -> str:
    lines = [f"cell-wide e-stop on loopback ({result['config']}, {result['rate_hz']:g} Hz loops; goal with the cell "
             f"on: p99 ≤ {result['goal_estop_p99_ms']:g} ms). off: daemons alone, e-stop on each control socket",
             f"{'robots':>6} {'cell':>4} {'trials':>6} {'e-stop p50':>10} {'p99':>8} {'max':>8} {'cmd p99':>8} "
             f"{'state msg/s':>11}  loops: compute p99 / lateness p99 (µs) / overruns"]
    for c in result["cells"]:
        loops = ", ".join(f"{lp['robot']} {lp['compute_p99_us']:.0f}/{lp['lateness_p99_us']:.0f}/{lp['overruns']}"
                          for lp in c["loops"])
        e = c["estop_ms"]
        msgs = "-" if c["state_msgs_per_s"] is None else f"{c['state_msgs_per_s']:.0f}"
        rate = "" if c["rate_hz"] == result["rate_hz"] else f" (at {c['rate_hz']:g} Hz)"
        lines.append(f"{c['robots']:>6} {c['cell']:>4} {c['trials']:>6} {e['p50']:>7.2f} ms {e['p99']:>5.2f} ms "
                     f"{e['max']:>5.2f} ms {c['round_trip_ms_p99']:>5.2f} ms {msgs:>11}  {loops}{rate}")
    by = {(c["robots"], c["cell"]): c for c in result["cells"]}
    for n in sorted({c["robots"] for c in result["cells"]}):
        if (n, "on") in by and (n, "off") in by:
            worst = [max(lp[key] for lp in by[n, on]["loops"]) for key in ("compute_p99_us", "lateness_p99_us")
                     for on in ("on", "off")]
            lines.append(f"{n} robot(s), the worst loop, cell on / off: compute p99 {worst[0] / worst[1]:.2f}, "
                         f"wake lateness p99 {worst[2]:.0f} / {worst[3]:.0f} µs (goal: compute within 1.10)")
    return "\n".join(lines)
