"""The MCAP export's log and stamps against the specifications they follow (mutation survivors of
the `mcap` target, issue 27): foxglove.Time splits nanoseconds into whole seconds and the rest;
"ended" is info for exit 0 and error otherwise (foxglove.Log levels: 1 debug, 2 info, 3 warning,
4 error); the operator's live changes are info; an event after the last row is still written;
joints without names are j1 … jn."""
from __future__ import annotations

import json
from decimal import Decimal

import pytest

from rtctl.telemetry import Recorder
from rtctl.telemetry.channels import stamp

pytest.importorskip("mcap")
from mcap.reader import make_reader  # noqa: E402

from rtctl.telemetry.mcap_export import export_mcap  # noqa: E402

INFO, ERROR = 2, 4


@pytest.mark.parametrize("t", [0.0, 0.5, 1.0, 1.999999999, 2.0, 1234.000000001, 86399.999999999])
def test_a_stamp_is_whole_seconds_and_the_nanoseconds_left(t):
    ns = int((Decimal(repr(t)) * 10**9).to_integral_value())
    assert stamp(t) == {"sec": ns // 10**9, "nsec": ns - (ns // 10**9) * 10**9}
    assert 0 <= stamp(t)["nsec"] < 10**9


def _export(tmp_path, summary, meta=None, rows=3):
    rec = Recorder(tmp_path / "run.msgpack", {"t": ((), "f8"), "q": (2, "f8")}, meta or {}, wait_when_full=True)
    for k in range(rows):
        rec.row["t"][()] = 0.001 * k
        rec.row["q"][:] = [0.0, 0.1]
        rec.commit()
    rec.close(summary=summary)
    export_mcap(tmp_path / "run.msgpack", tmp_path / "run.mcap")
    with open(tmp_path / "run.mcap", "rb") as f:
        return [(c.topic, json.loads(m.data)) for _, c, m in make_reader(f).iter_messages(log_time_order=False)]


@pytest.mark.parametrize("exit_code, level", [(0, INFO), (3, ERROR), (2, ERROR)])
def test_ended_is_info_after_a_clean_run_and_an_error_otherwise(tmp_path, exit_code, level):
    got = _export(tmp_path, {"exit_code": exit_code, "stop_reason": "why"})
    ended = [m for topic, m in got if topic == "/events" and m["message"].startswith("ended")]
    assert len(ended) == 1 and ended[0]["level"] == level
    assert f"exit_code={exit_code}" in ended[0]["message"] and 'stop_reason="why"' in ended[0]["message"]


def test_live_changes_are_info_events_and_one_after_the_last_row_is_written(tmp_path):
    operator = {"events": [{"event": "set", "t": 0.001, "tick": 1, "key": "ct.kp", "old": [1.0], "new": [2.0]},
                           {"event": "switch", "t": 0.5, "tick": 500, "started": ["b"], "stopped": ["a"]}]}
    got = _export(tmp_path, {"exit_code": 0, "operator": operator})
    events = [m for topic, m in got if topic == "/events"]
    names = [m["message"].split(" ", 1)[0] for m in events]
    assert names == ["started", "set", "ended", "switch"]  # the switch at 0.5 s, after the last row (2 ms)
    for m in events:
        if m["message"].split(" ", 1)[0] in ("set", "switch"):
            assert m["level"] == INFO
    assert "tick=500" in events[-1]["message"] and events[-1]["timestamp"] == {"sec": 0, "nsec": 500_000_000}


def test_joints_without_names_are_numbered_from_one(tmp_path):
    got = _export(tmp_path, {"exit_code": 0})
    states = [m for topic, m in got if topic == "/joint_states"]
    assert states and all(m["name"] == ["j1", "j2"] for m in states)
    named = _export(tmp_path / "named" if (tmp_path / "named").mkdir() is None else tmp_path, {"exit_code": 0},
                    {"joints": ["hip", "knee"]})
    assert all(m["name"] == ["hip", "knee"] for topic, m in named if topic == "/joint_states")
