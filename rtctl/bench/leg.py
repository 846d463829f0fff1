"""``rtctl bench leg``: the leg automaton's per-tick cost and the leg board codec's throughput.

* gates + settle: :func:`~rtctl.control.leg_automaton.automaton_tick` called from Python on
  sensor channels replayed from a simulated walk (so the circuit really changes state), and
  the controller's whole ``update()``. Goal: ≤ 3 µs per tick.
* codec: sensor frames encoded and decoded per second (the board's side and the host's), and
  command frames encoded into a preallocated buffer.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from rtctl.bench import percentiles_us

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "leg_sim.toml"
GOAL_US = 3.0


def _walk_channels(board, controller, ticks: int) -> np.ndarray:
    """Sensor channels of a simulated walk, one row per tick."""
    rows = np.zeros((ticks, board.channels.size))
    for k in range(ticks):
        board.read(0.0)
        controller.update(0.0, None, None, None)
        board.write(0.0)
        rows[k] = board.channels
    return rows


def bench_leg(ticks: int = 20000) -> dict:
    from drivers.protocols import leg_board as proto
    from rtctl.config import load_config
    from rtctl.control.leg_automaton import automaton_tick
    from rtctl.runtime import build

    rt = build(load_config(CONFIG, sim=True))
    board, ctl = rt.devices[0], rt.controllers[0]
    board.configure()
    board.activate()
    ctl.reset(None)
    channels = _walk_channels(board, ctl, ticks)
    board.close()
    ctl.reset(None)
    ch, gates, pla, labels, data, actions = board.channels, ctl.gates, ctl.pla, ctl.labels, ctl.data, board.actions
    nb, mp = ctl.cm.n_bits, ctl.cm.max_passes
    clock = time.perf_counter_ns
    ns_kernel, ns_update = np.zeros(ticks, np.int64), np.zeros(ticks, np.int64)
    changes = 0
    for k in range(ticks):
        ch[:] = channels[k]
        a = clock()
        changes += automaton_tick(ch, gates, pla, labels, data, actions, nb, mp) > 0
        ns_kernel[k] = clock() - a
    ctl.reset(None)
    update = ctl.update
    for k in range(ticks):
        ch[:] = channels[k]
        a = clock()
        update(0.0, None, None, None)
        ns_update[k] = clock() - a

    n = 20000
    sensor = [proto.encode_sensor(k, 0, channels[k % ticks]) for k in range(200)]
    t0 = time.perf_counter()
    for k in range(n):
        proto.encode_sensor(k, 0, channels[k % ticks])
    enc = n / (time.perf_counter() - t0)
    stream = b"".join(sensor)
    dec = proto.Decoder(proto.SENSOR)
    t0 = time.perf_counter()
    for _ in range(n // 200):
        dec.feed(stream)
    decoded = dec.counters["frames"] / (time.perf_counter() - t0)
    frame = bytearray(proto.COMMAND_LENGTH)
    t0 = time.perf_counter()
    for k in range(n):
        proto.encode_command(k, k & 3, 3 - (k & 3), frame)
    cmd = n / (time.perf_counter() - t0)
    return {"ticks": ticks, "state_changes": int(changes), "goal_us": GOAL_US,
            "gates_settle": percentiles_us(ns_kernel), "update": percentiles_us(ns_update),
            "codec": {"sensor_encode_per_s": enc, "sensor_decode_per_s": decoded, "command_encode_per_s": cmd,
                      "sensor_frame_bytes": proto.SENSOR_LENGTH, "command_frame_bytes": proto.COMMAND_LENGTH}}


def format_table(r: dict) -> str:
    lines = [f"leg automaton, {r['ticks']} ticks of a simulated walk ({r['state_changes']} state changes); "
             f"goal ≤ {r['goal_us']:g} µs per tick",
             f"{'µs per tick':<34}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}"]
    for label, key in (("gates + settle (compiled call)", "gates_settle"), ("controller update()", "update")):
        p = r[key]
        lines.append(f"{label:<34}{p['p50_us']:>8.2f}{p['p99_us']:>8.2f}{p['p99_9_us']:>8.2f}{p['max_us']:>9.1f}")
    c = r["codec"]
    lines.append(f"codec: sensor frames ({c['sensor_frame_bytes']} B) encoded {c['sensor_encode_per_s']:,.0f}/s, "
                 f"decoded {c['sensor_decode_per_s']:,.0f}/s; command frames ({c['command_frame_bytes']} B) "
                 f"encoded {c['command_encode_per_s']:,.0f}/s")
    return "\n".join(lines)
