"""What the MCAP export writes on each channel, against what was recorded (mutation survivors of the
`mcap` target, issue 27): the joint topics carry the joint names and the others do not; /timing
is each phase's recorded nanoseconds in µs; the log's start and end sit at the first and last row
(foxglove.Log, no source location: file "" and line 0); the "rtctl" metadata holds the run's summary."""
from __future__ import annotations

import json

import numpy as np
import pytest

from rtctl.telemetry import Recorder

pytest.importorskip("mcap")
from mcap.reader import make_reader  # noqa: E402

from rtctl.telemetry.mcap_export import export_mcap  # noqa: E402

PHASES = ["read", "update", "write"]
PHASE_NS = np.array([[1234567, 89, 1_000_001], [7, 999_999_999, 3_000_500], [42_424_242, 1, 0]])
T = [0.0, 0.001, 0.002]
SUMMARY = {"exit_code": 0, "stop_reason": "duration reached", "ticks": 3}


def _export(tmp_path, columns: dict, meta: dict, summary=SUMMARY):
    """Record ``columns`` ({name: rows}) at times T, export, and read the MCAP back: the messages
    as (topic, log time in ns, decoded message) and the metadata records by name."""
    schema = {"t": ((), "f8"), **{name: (np.shape(rows)[1:], np.asarray(rows).dtype.str) for name, rows in columns.items()}}
    rec = Recorder(tmp_path / "run.msgpack", schema, meta, wait_when_full=True)
    for k, t in enumerate(T):
        rec.row["t"][()] = t
        for name, rows in columns.items():
            rec.row[name][...] = rows[k]
        rec.commit()
    rec.close(summary=summary)
    export_mcap(tmp_path / "run.msgpack", tmp_path / "run.mcap")
    with open(tmp_path / "run.mcap", "rb") as f:
        reader = make_reader(f)
        got = [(c.topic, m.log_time, json.loads(m.data)) for _, c, m in reader.iter_messages(log_time_order=False)]
    with open(tmp_path / "run.mcap", "rb") as f:
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    return got, metadata


def _full(tmp_path):
    q = np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]])
    columns = {"q": q, "qd": q / 10, "q_des": q + 1, "tau": q * 3, "s": q - 1, "phase_ns": PHASE_NS}
    return _export(tmp_path, columns, {"joints": ["hip", "knee"], "phases": PHASES})


def test_the_joint_topics_carry_the_names_and_the_others_do_not(tmp_path):
    got, _ = _full(tmp_path)
    by_topic = {}
    for topic, _, msg in got:
        by_topic.setdefault(topic, []).append(msg)
    assert {"/joint_states", "/joint_commands", "/controller/s", "/timing", "/events"} <= set(by_topic)
    for topic in ("/joint_states", "/joint_commands"):
        assert all(m["name"] == ["hip", "knee"] for m in by_topic[topic]), topic
    for topic in ("/controller/s", "/timing"):
        assert all("name" not in m for m in by_topic[topic]), topic


def test_timing_is_each_phases_recorded_nanoseconds_in_microseconds(tmp_path):
    got, _ = _full(tmp_path)
    timing = [(t, m) for topic, t, m in got if topic == "/timing"]
    assert [t for t, _ in timing] == [round(x * 1e9) for x in T]
    for k, (_, msg) in enumerate(timing):
        assert {key: msg[key] for key in msg if key != "timestamp"} == \
            {f"{p}_us": int(PHASE_NS[k, i]) / 1000 for i, p in enumerate(PHASES)}


def test_the_log_starts_at_the_first_row_and_ends_at_the_last_with_no_source_location(tmp_path):
    got, _ = _full(tmp_path)
    log = [(t, m) for topic, t, m in got if topic == "/events"]
    assert [m["message"].split(" ", 1)[0] for _, m in log] == ["started", "ended"]
    (t_start, started), (t_end, ended) = log
    assert (t_start, started["level"]) == (round(T[0] * 1e9), 2)  # foxglove.Log: 2 info
    assert (t_end, ended["level"]) == (round(T[-1] * 1e9), 2)
    assert ended["timestamp"] == {"sec": 0, "nsec": round(T[-1] * 1e9)}
    assert all(m["file"] == "" and m["line"] == 0 for _, m in log)


def test_the_metadata_holds_the_runs_summary_and_null_without_one(tmp_path):
    _, metadata = _full(tmp_path)
    assert json.loads(metadata["rtctl"]["summary"]) == SUMMARY
    assert json.loads(metadata["rtctl"]["joints"]) == ["hip", "knee"]
    (tmp_path / "bare").mkdir()
    _, bare = _export(tmp_path / "bare", {"q": np.zeros((3, 2))}, {}, summary=None)
    assert bare["rtctl"]["summary"] == "null"


def test_without_positions_the_joints_are_counted_from_the_commands(tmp_path):
    got, metadata = _export(tmp_path, {"tau": np.ones((3, 3))}, {})
    commands = [m for topic, _, m in got if topic == "/joint_commands"]
    assert len(commands) == 3 and all(m["name"] == ["j1", "j2", "j3"] for m in commands)
    assert json.loads(metadata["rtctl"]["joints"]) == ["j1", "j2", "j3"]


def test_a_recording_without_joint_columns_names_no_joints(tmp_path):
    got, metadata = _export(tmp_path, {"s": np.ones((3, 2))}, {})
    assert {topic for topic, _, _ in got} == {"/controller/s", "/events"}
    assert json.loads(metadata["rtctl"]["joints"]) == []
