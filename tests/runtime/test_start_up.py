"""rtctl.start_up: a `stop` or an `estop` sent while the daemon starts is answered while the
step in progress runs (loading kernels, configuring or activating a device), and the start
ends before the next step — with every drive off, `estop` as a fault (exit 3)."""
from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import pytest

from rtctl.config import load_config
from rtctl.control_socket import request
from rtctl.daemon import Daemon
from rtctl.runtime import build
from runtime_helpers import BASE

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

NO_REPLY_S = 20.0  # a step gives up waiting for the client's reply: the serving did not happen


def _blocking(step, replied: threading.Event, calls: list):
    """``step`` that first waits until the client has its reply: only a socket served while
    this step runs lets it go on."""
    def blocked(*a, **kw):
        calls.append(step.__name__)
        if not replied.wait(NO_REPLY_S):
            raise AssertionError(f"no reply to the client while {step.__name__} ran")
        return step(*a, **kw)
    return blocked


def _daemon_blocked_in(step, write_config, tmp_path):
    """A daemon on the base config whose simulated device's ``step`` waits for the client's reply:
    (daemon, args, device, the reply's event, the calls made)."""
    cfg = load_config(write_config(BASE))
    args = SimpleNamespace(telemetry=None, socket=str(tmp_path / "s.sock"), enforce_rt=False, duration=3600.0,
                           summary=None, log_level="error")
    d = Daemon(cfg, build(cfg), args)
    (sim,) = d.rt.all_devices
    replied, calls = threading.Event(), []
    setattr(sim, step, _blocking(getattr(sim, step), replied, calls))
    return d, args, sim, replied, calls


def _run_beside(d, operator, replied) -> int:
    """``d.run()`` with ``operator`` in a thread beside it; the blocked step is let go at the end
    whatever happened (a failed operator must not leave the daemon waiting)."""
    thread = threading.Thread(target=operator)
    thread.start()
    try:
        return d.run()
    finally:
        replied.set()
        thread.join()


@pytest.mark.parametrize("step, cmd, code, reason", [
    ("warm_up", "stop", 0, "stop requested"),  # the first kernel group, loaded in the daemon's process
    ("configure", "stop", 0, "stop requested"),
    ("configure", "estop", 3, "operator e-stop before start: no drive was enabled"),
    ("activate", "estop", 3, "operator e-stop during start-up: sim disabled again"),
])
def test_a_stop_during_a_start_up_step_is_answered_then_and_ends_the_start(write_config, tmp_path, step, cmd, code,
                                                                           reason):
    d, args, sim, replied, calls = _daemon_blocked_in(step, write_config, tmp_path)
    seen = {}
    activate = sim.activate
    sim.activate = lambda: (calls.append("activate called"), activate())[1]

    def operator():
        end = time.monotonic() + 60
        while not (tmp_path / "s.sock").exists() and time.monotonic() < end:
            time.sleep(0.005)
        while step not in calls and time.monotonic() < end:  # the step is running (blocked)
            time.sleep(0.005)
        try:
            seen["reply"] = request(args.socket, cmd, timeout=10.0)
        finally:
            replied.set()

    code_seen = _run_beside(d, operator, replied)
    assert seen["reply"]["ok"], seen
    assert code_seen == code
    assert d.stop_reason == reason
    assert not d.running  # the loop never started
    assert ("activate called" in calls) == (step == "activate"), calls  # no step after the stop
    assert sim.lifecycle.value != "active", sim.lifecycle  # (closed: the clean-up disabled what was enabled)


@pytest.mark.parametrize("step, doing", [
    ("warm_up", "loading the compiled kernels"),
    ("configure", "configuring sim"),
    ("activate", "activating sim"),
])
def test_a_status_during_a_start_up_step_is_answered_then_with_what_the_daemon_does(write_config, tmp_path, step,
                                                                                     doing):
    """Not held for the loop: a status (or a move) sent while a step runs is answered while it
    runs — not ok, the daemon is starting, and the step it is in — and the start goes on."""
    d, args, sim, replied, calls = _daemon_blocked_in(step, write_config, tmp_path)
    seen = {}

    def operator():
        end = time.monotonic() + 60
        while step not in calls and time.monotonic() < end:  # the step is running (blocked)
            time.sleep(0.005)
        try:
            seen["status"] = request(args.socket, "status", timeout=10.0)
            seen["move"] = request(args.socket, "move", timeout=10.0, q=[0.0] * d.model.nq)
        finally:
            replied.set()
        while not d.running and time.monotonic() < end:
            time.sleep(0.005)
        seen["running"] = request(args.socket, "status", timeout=10.0)
        request(args.socket, "stop", timeout=10.0)

    code_seen = _run_beside(d, operator, replied)
    for name in ("status", "move"):
        assert not seen[name]["ok"] and seen[name]["starting"] == doing, seen
    assert seen["running"]["ok"] and "starting" not in seen["running"], seen
    assert code_seen == 0 and d.stop_reason == "stop requested"


def test_a_start_whose_kernels_all_loaded_says_nothing_of_compiling(write_config, tmp_path, monkeypatch):
    """The kernels are in the cache (this suite compiled them): the start loads them all before
    its steps, so no step says it compiles or loads them; it does say what it configures."""
    from rtctl.control_socket.while_starting import ServedWhileStarting
    steps = []
    doing = ServedWhileStarting.doing
    monkeypatch.setattr(ServedWhileStarting, "doing", lambda self, what: (steps.append(what), doing(self, what))[1])
    cfg = load_config(write_config(BASE))
    args = SimpleNamespace(telemetry=None, socket=str(tmp_path / "s.sock"), enforce_rt=False, duration=0.05,
                           summary=None, log_level="error")
    d = Daemon(cfg, build(cfg), args)
    d.run()  # a first run of this configuration in the process, to warm the cache: it may compile
    steps.clear()
    d = Daemon(cfg, build(cfg), args)
    assert d.run() == 0
    assert "configuring sim" in steps and "activating sim" in steps, steps
    assert not any("kernels" in s for s in steps), steps
