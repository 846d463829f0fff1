"""`rtctl export RUN --mcap OUT`: read back with the mcap library's reader, every message is strict
JSON that its channel's JSON Schema describes, and the values are the recorded ones."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rtctl.telemetry import Recorder, read

pytest.importorskip("mcap")
from mcap.reader import make_reader  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
PUMA = ROOT / "configs" / "robots" / "puma560.toml"
CONFIG = f"""
[robot]
description = "{PUMA}"
[loop]
realtime_factor = 0.0
[sim]
initial_q = [0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0]
[[controllers]]
name = "adaptive"
type = "slotine_li"
params0 = "true"
lam = 5.0
kd = 40.0
gamma = 1.0
[trajectory]
unit = "deg"
waypoints = [[0, 45, -180, 0, 45, 0], [20, 30, -160, 10, 60, 20]]
"""


def _reject(constant):
    raise ValueError(f"non-standard JSON constant {constant}")


def rtctl(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "rtctl.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=180, cwd=cwd)


def messages(path):
    """[(topic, schema dict, channel, message dict, log_time)] in file order, parsed strictly."""
    out = []
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            out.append((channel.topic, json.loads(schema.data), channel,
                        json.loads(message.data, parse_constant=_reject), message.log_time))
    return out


def check_against_schema(schema, msg):
    props = schema["properties"]
    assert set(msg) == set(props), (schema["title"], set(msg) ^ set(props))
    for key, value in msg.items():
        kind = props[key]["type"]
        if kind == "array":
            allowed = props[key]["items"]["type"]
            allowed = allowed if isinstance(allowed, list) else [allowed]
            for item in value:
                assert (item is None and "null" in allowed) or (isinstance(item, str) and "string" in allowed) \
                    or (isinstance(item, (int, float)) and "number" in allowed)
        elif kind == "object":
            assert set(value) == set(props[key]["properties"])
        elif kind == "integer":
            assert isinstance(value, int)
        elif kind == "string":
            assert isinstance(value, str)


def test_a_run_exports_to_mcap_with_every_channel(tmp_path):
    config = tmp_path / "run.toml"
    config.write_text(CONFIG)
    telemetry, out = tmp_path / "run.msgpack", tmp_path / "run.mcap"
    ran = rtctl("run", config, "--duration", "0.2", "--telemetry", telemetry, "--socket", tmp_path / "s")
    assert ran.returncode == 0, ran.stderr
    exported = rtctl("export", telemetry, "--mcap", out)
    assert exported.returncode == 0, exported.stderr
    tel = read(telemetry)
    got = messages(out)

    topics = {topic for topic, *_ in got}
    assert topics == {"/joint_states", "/joint_commands", "/controller/params_hat", "/controller/s", "/timing",
                      "/events", "/controller/controllers_active"}  # (the tunable gains: their sets are /events)
    for topic, schema, _, msg, _ in got:
        check_against_schema(schema, msg)
    times = [log_time for *_, log_time in got]
    assert times == sorted(times)  # one time-ordered stream, as a recorder writes

    states = [msg for topic, _, _, msg, _ in got if topic == "/joint_states"]
    assert len(states) == tel.rows
    assert states[0]["name"] == ["waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange"]
    np.testing.assert_array_equal([m["position"] for m in states], tel["q"])  # JSON floats round-trip exactly
    np.testing.assert_array_equal([m["velocity"] for m in states], tel["qd"])
    commands = [msg for topic, _, _, msg, _ in got if topic == "/joint_commands"]
    np.testing.assert_array_equal([m["effort"] for m in commands], tel["tau"])
    k = tel.rows // 2
    assert commands[k]["timestamp"] == {"sec": 0, "nsec": round(tel["t"][k] * 1e9)}
    estimates = [msg["data"] for topic, _, _, msg, _ in got if topic == "/controller/params_hat"]
    np.testing.assert_array_equal(estimates, tel["params_hat"])
    timing = [msg for topic, _, _, msg, _ in got if topic == "/timing"]
    assert math.isclose(timing[k]["update_us"], tel["phase_ns"][k, 1] / 1e3)

    events = [msg for topic, _, _, msg, _ in got if topic == "/events"]
    assert events[0]["message"].startswith("started") and events[-1]["message"].startswith("ended")
    assert 'stop_reason="duration reached"' in events[-1]["message"] and "exit_code=0" in events[-1]["message"]
    assert any(e["message"].startswith("stop ") and e["level"] == 2 for e in events)
    with open(out, "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert json.loads(meta["rtctl"]["joints"])[0] == "waist"
    assert json.loads(meta["rtctl"]["summary"], parse_constant=_reject)["exit_code"] == 0


def test_non_finite_values_are_null_and_a_file_without_summary_still_exports(tmp_path):
    from rtctl.telemetry.mcap_export import export_mcap

    rec = Recorder(tmp_path / "run.msgpack", {"t": ((), "f8"), "q": (2, "f8")}, {"joints": ["a", "b"]},
                   wait_when_full=True)
    for k, q in enumerate(([0.0, 1.0], [math.nan, 2.0], [math.inf, -math.inf])):
        rec.row["t"][()] = k * 1e-3
        rec.row["q"][:] = q
        rec.commit()
    rec.close()
    counts = export_mcap(tmp_path / "run.msgpack", tmp_path / "run.mcap")
    assert counts == {"/joint_states": 3, "/events": 1}
    states = [msg["position"] for topic, _, _, msg, _ in messages(tmp_path / "run.mcap") if topic == "/joint_states"]
    assert states == [[0.0, 1.0], [None, 2.0], [None, None]]


def test_missing_mcap_says_what_to_install(tmp_path, monkeypatch):
    from rtctl.errors import RtctlError
    from rtctl.telemetry.mcap_export import export_mcap

    monkeypatch.setitem(sys.modules, "mcap.writer", None)
    with pytest.raises(RtctlError, match=r"pip install -e '\.\[mcap\]'"):
        export_mcap(tmp_path / "run.msgpack", tmp_path / "run.mcap")
