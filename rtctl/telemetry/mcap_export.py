"""``rtctl export RUN.msgpack --mcap OUT.mcap``: a recorded run as MCAP, for Foxglove and
PlotJuggler (they open it as they open a ROS 2 bag).

Written with the ``mcap`` library (the optional extra ``mcap``). Every channel carries JSON
messages described by a JSON Schema (MCAP's ``json`` / ``jsonschema`` encodings); every
number is strict JSON (a non-finite value is ``null``). Log time is the loop's time since the
start of the run (simulated runs are reproducible, so is their export).

========================  =================================================================
topic                     message
========================  =================================================================
``/joint_states``         ``name``, ``position``, ``velocity`` per joint (``q``, ``qd``)
``/joint_commands``       ``name``, reference ``position``/``velocity`` (``q_des``,
                          ``qd_des``) and the torque command ``effort`` (``tau``)
``/controller/<column>``  each controller internal recorded (``params_hat``, ``s`` …): ``data``
``/timing``               the per-phase compute times of the tick, µs
``/events``               the run's events (start, safety events, end) as ``foxglove.Log``
========================  =================================================================

The run's metadata (configuration, robot, rate, joint names) and its summary go into an MCAP
metadata record named ``rtctl``.
"""
from __future__ import annotations

import json

import numpy as np

from rtctl import jsonout
from rtctl.errors import RtctlError
from rtctl.telemetry.reader import read

_STATE_COLUMNS = {"t", "q", "qd", "q_des", "qd_des", "tau", "phase_ns"}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_NUMBERS = {"type": "array", "items": {"type": ["number", "null"]}}
_NAMES = {"type": "array", "items": {"type": "string"}}
# foxglove.Log: Foxglove's Log panel lists these (level 1 debug … 5 fatal)
_LOG_SCHEMA = {"title": "foxglove.Log", "type": "object", "properties": {
    "timestamp": _TIME, "level": {"type": "integer"}, "message": {"type": "string"},
    "name": {"type": "string"}, "file": {"type": "string"}, "line": {"type": "integer"}}}
_WARNING_EVENTS = {"fault", "reset", "gravity_failed"}


def _schema(title: str, **properties) -> dict:
    return {"title": title, "type": "object", "properties": {"timestamp": _TIME, **properties}}


def _rows(values: np.ndarray) -> list:
    """Per-row lists of plain floats, non-finite → None (strict JSON), in one conversion."""
    values = values.reshape(len(values), -1).astype(float)
    rows = values.astype(object)
    rows[~np.isfinite(values)] = None
    return rows.tolist()


def _stamp(t: float) -> dict:
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _writer_class():
    try:
        from mcap.writer import Writer
    except ImportError:
        raise RtctlError("exporting MCAP needs the mcap library, the optional extra `mcap`: in the clone, "
                         ".venv/bin/pip install -e '.[mcap]'") from None
    return Writer


class Counts(dict):
    """{topic: messages}, and ``incomplete``: why the telemetry file was not a finished run's (or None)."""

    incomplete: str | None = None


def export_mcap(path, out) -> Counts:
    """Write the telemetry file ``path`` as the MCAP file ``out`` (its folder is created);
    return {topic: messages}."""
    from rtctl.outputs import output_path

    Writer = _writer_class()
    out = output_path(out, "--mcap")  # (its folder created)
    tel = read(path)
    tel.require_rows("export")
    if "t" not in tel:
        raise RtctlError(f"{path}: nothing to export ({tel.rows} rows, columns: {', '.join(tel.columns)})")
    t = tel["t"].astype(float)
    n = tel["q"].reshape(tel.rows, -1).shape[1] if "q" in tel else 0
    names = list(tel.meta.get("joints") or [f"j{j + 1}" for j in range(n)])
    summary = (tel.footer or {}).get("summary")

    channels = {}  # topic → (schema, {field: per-row values})
    if "q" in tel:
        fields = {"position": _rows(tel["q"])}
        if "qd" in tel:
            fields["velocity"] = _rows(tel["qd"])
        channels["/joint_states"] = (_schema("rtctl.JointState", name=_NAMES, position=_NUMBERS,
                                             velocity=_NUMBERS), fields)
    command = {key: _rows(tel[col]) for key, col in (("position", "q_des"), ("velocity", "qd_des"),
                                                     ("effort", "tau")) if col in tel}
    if command:
        channels["/joint_commands"] = (_schema("rtctl.JointCommand", name=_NAMES,
                                               **{k: _NUMBERS for k in command}), command)
    tunables = set(tel.meta.get("tunables") or ())  # parameters: their changes are /events, not a stream
    for column in tel.columns:
        if column not in _STATE_COLUMNS and column not in tunables:
            channels[f"/controller/{column}"] = (_schema(f"rtctl.controller.{column}", data=_NUMBERS),
                                                 {"data": _rows(tel[column])})
    if "phase_ns" in tel:
        phases = list(tel.meta.get("phases") or [])
        us = _rows(tel["phase_ns"] / 1e3)
        if len(phases) == len(us[0]):
            columns = list(zip(*us))
            channels["/timing"] = (_schema("rtctl.TickTiming", **{f"{p}_us": {"type": ["number", "null"]}
                                                                   for p in phases}),
                                   {f"{p}_us": list(columns[k]) for k, p in enumerate(phases)})

    events = _events(t, tel, summary)
    with open(out, "wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="rtctl")
        streams = [(_channel(writer, topic, schema), "name" in schema["properties"], fields)
                   for topic, (schema, fields) in channels.items()]
        log_channel = _channel(writer, "/events", _LOG_SCHEMA)
        pending = 0
        for k in range(tel.rows):  # in log-time order, channels interleaved, as a recorder writes
            while pending < len(events) and events[pending]["t"] <= t[k]:
                _add(writer, log_channel, events[pending].pop("t"), events[pending], pending)
                pending += 1
            for channel, with_names, fields in streams:
                msg = {"timestamp": _stamp(t[k]), **({"name": names} if with_names else {}),
                       **{key: values[k] for key, values in fields.items()}}
                _add(writer, channel, t[k], msg, k)
        for k in range(pending, len(events)):
            _add(writer, log_channel, events[k].pop("t"), events[k], k)
        writer.add_metadata("rtctl", {
            "config": str(tel.meta.get("config", "")), "robot": str(tel.meta.get("robot", "")),
            "rate_hz": str(tel.meta.get("rate_hz", "")), "joints": jsonout.dumps(names),
            "summary": jsonout.dumps(summary) if summary is not None else "null"})
        writer.finish()
    counts = Counts({**{topic: tel.rows for topic in channels}, "/events": len(events)})
    counts.incomplete = tel.incomplete
    return counts


def _channel(writer, topic: str, schema: dict) -> int:
    schema_id = writer.register_schema(name=schema["title"], encoding="jsonschema",
                                       data=json.dumps(schema).encode())
    return writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id)


def _add(writer, channel: int, t: float, message: dict, sequence: int) -> None:
    ns = round(t * 1e9)
    writer.add_message(channel_id=channel, log_time=ns, publish_time=ns,
                       data=json.dumps(message, allow_nan=False).encode(), sequence=sequence)


def _events(t, tel, summary) -> list[dict]:
    """Start, the safety stage's events, the operator's live changes, end — as foxglove.Log messages (plus their time ``t``)."""
    events = [(float(t[0]), 2, "started", {"config": tel.meta.get("config"), "robot": tel.meta.get("robot")})]
    if summary is not None:
        safety = summary.get("safety") or {}
        for e in safety.get("events", []):
            fields = {k: v for k, v in e.items() if k not in ("event", "t", "tick")}
            warn = e["event"] in _WARNING_EVENTS or (e["event"] == "deactivate" and safety.get("faulted"))
            events.append((float(e["t"]), 3 if warn else 2, e["event"], {"tick": e.get("tick"), **fields}))
        for e in (summary.get("operator") or {}).get("events", []):  # live changes: switch, set
            fields = {k: v for k, v in e.items() if k not in ("event", "t", "tick")}
            events.append((float(e["t"]), 2, e["event"], {"tick": e.get("tick"), **fields}))
        events.append((float(t[-1]), 2 if summary.get("exit_code") == 0 else 4, "ended",
                       {"stop_reason": summary.get("stop_reason"), "exit_code": summary.get("exit_code")}))
    out = []
    for time_s, level, name, fields in sorted(events, key=lambda e: e[0]):
        text = name + "".join(f" {key}={jsonout.dumps(value)}" for key, value in fields.items())
        out.append({"t": time_s, "timestamp": _stamp(time_s), "level": level, "message": text, "name": "rtctl",
                    "file": "", "line": 0})
    return out
