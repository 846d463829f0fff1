"""The live view: a real Foxglove WebSocket client on a running daemon receives the telemetry
file's rows, on the MCAP export's channels; a bad ``[live]`` or ``--live`` and a port in use
exit 2 naming the key before anything is touched.

The client is the ``websockets`` package speaking the protocol by hand (advertise → subscribe →
binary message frames: opcode 1, subscription id u32, log time u64, JSON payload). foxglove-sdk
0.30 names the protocol ``foxglove.sdk.v1`` (it refuses the older ``foxglove.websocket.v1``).
"""
from __future__ import annotations

import asyncio
import json
import socket
import struct
from types import SimpleNamespace

import numpy as np
import pytest
from runtime_helpers import BASE, rtctl

from rtctl.telemetry import Recorder, read
from rtctl.telemetry.live_server import Publisher
from rtctl.telemetry.ring import Ring
from rtctl.telemetry.schema import row_dtype

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

pytest.importorskip("foxglove")
websockets = pytest.importorskip("websockets")

SUBPROTOCOL = "foxglove.sdk.v1"
PACED = BASE.replace("realtime_factor = 0.0", "realtime_factor = 1.0")  # a viewer watches it live
WANTED = 300  # joint-state messages before the client asks the daemon to stop


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def watch(port: int, stop) -> tuple[list, list, dict]:
    """Subscribe to /joint_states and /events; after WANTED joint states call ``stop`` and read
    until the server goes away. Returns ([(log_time, message)], [event message], advertised)."""
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL],
                                  max_size=None) as ws:
        assert json.loads(await ws.recv())["op"] == "serverInfo"
        advertised = {}
        while {"/joint_states", "/events"} - set(advertised):
            msg = json.loads(await ws.recv())
            if msg["op"] == "advertise":
                advertised.update({c["topic"]: c for c in msg["channels"]})
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": advertised["/joint_states"]["id"]},
            {"id": 2, "channelId": advertised["/events"]["id"]}]}))
        states, events, stopped = [], [], False
        try:
            async for frame in ws:
                if not isinstance(frame, bytes) or frame[0] != 1:
                    continue
                subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                payload = json.loads(frame[13:])
                (states if subscription == 1 else events).append((log_time, payload))
                if len(states) >= WANTED and not stopped:
                    stopped = True
                    await asyncio.get_running_loop().run_in_executor(None, stop)
        except websockets.ConnectionClosed:
            pass
        return states, [e for _, e in events], advertised


def test_a_foxglove_client_receives_the_rows_the_telemetry_file_records(write_config, daemon, tmp_path):
    port, telemetry = free_port(), tmp_path / "run.msgpack"
    d = daemon(write_config(PACED), "--live", port, "--telemetry", telemetry)
    d.wait_ready()
    states, events, advertised = asyncio.run(watch(port, lambda: rtctl("stop", "--socket", d.socket)))
    code, out, err = d.finish()
    assert code == 0, err
    assert "ws://127.0.0.1:" + str(port) in out

    assert {"/joint_states", "/joint_commands", "/controller/qdd_cmd", "/controller/controllers_active", "/timing",
            "/events"} == set(advertised)  # (the MCAP export's; the tunable gains are not channels)
    schema = json.loads(advertised["/joint_states"]["schema"])
    assert advertised["/joint_states"]["schemaName"] == schema["title"] == "rtctl.JointState"
    tel = read(telemetry)
    row_of = {round(t * 1e9): k for k, t in enumerate(tel["t"])}
    assert len(states) >= WANTED
    ticks = []
    for log_time, msg in states:
        k = row_of[log_time]  # the frame's time is a recorded row's
        assert msg["timestamp"] == {"sec": log_time // 10**9, "nsec": log_time % 10**9}
        assert msg["name"] == ["waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange"]
        np.testing.assert_array_equal(msg["position"], tel["q"][k])  # JSON floats round-trip exactly
        np.testing.assert_array_equal(msg["velocity"], tel["qd"][k])
        ticks.append(k)
    assert ticks == sorted(set(ticks))  # each row once, in the loop's order
    assert events and events[-1]["message"].startswith("ended") and "exit_code=0" in events[-1]["message"]


def test_live_without_a_telemetry_file_serves_rows_all_the_same(write_config, daemon, tmp_path):
    port = free_port()
    d = daemon(write_config(PACED), "--live", f"127.0.0.1:{port}")
    d.wait_ready()
    states, _, _ = asyncio.run(watch(port, lambda: rtctl("stop", "--socket", d.socket)))
    code, _, err = d.finish()
    assert code == 0, err
    assert len(states) >= WANTED and states[0][1]["position"][0] == pytest.approx(0.0, abs=0.1)


@pytest.mark.parametrize("table, key", [("[live]\nport = 70000\n", "live.port"),
                                        ("[live]\nhost = \"\"\n", "live.host"),
                                        ("[live]\nprot = 8765\n", "live.prot")])
def test_a_bad_live_table_exits_2_naming_the_key(write_config, table, key):
    ran = rtctl("run", write_config(BASE + table), "--duration", "0.01")
    assert ran.returncode == 2, ran.stderr
    assert key in ran.stderr and "run.toml" in ran.stderr


def test_a_bad_live_argument_exits_2_naming_it(write_config):
    ran = rtctl("run", write_config(), "--live", "localhost:http", "--duration", "0.01")
    assert ran.returncode == 2 and "--live" in ran.stderr and "PORT" in ran.stderr, ran.stderr


@pytest.mark.parametrize("where", ["argument", "table"])
def test_a_port_in_use_exits_2_before_anything_is_touched(write_config, tmp_path, where):
    telemetry = tmp_path / "earlier.msgpack"
    telemetry.write_bytes(b"an earlier run's rows")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        if where == "argument":
            ran = rtctl("run", write_config(), "--live", port, "--telemetry", telemetry, "--log-format", "json")
        else:
            ran = rtctl("run", write_config(BASE + f"[live]\nport = {port}\n"), "--telemetry", telemetry,
                        "--log-format", "json")
    assert ran.returncode == 2, ran.stderr
    assert f"{port} is in use" in ran.stderr
    assert ("--live" if where == "argument" else "live.port") in ran.stderr
    assert telemetry.read_bytes() == b"an earlier run's rows"  # not truncated
    assert '"preparing kernels"' not in ran.stdout and '"started"' not in ran.stdout  # no device touched


class FakeChannel:
    def __init__(self, topic, schema):
        self.topic, self.logged = topic, []

    def has_sinks(self):
        return True

    def log(self, data, log_time):
        self.logged.append((log_time, json.loads(data)))


def test_a_reader_that_fell_behind_skips_to_rows_the_loop_cannot_be_overwriting(tmp_path):
    """Ring of 2 blocks of 4 rows: after 23 rows, rows 15-22 are in memory, the loop's next
    block may reuse 15-18 at any time, so the reader takes 19-22 only."""
    schema = {"t": ((), "f8"), "q": (2, "f8")}
    rec = Recorder(tmp_path / "run.msgpack", schema, {"joints": ["a", "b"]}, block_rows=4, n_blocks=2,
                   wait_when_full=True)
    dtype = row_dtype(rec.schema)
    ring = Ring(rec.ring_fd, dtype, 4, 2)
    publisher = Publisher(ring, dtype, rec.meta, SimpleNamespace(Channel=FakeChannel))
    states = next(ch for topic, ch in publisher.channels if topic.topic == "/joint_states")

    def commit(k):
        rec.row["t"][()] = k * 1e-3
        rec.row["q"][:] = (k, -k)
        rec.commit()

    for k in range(3):
        commit(k)
    publisher.poll()
    for k in range(3, 23):
        commit(k)
    publisher.poll()
    rec.close()
    got = [(ns, msg["position"]) for ns, msg in states.logged]
    assert got == [(round(k * 1e-3 * 1e9), [k, -k]) for k in (0, 1, 2, 19, 20, 21, 22)]


class AdvancingCounters:
    """A ring's counters where the loop stores ``advance`` more rows while the reader copies."""

    def __init__(self, stored: int, advance: int):
        self.reads = iter((stored, stored + advance))

    def __getitem__(self, index):
        return next(self.reads)


def test_rows_the_loop_started_overwriting_during_the_copy_are_dropped():
    """8 rows in the ring (2 blocks of 4), 8 stored; while the reader copies them the loop stores
    6 more (rows 8-13) and may be writing row 14 already: row k's slot is rewritten from the
    moment row k + 8 is being stored, so of rows 4-7 only row 7 is intact."""
    schema = {"t": ((), "f8"), "q": (1, "f8")}
    dtype = row_dtype(schema)
    memory = bytearray(Ring.size(dtype, 4, 2))
    rows = np.frombuffer(memory, dtype=dtype, count=8, offset=64)
    rows["t"] = np.arange(8) * 1e-3
    rows["q"][:, 0] = np.arange(8)
    ring = SimpleNamespace(map=memory, block_rows=4, n_blocks=2, ctl=AdvancingCounters(8, 6))
    publisher = Publisher(ring, dtype, {"joints": ["a"]}, SimpleNamespace(Channel=FakeChannel))
    publisher.next = 4  # rows 0-3 were read earlier: the copy takes 4-7
    publisher.t_first = 0.0
    publisher.poll()
    states = next(ch for topic, ch in publisher.channels if topic.topic == "/joint_states")
    assert [msg["position"] for _, msg in states.logged] == [[7.0]]


def test_messages_refuse_columns_and_times_of_different_lengths():
    from rtctl.telemetry.channels import messages, topics

    (states,) = [t for t in topics({"t": (), "q": (2,)}, {}) if t.topic == "/joint_states"]
    with pytest.raises(ValueError, match="'q' has 3 rows, the times 2"):
        list(messages(states, ["a", "b"], np.zeros(2), {"q": np.zeros((3, 2))}))


def test_the_end_events_carry_the_last_rows_time_when_nobody_watched_the_rows(tmp_path):
    schema = {"t": ((), "f8"), "q": (1, "f8")}
    rec = Recorder(tmp_path / "run.msgpack", schema, {"joints": ["a"]}, block_rows=4, n_blocks=2,
                   wait_when_full=True)
    dtype = row_dtype(rec.schema)
    publisher = Publisher(Ring(rec.ring_fd, dtype, 4, 2), dtype, rec.meta, SimpleNamespace(Channel=FakeChannel))
    for topic, channel in publisher.channels:
        channel.has_sinks = lambda: False  # only the event log is watched
    for k in range(6):
        rec.row["t"][()] = k * 1e-3
        rec.commit()
        publisher.poll()
    rec.close()
    publisher.finish({"exit_code": 0, "stop_reason": "duration reached"})
    logged = [(ns, msg["message"].split()[0]) for ns, msg in publisher.log.logged]
    assert logged == [(0, "started"), (5_000_000, "ended")]
