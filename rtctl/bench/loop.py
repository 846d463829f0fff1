"""``rtctl bench loop``: the full stack — the shipped run configuration on the embedded PUMA 560,
telemetry on — first paced at ``rate`` on the wall clock (with the real-time knobs this
process is allowed), then as fast as possible (lock-step, realtime_factor = 0).

Reports wake lateness and per-phase compute percentiles of the paced run, and how many
times real time the lock-step run achieves.
"""
from __future__ import annotations

import json
import tempfile
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

from rtctl import logs
from rtctl.config import load_config
from rtctl.timing.rt import RtSettings

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "puma560_sim.toml"
KNOBS = RtSettings(priority=80, mlockall=True, timer_slack_ns=1, gc_freeze=True)


def _run(cfg, seconds: float, directory: Path, name: str) -> dict:
    from rtctl.daemon import Daemon
    from rtctl.runtime import build

    args = SimpleNamespace(telemetry=str(directory / f"{name}.msgpack"), socket=str(directory / f"{name}.sock"),
                           summary=str(directory / f"{name}.json"), duration=seconds, enforce_rt=False)
    code = Daemon(cfg, build(cfg), args).run()
    summary = json.loads(Path(args.summary).read_text())
    summary["exit_code"] = code
    return summary


def bench_loop(config=None, rate: float = 1000.0, seconds: float = 10.0, rt: bool = True) -> dict:
    logs.configure("json", level="warning")
    cfg = load_config(config or SHIPPED, sim=True)
    loop = replace(cfg.loop, rate_hz=rate, rt=KNOBS if rt else RtSettings(gc_freeze=True))
    result = {"config": str(cfg.file), "robot": cfg.model.name, "joints": cfg.model.nq, "rate_hz": rate,
              "seconds": seconds}
    with tempfile.TemporaryDirectory(prefix="rtctl-bench-") as tmp:
        for mode, factor in (("paced", 1.0), ("as_fast_as_possible", 0.0)):
            run_cfg = replace(cfg, loop=replace(loop, realtime_factor=factor))
            s = _run(run_cfg, seconds, Path(tmp), mode)
            result[mode] = {"timing": s["timing"], "tracking_max_rad": s["tracking_error_rad"]["max_all"],
                            "dropped_rows": s.get("telemetry", {}).get("dropped_rows"), "exit_code": s["exit_code"]}
    return result


def _row(name, p) -> str:
    if not p or p.get("p50") is None:
        return f"  {name:<22} {'-':>9}"
    return f"  {name:<22} {p['p50']:9.1f} {p['p99']:9.1f} {p['p99_9']:9.1f} {p['max']:11.1f}"


def format_table(result: dict) -> str:
    paced, fast = result["paced"]["timing"], result["as_fast_as_possible"]["timing"]
    lines = [f"rtctl bench loop — {result['robot']} ({result['joints']} joints), full stack, "
             f"{result['rate_hz']:g} Hz for {result['seconds']:g} s",
             f"  {'paced (µs)':<22} {'p50':>9} {'p99':>9} {'p99.9':>9} {'max':>11}",
             _row("wake lateness", paced["wake_lateness_us"])]
    for phase, p in paced["compute_us"].items():
        lines.append(_row(f"compute: {phase}", p))
    lines += [f"  ticks {paced['ticks']}, overruns {paced['overruns']}, skipped periods {paced['skipped_periods']}, "
              f"achieved {paced['achieved_rate_hz']:.1f} Hz, dropped telemetry rows {result['paced']['dropped_rows']}",
              f"  as fast as possible: {fast['realtime_ratio']:.1f}× real time "
              f"({fast['achieved_rate_hz']:.0f} ticks/s; tick p50 {fast['compute_us']['tick']['p50']:.1f} µs, "
              f"p99 {fast['compute_us']['tick']['p99']:.1f} µs)"]
    return "\n".join(lines)
