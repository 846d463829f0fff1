"""The bridge's loop without Zenoh or a daemon: a fake session records what is published and
a fake clock stands for time, so the rate is checked exactly, never by timing a run."""
from __future__ import annotations

import json

import pytest

from cell_helpers import write_cell
from rtctl.cell import bridge as bridge_module
from rtctl.cell.config import load_cell
from rtctl.errors import ControlSocketError


class FakePublisher:
    def __init__(self, log, key):
        self.log, self.key = log, key

    def put(self, payload):
        self.log.append((self.key, json.loads(payload)))


class FakeSession:
    def __init__(self):
        self.log, self.queryables = [], []

    def declare_publisher(self, key):
        return FakePublisher(self.log, key)

    def declare_queryable(self, key, callback):
        self.queryables.append(key)


class FakeClock:
    """``monotonic`` for the bridge and the ``stop`` event it waits on: a wait advances time."""

    def __init__(self, polls):
        self.now, self.polls = 0.0, polls

    def monotonic(self):
        return self.now

    def is_set(self):
        return self.polls <= 0

    def wait(self, delay):
        assert delay >= 0
        self.now += delay
        self.polls -= 1


@pytest.fixture
def cell(tmp_path):
    return load_cell(write_cell(tmp_path, 1), check_robots=False)


def run_bridge(cell, monkeypatch, statuses):
    """Serve until ``statuses`` (dicts, or exceptions to raise) run out; the published log."""
    clock = FakeClock(len(statuses))
    replies = iter(statuses)

    def fake_request(path, cmd, timeout):
        assert cmd == "status"
        reply = next(replies)
        if isinstance(reply, Exception):
            raise reply
        clock.now += 0.001  # a request takes a millisecond
        return reply

    monkeypatch.setattr(bridge_module, "request", fake_request)
    monkeypatch.setattr(bridge_module.time, "monotonic", clock.monotonic)
    session = FakeSession()
    b = bridge_module.Bridge(cell, cell.robots[0], "/nonexistent.sock", session)
    assert session.queryables == [cell.key("r0", "cmd", "*")]
    code = b.serve(clock)
    return code, session.log, clock


def status(tick, **changes):
    return {"ok": True, "t": tick * 0.002, "tick": tick, "q": [0.0] * 6, "qd": [0.0] * 6, "verdict": "OK",
            "estopped": False, "faults": [], "stopping": None} | changes


def test_one_state_per_period_at_the_configured_rate_and_a_status_every_second(cell, monkeypatch):
    n = 250
    code, log, clock = run_bridge(cell, monkeypatch, [status(5 * k) for k in range(n)])
    states = [m for key, m in log if key.endswith("/state")]
    assert code == 0 and [s["tick"] for s in states] == [5 * k for k in range(n)]
    assert clock.now == pytest.approx(n / cell.state_rate_hz)  # 100 Hz: one period per state, no drift
    assert [m["daemon"]["tick"] for key, m in log if key.endswith("/status")] == [0, 500, 1000]  # 1 Hz
    assert not [m for key, m in log if key.endswith("/events")]


def test_a_change_is_one_event_and_a_daemon_gone_ends_the_bridge(cell, monkeypatch):
    gone = ControlSocketError("no rtctl daemon")
    seq = [status(0), status(1), status(2, estopped=True, verdict="FALLBACK", faults=["operator e-stop"]),
           status(3, estopped=True, verdict="FALLBACK", faults=["operator e-stop"]), gone, gone, gone, status(9)]
    code, log, _ = run_bridge(cell, monkeypatch, seq)
    events = [m for key, m in log if key.endswith("/events")]
    assert code == 0
    assert [(e["event"], e.get("tick")) for e in events] == [
        ("verdict changed", 2), ("estopped changed", 2), ("faults changed", 2), ("daemon gone", None)]
    assert events[0]["from"] == "OK" and events[0]["to"] == "FALLBACK"
    assert [m["tick"] for key, m in log if key.endswith("/state")] == [0, 1, 2, 3]  # (status(9) never asked)


def test_a_status_refused_at_the_daemons_exit_is_not_a_state(cell, monkeypatch):
    """At its exit the daemon answers ``status`` with a refusal (no t, no tick: a KeyError ended the
    bridge with exit 1 in CI); it counts towards "daemon gone" like a connection that fails."""
    stopping = {"ok": False, "error": "the daemon is stopping (stop requested)", "stopping": True}
    code, log, _ = run_bridge(cell, monkeypatch, [status(0), status(1, verdict="DEACTIVATE"), stopping,
                                                  ControlSocketError("no rtctl daemon"), stopping])
    events = [m for key, m in log if key.endswith("/events")]
    assert code == 0 and [m["tick"] for key, m in log if key.endswith("/state")] == [0, 1]
    assert [e["event"] for e in events] == ["verdict changed", "daemon gone"]
    assert events[-1]["error"] == "the daemon is stopping (stop requested)"


def test_forward_refuses_what_the_cell_does_not_forward_and_garbled_payloads():
    assert "unknown command 'set'" in bridge_module.forward("/x.sock", "set", None)["error"]
    assert "not JSON" in bridge_module.forward("/x.sock", "move", b"{q:")["error"]
    assert "JSON object" in bridge_module.forward("/x.sock", "move", b"[1]")["error"]
    assert "no rtctl daemon" in bridge_module.forward("/nonexistent/x.sock", "status", None)["error"]


def test_query_all_refuses_a_name_that_is_not_one_key_chunk(cell):
    from rtctl.cell.commands import query_all

    for bad in ("*", "cmd/estop", "", 3):
        with pytest.raises(ValueError, match="name"):
            query_all(cell, None, bad)
    with pytest.raises(ValueError, match="fields"):
        query_all(cell, None, "move", [1, 2])
