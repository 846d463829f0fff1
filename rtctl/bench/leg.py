"""``rtctl bench leg``: the leg automaton's per-tick cost and the leg board codec's throughput.

* gates + settle: :func:`~rtctl.control.leg_automaton.automaton_tick` called from Python on
  sensor channels replayed from a simulated walk (so the circuit really changes state), and
  the controller's whole ``update()``. Goal: ≤ 3 µs per tick.
* codec: sensor frames encoded and decoded per second (the board's side and the host's), and
  command frames encoded into a preallocated buffer.
* plant step: one period of each leg plant in a closed-loop walk — the scripted gait generator
  (configs/leg_sim.toml) and the leg on MuJoCo (configs/leg_mujoco.toml; skipped without the
  ``mujoco`` package) — and the real-time factor of the plant alone (period / p50).
* compile: the whole synthesis and both proofs (what ``rtctl leg compile`` does after its
  imports) on synthetic event tables of 6, 9, 12 and 16 states (:mod:`rtctl.logic.synthetic`),
  the complete one (every transition) also at 11 gates, the most a 16-state circuit leaves
  room for. Goal: ≤ 10 s each.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from rtctl.bench import percentiles_us

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "leg_sim.toml"
PLANTS = {"scripted": CONFIG, "MuJoCo": CONFIG.with_name("leg_mujoco.toml")}
GOAL_US = 3.0
COMPILE_GOAL_S = 10.0
COMPILE_CASES = [(kind, n, gates) for kind, gates in (("chain", 8), ("star", 5), ("random", 6), ("complete", 8))
                 for n in (6, 9, 12, 16)] + [("complete", 16, 11)]  # (the widest table 5 flip-flops leave room for)


def bench_compile() -> list[dict]:
    """Seconds to synthesise and prove each synthetic table (see the module doc)."""
    import tempfile

    from rtctl.logic.emulate import CircuitModel
    from rtctl.logic.synth import compile_table
    from rtctl.logic.synthetic import synthetic_table
    from rtctl.logic.table import load_table
    from rtctl.logic.verify import agreement, race_proof

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for kind, n, gates in COMPILE_CASES:
            path = Path(tmp) / f"{kind}{n}.toml"
            path.write_text(synthetic_table(kind, n, gates))
            t0 = time.perf_counter()
            table = load_table(path)
            circuit = compile_table(table)
            model = CircuitModel.from_pla(circuit.pla, table.n_gates, circuit.n_bits, circuit.settle_passes)
            ok = not agreement(circuit, model)["mismatches"] and race_proof(circuit, model).ok
            rows.append({"table": kind, "states": n, "gates": gates, "seconds": time.perf_counter() - t0,
                         "flip_flops": circuit.n_bits, "terms": circuit.pla.n_terms, "passes": model.max_passes,
                         "proved": ok, "exact": not circuit.unproved})
    return rows


def _walk_channels(board, controller, ticks: int) -> np.ndarray:
    """Sensor channels of a simulated walk, one row per tick."""
    rows = np.zeros((ticks, board.channels.size))
    for k in range(ticks):
        board.read(0.0)
        controller.update(0.0, None, None, None)
        board.write(0.0)
        rows[k] = board.channels
    return rows


def bench_plant_step(config: Path, ticks: int) -> dict:
    """One period of the configuration's leg plant, timed in a closed-loop walk (the automaton
    decides the actions each tick, as in the loop)."""
    from rtctl.config import load_config
    from rtctl.runtime import build

    rt = build(load_config(config, sim=True))
    board, ctl = rt.devices[0], rt.controllers[0]
    board.configure()
    board.activate()
    ctl.reset(None)
    plant, clock, ns = board.plant, time.perf_counter_ns, np.zeros(ticks, np.int64)
    for k in range(ticks):
        board.read(0.0)
        ctl.update(0.0, None, None, None)
        plant.actions[:] = board.actions
        a = clock()
        plant.step(board.period)
        ns[k] = clock() - a
    board.close()
    return {**percentiles_us(ns), "period_us": board.period * 1e6}


def bench_plants(ticks: int) -> dict:
    """:func:`bench_plant_step` of each leg plant; None for MuJoCo without its package."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return {"scripted": bench_plant_step(PLANTS["scripted"], ticks), "MuJoCo": None}
    return {name: bench_plant_step(config, ticks) for name, config in PLANTS.items()}


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
                      "sensor_frame_bytes": proto.SENSOR_LENGTH, "command_frame_bytes": proto.COMMAND_LENGTH},
            "plant_step": bench_plants(ticks), "compile": bench_compile(), "compile_goal_s": COMPILE_GOAL_S}


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
    lines.append(f"{'leg plant step (one period)':<34}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}  × real time")
    for name, p in r["plant_step"].items():
        if p is None:
            lines.append(f"  {name:<32}not measured (pip install -e '.[mujoco]')")
            continue
        lines.append(f"  {name:<32}{p['p50_us']:>8.2f}{p['p99_us']:>8.2f}{p['p99_9_us']:>8.2f}{p['max_us']:>9.1f}"
                     f"  {p['period_us'] / p['p50_us']:.0f}")
    lines.append(f"leg compile (synthesis + both proofs), goal ≤ {r['compile_goal_s']:g} s each:")
    lines.append(f"  {'table':<9}{'states':>7}{'gates':>6}{'flip-flops':>11}{'terms':>6}{'passes':>7}{'s':>7}"
                 "  proved  minimum cover")
    for row in r["compile"]:
        lines.append(f"  {row['table']:<9}{row['states']:>7}{row['gates']:>6}{row['flip_flops']:>11}{row['terms']:>6}"
                     f"{row['passes']:>7}{row['seconds']:>7.2f}  {'yes' if row['proved'] else 'NO':<6}  "
                     f"{'proved' if row['exact'] else 'best within the budget'}")
    worst = max(row["seconds"] for row in r["compile"])
    lines.append(f"goal compile ≤ {r['compile_goal_s']:g} s: {'yes' if worst <= r['compile_goal_s'] else 'NO'} "
                 f"(slowest {worst:.2f} s)")
    return "\n".join(lines)
