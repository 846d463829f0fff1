"""The shared zone's fault matrix, each case checked from telemetry on one clock (docs/cell.md):
robot r0 works inside W (its job pauses there), r1's job waits at W's border, then

* r0's daemon is killed (SIGKILL): r1 does not enter W while r0's lease may be valid, nor
  before r0 — its daemon started again — reports itself outside;
* the link is cut (the arbiter is killed): r1 holds at the border, r0 stops inside, before its
  lease ends;
* the link is delayed by more than the lease (the arbiter stopped for d + m + 2 s, then resumed):
  never both inside, r0 stops inside.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

pytest.importorskip("zenoh", reason="the `cell` extra (eclipse-zenoh) is not installed: pip install 'rtctl[cell]'")

from cell_helpers import REPO, RUN_CONFIG, RunningCell  # noqa: E402
from rtctl.cell.config import load_cell  # noqa: E402
from rtctl.control_socket.client import request  # noqa: E402
from zone_helpers import (LEASE_MARGIN_S, LEASE_S, READY, SIGN, Track, arbiter_events,  # noqa: E402
                          never_both_inside, status, wait_for, write_zone_cell)

pytestmark = [pytest.mark.slow, pytest.mark.soak, pytest.mark.realtime, pytest.mark.timeout(400)]  # (each tens of seconds of real time: the soak run)


def visit(robot: str, pause_s: float) -> dict:
    """A ``move`` into the robot's region of W, a pause there, and back out."""
    centre = list(READY)
    centre[0] = SIGN[robot] * 0.55
    return {"waypoints": [centre, centre, READY], "times": [1.0, 1.0 + pause_s, 2.3 + pause_s]}


def zone(cell, robot):
    s = status(cell.run_dir, robot)
    return None if s is None else s["zones"]["fixture"]


def r0_inside_r1_waiting(tmp_path):
    """A running cell in which r0 holds W and is inside it, and r1 waits at the border."""
    path = write_zone_cell(tmp_path)
    cell = load_cell(path)
    running = RunningCell(path)
    wait_for(lambda: all(status(cell.run_dir, r) for r in ("r0", "r1")), "both daemons", 60.0)
    assert request(cell.run_dir / "r0.sock", "move", timeout=30.0, **visit("r0", 60.0))["ok"]
    wait_for(lambda: (zone(cell, "r0") or {}).get("inside") and zone(cell, "r0")["held"], "r0 inside W", 60.0)
    assert request(cell.run_dir / "r1.sock", "move", timeout=30.0, **visit("r1", 1.0))["ok"]
    wait_for(lambda: (zone(cell, "r1") or {}).get("waiting"), "r1 waiting at W's border", 30.0)
    return cell, running


def pid_of(running, what: str) -> int:
    for line in running.lines:
        if line.startswith(what):
            return int(line.split(" pid ")[1].split(",")[0].split()[0])
    raise AssertionError(f"no pid for {what!r} in {running.lines}")


def last_grant_s(cell, robot: str, before_s: float) -> float:
    grants = [e["t_ns"] * 1e-9 for e in arbiter_events(cell.run_dir)
              if e["event"] == "granted" and e["robot"] == robot and e["t_ns"] * 1e-9 <= before_s]
    assert grants, f"no grant to {robot}"
    return grants[-1]


def stopped_inside(track: Track, after_s: float) -> None:
    """Inside W when it stopped, with a GUARD fault, at rest at the end."""
    faults = track.summary["safety"]["faults"]
    assert any("shared zone" in f["reason"] for f in faults), faults
    assert track.inside[-1] and np.max(np.abs(track.qd[-1])) < 1e-2


def test_killed_daemon_inside_w_keeps_it_until_its_restart_reports_outside(tmp_path):
    cell, running = r0_inside_r1_waiting(tmp_path)
    own = []
    try:
        killed_s = time.monotonic()
        os.kill(pid_of(running, "r0: daemon"), signal.SIGKILL)
        time.sleep(LEASE_S + LEASE_MARGIN_S + 3.0)  # (what r1 does meanwhile is read from its telemetry)
        assert zone(cell, "r1")["waiting"] and not zone(cell, "r1")["inside"]
        # r0's daemon again (in the simulator it starts at the ready pose, outside W), and its bridge
        d = cell.run_dir
        argv = [sys.executable, "-m", "rtctl.cli", "run", str(RUN_CONFIG), "--sim", "--socket", str(d / "r0.sock"),
                "--telemetry", str(d / "r0b.msgpack"), "--summary", str(d / "r0b.summary.json"),
                "--cell", str(cell.file), "--cell-robot", "r0", "--log-format", "json"]
        env = os.environ | {"PYTHONPATH": str(REPO)}
        with (d / "r0b.log").open("w") as log:
            own.append(subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=env))
        wait_for(lambda: status(d, "r0"), "r0's daemon again", 120.0)
        with (d / "r0b.bridge.log").open("w") as log:
            own.append(subprocess.Popen([sys.executable, "-m", "rtctl.cell.bridge", json.dumps(
                {"cell": str(cell.file), "robot": "r0", "socket": str(d / "r0.sock")})], stdout=log,
                stderr=subprocess.STDOUT, env=env))
        wait_for(lambda: (s := status(d, "r1")) and s["gate"]["finished"], "r1's job to finish", 90.0)
    finally:
        try:
            request(cell.run_dir / "r0.sock", "stop")
        except Exception:  # noqa: BLE001 - (already gone)
            pass
        for p in own:
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                p.terminate()
                p.wait(15)
        running.close()
    r1 = Track(cell.run_dir, "r1")
    granted_r0 = last_grant_s(cell, "r0", killed_s)
    confirmed = [e["t_ns"] * 1e-9 for e in arbiter_events(cell.run_dir)
                 if e["event"] == "confirmed outside" and e["robot"] == "r0" and e["t_ns"] * 1e-9 > killed_s]
    entered = r1.inside_times()
    assert entered.size, "r1 never entered W"
    assert entered[0] >= granted_r0 + LEASE_S + LEASE_MARGIN_S  # r0's lease provably expired first
    assert confirmed and entered[0] >= confirmed[0]  # and r0 had reported itself outside
    r0b = Track(cell.run_dir, "r0", cell.run_dir / "r0b.msgpack", cell.run_dir / "r0b.summary.json")
    never_both_inside(r0b, r1)
    print(f"\nkill: r0 killed inside W; its last grant {killed_s - granted_r0:.2f} s before; r1 entered "
          f"{entered[0] - killed_s:.2f} s after the kill, {entered[0] - (granted_r0 + LEASE_S + LEASE_MARGIN_S):.2f} s "
          f"after the lease's end at the arbiter, {entered[0] - confirmed[0]:.3f} s after r0's restart reported "
          f"it outside")


def test_cut_link_robot_outside_holds_at_the_border_robot_inside_stops(tmp_path):
    cell, running = r0_inside_r1_waiting(tmp_path)
    try:
        cut_s = time.monotonic()
        os.kill(pid_of(running, "shared zones: arbiter"), signal.SIGKILL)
        # (a latched fault holds the arm, then its drives go off and the daemon ends: exit 3)
        wait_for(lambda: (s := status(cell.run_dir, "r0")) is None or s["faults"], "r0 to stop", LEASE_S + 10.0)
        time.sleep(2.0)
        code, out = running.finish(signal.SIGTERM)
    finally:
        running.close()
    r0, r1 = Track(cell.run_dir, "r0"), Track(cell.run_dir, "r1")
    never_both_inside(r0, r1)
    assert not r1.inside.any() and r1.waiting[-1] == 1  # held at the border
    assert 0 < r1.depth[-1] < 2 * 0.0524  # (at the border: within two gate margins (3°) of W)
    stopped_inside(r0, cut_s)
    fault_s = r0.summary["clock"]["tick0_monotonic_ns"] * 1e-9 + r0.summary["safety"]["faults"][0]["t"]
    grant = last_grant_s(cell, "r0", cut_s)
    assert fault_s <= grant + LEASE_S  # stopped before its own view of the lease ended
    print(f"\ncut: arbiter killed; r0 stopped inside {fault_s - cut_s:.2f} s later, {grant + LEASE_S - fault_s:.2f} s "
          f"before its lease's end; r1 held at {r1.depth[-1]:.4f} rad from W")


def test_delayed_link_longer_than_the_lease_never_both_inside(tmp_path):
    cell, running = r0_inside_r1_waiting(tmp_path)
    arbiter = pid_of(running, "shared zones: arbiter")
    try:
        delayed_s = time.monotonic()
        os.kill(arbiter, signal.SIGSTOP)
        time.sleep(LEASE_S + LEASE_MARGIN_S + 2.0)
        os.kill(arbiter, signal.SIGCONT)
        time.sleep(5.0)
        code, out = running.finish(signal.SIGTERM)
    finally:
        try:
            os.kill(arbiter, signal.SIGCONT)
        except ProcessLookupError:
            pass
        running.close()
    r0, r1 = Track(cell.run_dir, "r0"), Track(cell.run_dir, "r1")
    never_both_inside(r0, r1)
    stopped_inside(r0, delayed_s)
    assert not r1.inside.any()
    print(f"\ndelay: arbiter stopped {LEASE_S + LEASE_MARGIN_S + 2.0:.2f} s; r0 stopped inside, r1 never entered")
