"""The MCAP export against the MCAP specification and the run's own log: log and publish times
are nanoseconds (MCAP's Message record), equal to each message's ``timestamp``; the events come
in time order with the rows — "started" is the file's first message; and each safety event's
foxglove.Log level is the level the safety stage logged it at (info 2, warning 3): a normal
stop's ``deactivate`` is info, a fault's is a warning."""
from __future__ import annotations

import json

import numpy as np
import pytest
from structlog.testing import capture_logs

from rtctl.hal.joints import JointCommand, JointState
from rtctl.safety import SafetyStage, Verdict
from rtctl.telemetry import Recorder

pytest.importorskip("mcap")
from mcap.reader import make_reader  # noqa: E402

from rtctl.telemetry.mcap_export import export_mcap  # noqa: E402

DT, T0 = 0.001, 1.25  # (a run's clock need not start at 0)
FOXGLOVE_LEVEL = {"debug": 1, "info": 2, "warning": 3, "error": 4}


def _run_stage(fault: bool):
    """A two-joint safety stage ticked at rest to its deactivation: a normal stop, or a fault
    (joint 0 past its limit). Returns its summary, the levels it logged per event, and the ticks."""
    stage = SafetyStage([-1.0, -1.0], [1.0, 1.0], [2.0, 2.0], [10.0, 10.0], fault_off_delay=0.005,
                        estop_off_delay=0.005)
    state, command = JointState(2), JointCommand(2)
    state.fresh[:] = True
    with capture_logs() as logs:
        for ticks in range(50):
            state.position[0] = 1.5 if fault and ticks == 3 else 0.0
            if stage.check(T0 + ticks * DT, ticks, state, None, command) == Verdict.DEACTIVATE:
                break
            if not fault and ticks == 2:
                stage.stop("duration reached")
    assert stage.deactivated and stage.faulted == fault
    levels = {entry["event"]: entry["log_level"] for entry in logs}
    return stage.summary(), levels, ticks


def _export(tmp_path, summary, ticks):
    rec = Recorder(tmp_path / "run.msgpack", {"t": ((), "f8"), "q": (2, "f8")}, {"joints": ["a", "b"]},
                   wait_when_full=True)
    for k in range(ticks + 1):
        rec.row["t"][()] = T0 + k * DT
        rec.row["q"][:] = [0.0, 0.0]
        rec.commit()
    rec.close(summary={"safety": summary, "exit_code": 0, "stop_reason": "duration reached"})
    export_mcap(tmp_path / "run.msgpack", tmp_path / "run.mcap")
    with open(tmp_path / "run.mcap", "rb") as f:
        return [(channel.topic, json.loads(message.data), message)
                for _, channel, message in make_reader(f).iter_messages(log_time_order=False)]


@pytest.mark.parametrize("fault", [False, True], ids=["stop", "fault"])
def test_each_event_is_logged_at_the_level_the_safety_stage_logged_it(tmp_path, fault):
    summary, levels, ticks = _run_stage(fault)
    assert levels["deactivate"] == ("warning" if fault else "info")
    events = [msg for topic, msg, _ in _export(tmp_path, summary, ticks) if topic == "/events"]
    checked = 0
    for msg in events:
        name = msg["message"].split(" ", 1)[0]
        if name in levels:
            assert msg["level"] == FOXGLOVE_LEVEL[levels[name]], (name, msg)
            checked += 1
    assert checked == len(summary["events"]) >= 2


def test_log_times_are_nanoseconds_and_started_comes_first(tmp_path):
    summary, _, ticks = _run_stage(False)
    got = _export(tmp_path, summary, ticks)
    topic, first, _ = got[0]
    assert topic == "/events" and first["message"].startswith("started")
    rows = [(msg, m) for topic, msg, m in got if topic == "/joint_states"]
    assert len(rows) == ticks + 1
    for k, (msg, m) in enumerate(rows):
        ns = round((T0 + k * DT) * 1e9)
        assert m.log_time == m.publish_time == ns
        assert msg["timestamp"] == {"sec": ns // 10**9, "nsec": ns % 10**9}
    for topic, msg, m in got:
        assert m.log_time == msg["timestamp"]["sec"] * 10**9 + msg["timestamp"]["nsec"], topic
    times = [m.log_time for *_, m in got]
    assert times == sorted(times)
