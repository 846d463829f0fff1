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


@pytest.mark.parametrize("step, cmd, code, reason", [
    ("warm_up", "stop", 0, "stop requested"),  # the first kernel group, loaded in the daemon's process
    ("configure", "stop", 0, "stop requested"),
    ("configure", "estop", 3, "operator e-stop before start: no drive was enabled"),
    ("activate", "estop", 3, "operator e-stop during start-up: sim disabled again"),
])
def test_a_stop_during_a_start_up_step_is_answered_then_and_ends_the_start(write_config, tmp_path, step, cmd, code,
                                                                           reason):
    cfg = load_config(write_config(BASE))
    args = SimpleNamespace(telemetry=None, socket=str(tmp_path / "s.sock"), enforce_rt=False, duration=3600.0,
                           summary=None, log_level="error")
    d = Daemon(cfg, build(cfg), args)
    (sim,) = d.rt.all_devices
    replied, calls, seen = threading.Event(), [], {}
    setattr(sim, step, _blocking(getattr(sim, step), replied, calls))
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

    thread = threading.Thread(target=operator)
    thread.start()
    try:
        code_seen = d.run()
    finally:
        replied.set()
        thread.join()
    assert seen["reply"]["ok"], seen
    assert code_seen == code
    assert d.stop_reason == reason
    assert not d.running  # the loop never started
    assert ("activate called" in calls) == (step == "activate"), calls  # no step after the stop
    assert sim.lifecycle.value != "active", sim.lifecycle  # (closed: the clean-up disabled what was enabled)
