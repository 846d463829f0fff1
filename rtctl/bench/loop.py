"""``rtctl bench loop``: the full stack — the shipped run configuration on the embedded PUMA 560,
telemetry on — first paced at ``rate`` on the wall clock (with the real-time knobs this
process is allowed), then as fast as possible (lock-step, realtime_factor = 0) for each PUMA job
(computed torque and C* Slotine–Li, or ``--config``).

Reports wake lateness and per-phase compute percentiles of the paced run and, per lock-step
run: the per-phase split of the tick, how many times real time it runs, and the compiled floor
under it — the summed time of the kernels the tick calls from Python, each called directly on a
copy of the arrays of the same run (:mod:`rtctl.bench.kernel_census`). The overhead ratio is
tick p50 / that floor; the floor's own real-time factor (period / floor) is the pure compiled
reference the achieved factor is compared with, so the machine's speed cancels out.
"""
from __future__ import annotations

import json
import tempfile
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

from rtctl import logs
from rtctl.bench.kernel_census import KernelCensus
from rtctl.config import load_config
from rtctl.timing.rt import RtSettings

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
SHIPPED = CONFIGS / "puma560_sim.toml"
LOCKSTEP_JOBS = (SHIPPED, CONFIGS / "puma560_cstar_sim.toml")
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


def _configured(path, rate: float, rt: bool, factor: float):
    cfg = load_config(path, sim=True)
    loop = replace(cfg.loop, rate_hz=rate, rt=KNOBS if rt else RtSettings(gc_freeze=True), realtime_factor=factor)
    return replace(cfg, loop=loop)


def _lockstep(path, rate: float, seconds: float, directory: Path) -> dict:
    """One lock-step run with telemetry on, then a short one under the kernel census."""
    cfg = _configured(path, rate, False, 0.0)
    s = _run(cfg, seconds, directory, "lockstep")
    timing = s["timing"]
    with KernelCensus() as census:
        ticks = _run(cfg, min(seconds, 1.0), directory, "census")["timing"]["ticks"]
    floor = census.cost_per_tick(ticks)
    tick_us = timing["compute_us"]["tick"]["p50"]
    period_us = 1e6 / rate
    return {"config": str(cfg.file), "controllers": [c.type for c in cfg.controllers],
            "timing": timing, "tracking_max_rad": s["tracking_error_rad"]["max_all"], "exit_code": s["exit_code"],
            "kernels": floor["kernels"], "kernels_us": floor["total_us"],
            "overhead_ratio": tick_us / floor["total_us"] if floor["total_us"] else None,
            "realtime_ratio": timing["realtime_ratio"],
            "compiled_realtime_ratio": period_us / floor["total_us"] if floor["total_us"] else None}


def bench_loop(config=None, rate: float = 1000.0, seconds: float = 10.0, rt: bool = True) -> dict:
    logs.configure("json", level="warning")
    cfg = _configured(config or SHIPPED, rate, rt, 1.0)
    result = {"config": str(cfg.file), "robot": cfg.model.name, "joints": cfg.model.nq, "rate_hz": rate,
              "seconds": seconds}
    with tempfile.TemporaryDirectory(prefix="rtctl-bench-") as tmp:
        s = _run(cfg, seconds, Path(tmp), "paced")
        result["paced"] = {"timing": s["timing"], "tracking_max_rad": s["tracking_error_rad"]["max_all"],
                           "dropped_rows": s.get("telemetry", {}).get("dropped_rows"), "exit_code": s["exit_code"]}
        result["lockstep"] = [_lockstep(path, rate, seconds, Path(tmp)) for path in
                              ((config,) if config else LOCKSTEP_JOBS)]
    return result


def _row(name, p) -> str:
    if not p or p.get("p50") is None:
        return f"  {name:<22} {'-':>9}"
    return f"  {name:<22} {p['p50']:9.1f} {p['p99']:9.1f} {p['p99_9']:9.1f} {p['max']:11.1f}"


def format_table(result: dict) -> str:
    paced = result["paced"]["timing"]
    lines = [f"rtctl bench loop — {result['robot']} ({result['joints']} joints), full stack, "
             f"{result['rate_hz']:g} Hz for {result['seconds']:g} s",
             f"  {'paced (µs)':<22} {'p50':>9} {'p99':>9} {'p99.9':>9} {'max':>11}",
             _row("wake lateness", paced["wake_lateness_us"])]
    for phase, p in paced["compute_us"].items():
        lines.append(_row(f"compute: {phase}", p))
    lines += [f"  ticks {paced['ticks']}, overruns {paced['overruns']}, skipped periods {paced['skipped_periods']}, "
              f"achieved {paced['achieved_rate_hz']:.1f} Hz, dropped telemetry rows {result['paced']['dropped_rows']}"]
    for run in result["lockstep"]:
        lines += _lockstep_rows(run)
    return "\n".join(lines)


def _lockstep_rows(run: dict) -> list[str]:
    timing = run["timing"]
    lines = [f"lock-step, telemetry on — {Path(run['config']).name} ({', '.join(run['controllers'])})",
             f"  {'tick split (µs)':<22} {'p50':>9} {'p99':>9} {'p99.9':>9} {'max':>11}"]
    lines += [_row(phase, p) for phase, p in timing["compute_us"].items()]
    lines.append(f"  {'compiled kernels (µs)':<22} {'calls':>9} {'µs/call':>9} {'µs/tick':>9}")
    for name, k in run["kernels"].items():
        lines.append(f"  {name[:22]:<22} {k['calls_per_tick']:9.2f} {k['us_per_call']:9.2f} {k['us_per_tick']:9.2f}")
    ratio = f"{run['overhead_ratio']:.2f}" if run["overhead_ratio"] else "-"
    ceiling = run["compiled_realtime_ratio"]
    lines += [f"  kernels sum {run['kernels_us']:.2f} µs/tick; overhead ratio tick p50 / kernels = {ratio}",
              f"  real time: {run['realtime_ratio']:.1f}× achieved, {ceiling or 0:.0f}× compiled floor "
              f"({run['realtime_ratio'] / ceiling if ceiling else 0:.3f} of it); exit code {run['exit_code']}"]
    return lines
