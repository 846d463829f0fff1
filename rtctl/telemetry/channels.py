"""The Foxglove channels of a run — one place for the MCAP export and the live view.

Both show a run the same way, so one Foxglove layout serves a recorded file and a live robot:
the same topics, the same JSON Schemas, the same messages built from the same telemetry rows.
Every number is strict JSON (a non-finite value is ``null``); the time of a message is the
loop's time since the start of the run.

========================  =================================================================
topic                     message
========================  =================================================================
``/joint_states``         ``name``, ``position``, ``velocity`` per joint (``q``, ``qd``)
``/joint_commands``       ``name``, reference ``position``/``velocity`` (``q_des``,
                          ``qd_des``) and the torque command ``effort`` (``tau``)
``/controller/<column>``  each controller internal recorded (``params_hat``, ``s``,
                          ``leg_state``, ``marker_measured_px`` …): ``data``
``/timing``               the per-phase compute times of the tick, µs
``/events``               the run's events (start, safety events, the operator's switches
                          and sets, end) as ``foxglove.Log``
========================  =================================================================
"""
from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from rtctl import jsonout

STATE_COLUMNS = {"t", "q", "qd", "q_des", "qd_des", "tau", "phase_ns"}
EVENTS = "/events"
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_NUMBERS = {"type": "array", "items": {"type": ["number", "null"]}}
_NUMBER = {"type": ["number", "null"]}
_NAMES = {"type": "array", "items": {"type": "string"}}
# foxglove.Log: Foxglove's Log panel lists these (level 1 debug … 5 fatal)
LOG_SCHEMA = {"title": "foxglove.Log", "type": "object", "properties": {
    "timestamp": _TIME, "level": {"type": "integer"}, "message": {"type": "string"},
    "name": {"type": "string"}, "file": {"type": "string"}, "line": {"type": "integer"}}}
_WARNING_EVENTS = {"fault", "reset", "gravity_failed"}


@dataclass(frozen=True)
class Field:
    """A message key filled from a telemetry column: the whole row of it, or entry ``index``
    of it (a scalar), divided by ``divisor`` (the unit)."""

    key: str
    column: str
    index: int | None = None
    divisor: float = 1.0


@dataclass(frozen=True)
class Topic:
    topic: str
    schema: dict
    fields: tuple[Field, ...]
    named: bool  # the message carries the joint names


def _schema(title: str, **properties) -> dict:
    return {"title": title, "type": "object", "properties": {"timestamp": _TIME, **properties}}


def topics(shapes: Mapping[str, tuple], meta: Mapping) -> list[Topic]:
    """The channels of a run whose telemetry has columns ``shapes`` ({name: per-row shape}) and
    run metadata ``meta`` (the recorder's header ``meta``), in the order they are written."""
    out = []
    if "q" in shapes:
        fields = (Field("position", "q"),) + ((Field("velocity", "qd"),) if "qd" in shapes else ())
        out.append(Topic("/joint_states", _schema("rtctl.JointState", name=_NAMES, position=_NUMBERS,
                                                   velocity=_NUMBERS), fields, True))
    command = tuple(Field(key, col) for key, col in (("position", "q_des"), ("velocity", "qd_des"),
                                                     ("effort", "tau")) if col in shapes)
    if command:
        out.append(Topic("/joint_commands", _schema("rtctl.JointCommand", name=_NAMES,
                                                    **{f.key: _NUMBERS for f in command}), command, True))
    tunables = set(meta.get("tunables") or ())  # parameters: their changes are /events, not a stream
    for column in shapes:
        if column not in STATE_COLUMNS and column not in tunables:
            out.append(Topic(f"/controller/{column}", _schema(f"rtctl.controller.{column}", data=_NUMBERS),
                             (Field("data", column),), False))
    phases = list(meta.get("phases") or [])
    if "phase_ns" in shapes and tuple(shapes["phase_ns"]) == (len(phases),):
        fields = tuple(Field(f"{p}_us", "phase_ns", k, 1e3) for k, p in enumerate(phases))
        out.append(Topic("/timing", _schema("rtctl.TickTiming", **{f.key: _NUMBER for f in fields}), fields, False))
    return out


def joint_names(meta: Mapping, shapes: Mapping[str, tuple]) -> list[str]:
    """The run's joint names, or j1 … jn, n from the first per-joint column recorded."""
    n = next((int(np.prod(shapes[c])) for c in ("q", "qd", "q_des", "qd_des", "tau") if c in shapes), 0)
    return list(meta.get("joints") or [f"j{j + 1}" for j in range(n)])


def _plain(values: np.ndarray) -> list:
    """Per-row plain floats (or lists of them), non-finite → None (strict JSON), in one conversion."""
    values = values.astype(float)
    rows = values.astype(object)
    rows[~np.isfinite(values)] = None
    return rows.tolist()


def _values(field: Field, column: np.ndarray) -> list:
    if field.index is not None:
        column = column.reshape(len(column), -1)[:, field.index]
    else:
        column = column.reshape(len(column), -1)
    return _plain(column / field.divisor if field.divisor != 1.0 else column)


def messages(topic: Topic, names: list[str], t: np.ndarray, columns: Mapping[str, np.ndarray]) -> Iterator[dict]:
    """``topic``'s message for each row of ``columns`` ({name: array of rows}, at loop times ``t``)."""
    for f in topic.fields:
        if len(columns[f.column]) != len(t):
            raise ValueError(f"{topic.topic}: column {f.column!r} has {len(columns[f.column])} rows, "
                             f"the times {len(t)}")
    keys = [f.key for f in topic.fields]
    values = [_values(f, columns[f.column]) for f in topic.fields]
    head = {"name": names} if topic.named else {}
    for k, row in enumerate(zip(*values)):
        yield {"timestamp": stamp(t[k]), **head, **dict(zip(keys, row))}


def stamp(t: float) -> dict:
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def encode(message: dict) -> bytes:
    return json.dumps(message, allow_nan=False).encode()


def events(t_first: float, t_last: float, meta: Mapping, summary) -> list[dict]:
    """Start, the safety stage's events, the operator's live changes, end — as foxglove.Log
    messages (plus their time ``t``); only the start while the run has no summary (it is written
    when the run ends)."""
    found = [(float(t_first), 2, "started", {"config": meta.get("config"), "robot": meta.get("robot")})]
    if summary is not None:
        safety = summary.get("safety") or {}
        for e in safety.get("events", []):
            fields = {k: v for k, v in e.items() if k not in ("event", "t", "tick")}
            warn = e["event"] in _WARNING_EVENTS or (e["event"] == "deactivate" and safety.get("faulted"))
            found.append((float(e["t"]), 3 if warn else 2, e["event"], {"tick": e.get("tick"), **fields}))
        for e in (summary.get("operator") or {}).get("events", []):  # live changes: switch, set
            fields = {k: v for k, v in e.items() if k not in ("event", "t", "tick")}
            found.append((float(e["t"]), 2, e["event"], {"tick": e.get("tick"), **fields}))
        found.append((float(t_last), 2 if summary.get("exit_code") == 0 else 4, "ended",
                      {"stop_reason": summary.get("stop_reason"), "exit_code": summary.get("exit_code")}))
    out = []
    for time_s, level, name, fields in sorted(found, key=lambda e: e[0]):
        text = name + "".join(f" {key}={jsonout.dumps(value)}" for key, value in fields.items())
        out.append({"t": time_s, "timestamp": stamp(time_s), "level": level, "message": text, "name": "rtctl",
                    "file": "", "line": 0})
    return out
