"""``rtctl export RUN.msgpack --mcap OUT.mcap``: a recorded run as MCAP, for Foxglove and
PlotJuggler (they open it as they open a ROS 2 bag).

Written with the ``mcap`` library (the optional extra ``mcap``). The channels, their JSON
Schemas (MCAP's ``json`` / ``jsonschema`` encodings) and their messages are the live view's
(:mod:`rtctl.telemetry.channels`), so one Foxglove layout serves both. Log time is the loop's
time since the start of the run (simulated runs are reproducible, so is their export).

The run's metadata (configuration, robot, rate, joint names) and its summary go into an MCAP
metadata record named ``rtctl``.
"""
from __future__ import annotations

import json

from rtctl import jsonout
from rtctl.errors import RtctlError
from rtctl.telemetry.channels import EVENTS, LOG_SCHEMA, encode, events, joint_names, messages, topics
from rtctl.telemetry.reader import read


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
    shapes = {name: column.shape[1:] for name, column in tel.columns.items()}
    names = joint_names(tel.meta, shapes)
    summary = (tel.footer or {}).get("summary")
    found = topics(shapes, tel.meta)
    logged = events(float(t[0]), float(t[-1]), tel.meta, summary)
    with open(out, "wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="rtctl")
        streams = [messages(topic, names, t, tel.columns) for topic in found]
        channels = [_channel(writer, topic.topic, topic.schema) for topic in found]
        log_channel = _channel(writer, EVENTS, LOG_SCHEMA)
        pending = 0
        for k, row in enumerate(zip(*streams)):  # in log-time order, channels interleaved, as a recorder writes
            while pending < len(logged) and logged[pending]["t"] <= t[k]:
                _add(writer, log_channel, logged[pending].pop("t"), logged[pending], pending)
                pending += 1
            for channel, msg in zip(channels, row):
                _add(writer, channel, t[k], msg, k)
        for k in range(pending, len(logged)):
            _add(writer, log_channel, logged[k].pop("t"), logged[k], k)
        writer.add_metadata("rtctl", {
            "config": str(tel.meta.get("config", "")), "robot": str(tel.meta.get("robot", "")),
            "rate_hz": str(tel.meta.get("rate_hz", "")), "joints": jsonout.dumps(names),
            "summary": jsonout.dumps(summary) if summary is not None else "null"})
        writer.finish()
    counts = Counts({**{topic.topic: tel.rows for topic in found}, EVENTS: len(logged)})
    counts.incomplete = tel.incomplete
    return counts


def _channel(writer, topic: str, schema: dict) -> int:
    schema_id = writer.register_schema(name=schema["title"], encoding="jsonschema",
                                       data=json.dumps(schema).encode())
    return writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id)


def _add(writer, channel: int, t: float, message: dict, sequence: int) -> None:
    ns = round(t * 1e9)
    writer.add_message(channel_id=channel, log_time=ns, publish_time=ns,
                       data=encode(message), sequence=sequence)
