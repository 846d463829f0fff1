"""A running two-robot cell (``rtctl cell up`` on the embedded simulator, loopback): its
commands reach both daemons through Zenoh, each bridge publishes its robot's state, a session
without the cell's credentials is refused, and every process ends when the cell is stopped.

What a command did is read back from the daemons' control sockets directly, not through the
cell: the check does not go through the path it checks."""
from __future__ import annotations

import json
import os
import re
import signal
import socket
import threading
import time

import pytest

pytest.importorskip("zenoh", reason="the `cell` extra (eclipse-zenoh) is not installed: pip install 'rtctl[cell]'")

from cell_helpers import (OBSERVER, OBSERVER_PASSWORD, OTHER, OTHER_PASSWORD, PASSWORD, USER,  # noqa: E402
                          RunningCell, alive, rtctl, write_cell)
from rtctl.cell.commands import query_all  # noqa: E402
from rtctl.cell.config import load_cell  # noqa: E402
from rtctl.cell.session import open_client_session  # noqa: E402
from rtctl.control_socket.client import request  # noqa: E402

pytestmark = [pytest.mark.timeout(300), pytest.mark.realtime]  # (tests/conftest.py)


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    path = write_cell(tmp_path_factory.mktemp("cell"))
    running = RunningCell(path)
    yield load_cell(path), running
    running.close()


def daemon_status(cell, robot: str) -> dict:
    return request(cell.run_dir / f"{robot}.sock", "status")


def test_up_shows_every_robots_status(cell):
    cfg, running = cell
    table = "".join(running.lines)
    for r in cfg.robots:
        assert f"{r.name}: running; bridge pid" in table
        assert any(line.split()[:2] == [r.name, "yes"] for line in running.lines)


def test_the_bridges_run_at_the_cells_priority_below_the_loops(cell):
    """The e-stop's path: every thread of each bridge (Zenoh's too) at SCHED_FIFO bridge_priority,
    each daemon's loop above it (this machine grants SCHED_FIFO; where it does not, both run on)."""
    cfg, running = cell
    bridges = [int(p) for line in running.lines for p in re.findall(r"bridge pid (\d+)", line)]
    assert len(bridges) == len(cfg.robots)
    for pid in bridges:
        threads = [int(t) for t in os.listdir(f"/proc/{pid}/task")]
        assert len(threads) > 1  # (Zenoh's runtime threads)
        for tid in threads:
            assert os.sched_getscheduler(tid) == os.SCHED_FIFO, tid
            assert os.sched_getparam(tid).sched_priority == cfg.bridge_priority == 60
    for pid in (int(p) for line in running.lines for p in re.findall(r"daemon pid (\d+)", line)):
        assert os.sched_getparam(pid).sched_priority > cfg.bridge_priority  # (the loop's thread is the main one)


def test_each_bridge_publishes_its_robots_state(cell):
    cfg, _ = cell
    session, peers = open_client_session(cfg)
    got: dict[str, list] = {r.name: [] for r in cfg.robots}
    lock = threading.Lock()

    def on_state(sample):
        with lock:
            got[str(sample.key_expr).split("/")[2]].append(json.loads(sample.payload.to_bytes()))

    sub = session.declare_subscriber(cfg.key("*", "state"), on_state)
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and min(len(v) for v in got.values()) < 5:
            time.sleep(0.05)
    finally:
        sub.undeclare()
        session.close()
    assert peers == len(cfg.robots)
    for robot, states in got.items():
        assert len(states) >= 5, robot
        s = states[-1]
        assert s["robot"] == robot and len(s["q"]) == 6 and len(s["qd"]) == 6 and s["verdict"] == "OK"
        ticks = [x["tick"] for x in states]
        assert ticks == sorted(ticks) and ticks[-1] > ticks[0]  # a fresh state each period, in order


@pytest.mark.parametrize("credentials", [None, (USER, "wrong"), ("intruder", PASSWORD)],
                         ids=["no credentials", "wrong password", "unknown user"])
def test_a_session_without_the_cells_credentials_is_refused(cell, credentials):
    cfg, _ = cell
    session, peers = open_client_session(cfg, credentials=credentials, wait_s=1.0)
    try:
        replies = query_all(cfg, session, "estop", timeout_s=1.0)
    finally:
        session.close()
    assert peers == 0  # no link was opened
    assert all(not r["ok"] and "no reply" in r["error"] for r in replies.values())
    for r in cfg.robots:
        assert daemon_status(cfg, r.name)["estopped"] is False  # the e-stop did not arrive


def states_and_estop(cfg, credentials) -> tuple[int, int, dict]:
    """(bridges linked, state messages received within 2 s, the replies to an e-stop) for a
    session with ``credentials``."""
    session, peers = open_client_session(cfg, credentials=credentials)
    got = []
    sub = session.declare_subscriber(cfg.key("*", "state"), lambda sample: got.append(1))
    try:
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline and len(got) < 10:
            time.sleep(0.05)
        replies = query_all(cfg, session, "estop", timeout_s=1.0)
    finally:
        sub.undeclare()
        session.close()
    return peers, len(got), replies


def test_access_control_an_observer_sees_the_state_but_cannot_command(cell):
    cfg, _ = cell
    peers, states, replies = states_and_estop(cfg, (OBSERVER, OBSERVER_PASSWORD))
    assert peers == len(cfg.robots) and states >= 10  # authenticated, and allowed to subscribe
    assert all(not r["ok"] and "no reply" in r["error"] for r in replies.values())
    peers, states, replies = states_and_estop(cfg, (OTHER, OTHER_PASSWORD))  # in the dictionary, no policy
    assert peers == len(cfg.robots) and states == 0
    assert all(not r["ok"] and "no reply" in r["error"] for r in replies.values())
    for r in cfg.robots:
        assert daemon_status(cfg, r.name)["estopped"] is False  # neither e-stop arrived


def test_cell_estop_reaches_every_loop_and_reset_clears_it(cell):
    cfg, _ = cell
    out = rtctl("cell", "estop", str(cfg.file))
    assert out.returncode == 0, out.stdout + out.stderr
    for r in cfg.robots:
        s = daemon_status(cfg, r.name)
        assert s["estopped"] is True and s["faults"] == ["operator e-stop"]
    time.sleep(0.05)
    out = rtctl("cell", "reset", str(cfg.file))
    assert out.returncode == 0, out.stdout + out.stderr
    for r in cfg.robots:
        s = daemon_status(cfg, r.name)
        assert s["estopped"] is False and s["faults"] == []
    out = rtctl("cell", "status", str(cfg.file))
    assert out.returncode == 0 and out.stdout.count(" yes ") >= len(cfg.robots), out.stdout


def test_a_command_the_cell_does_not_forward_is_refused_by_the_bridge(cell):
    cfg, _ = cell
    session, _ = open_client_session(cfg)
    try:
        replies = query_all(cfg, session, "set", {"key": "ct.kp", "value": 1.0})
    finally:
        session.close()
    assert all(not r["ok"] and "unknown command 'set'" in r["error"] for r in replies.values())
    assert request(cfg.run_dir / "r0.sock", "get", key="ct.kp")["value"] == [400.0] * 6


@pytest.mark.parametrize("how, n", [("SIGINT", 1), ("cell stop", 2)])  # (SIGTERM: the test below)
def test_stopping_the_cell_leaves_nothing_running(tmp_path, how, n):
    path = write_cell(tmp_path, n)
    running = RunningCell(path)
    assert len(running.pids) == 2 * n  # the daemons and their bridges
    assert all(alive(p) for p in running.pids)
    if how == "cell stop":
        out = rtctl("cell", "stop", str(path))
        assert out.returncode == 0, out.stdout + out.stderr
        code, rest = running.finish()
    else:
        code, rest = running.finish(getattr(signal, how))
    assert code == 0, rest
    assert not [p for p in running.pids if alive(p)]
    for i in range(n):
        summary = json.loads((tmp_path / "run" / f"r{i}.summary.json").read_text())
        assert summary["exit_code"] == 0 and summary["telemetry"]["rows"] > 0


def test_up_with_robot_starts_only_that_robot_and_sigterm_stops_it(tmp_path):
    path = write_cell(tmp_path, 2)
    running = RunningCell(path, extra_args=("--robot", "r1"))
    try:
        assert len(running.pids) == 2  # r1's daemon and bridge
        table = {line.split()[0]: line.split()[1] for line in running.lines if line.startswith(("r0 ", "r1 "))}
        assert table == {"r0": "NO", "r1": "yes"}  # r0 is another host's: not started here, not reachable
        assert not (tmp_path / "run" / "r0.log").exists()
    finally:
        code, rest = running.finish(signal.SIGTERM)
    assert code == 0, rest
    assert not [p for p in running.pids if alive(p)]


def test_a_bridge_that_cannot_start_stops_the_cell(tmp_path):
    path = write_cell(tmp_path, 1)
    port = load_cell(path, check_robots=False).robots[0].port
    with socket.socket() as taken:  # something else listens on the bridge's endpoint
        taken.bind(("127.0.0.1", port))
        taken.listen()
        out = rtctl("cell", "up", str(path), timeout=240)
    assert out.returncode == 2, out.stdout + out.stderr
    assert "r0: its bridge ended with exit code 6" in out.stderr and "the cell cannot e-stop it" in out.stderr
    assert "Address already in use" in (tmp_path / "run" / "r0.bridge.log").read_text()
    pids = [int(p) for p in re.findall(r"(?:daemon|bridge) pid (\d+)", out.stdout)]
    assert len(pids) == 2 and not [p for p in pids if alive(p)]
