"""The scheduler alone on the real clock: what the machine gives an empty loop (like cyclictest).

* an empty tick (five marked phases, nothing in them) paced at ``rate`` for ``seconds``:
  wake lateness and tick overhead percentiles, overruns — the floor under ``rtctl bench loop``;
* the cost of ``LoopStats.record`` and of the ticker's own per-tick work (lock-step, no sleep).
"""
from __future__ import annotations

import os
import time

import numpy as np

from rtctl.timing.rt import RtSettings, apply_rt
from rtctl.timing.scheduler import PHASES, Ticker
from rtctl.timing.stats import LoopStats


def empty_loop(rate_hz: float, seconds: float, spin_margin_us: float = 200.0,
               realtime_factor: float = 1.0) -> dict:
    """Run empty ticks at ``rate_hz`` for ``seconds`` (of simulated time) and return the summary."""
    ticker = Ticker(round(1e9 / rate_hz), realtime_factor=realtime_factor,
                    spin_margin_ns=round(spin_margin_us * 1e3), max_consecutive_overruns=10**9)
    n = round(rate_hz * seconds)
    mark, marks = ticker.mark, range(len(PHASES))
    ticker.start()
    while ticker.tick < n - 1:
        ticker.wait()
        for phase in marks:
            mark(phase)
        ticker.end_tick()
    return ticker.summary()


def record_cost_us(calls: int = 200_000) -> float:
    """µs per tick of the statistics' bookkeeping (``LoopStats.record_marks``: the phase times
    from the marks and every histogram) with µs-scale values (best of 5)."""
    stats = LoopStats()
    stamps, phase_ns = np.cumsum([12_345, 45_678, 3_456, 7_890, 2_345]) + 1_000, np.zeros(5, dtype=np.int64)
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter_ns()
        for _ in range(calls):
            stats.record_marks(stamps, 1_000, 72_714, 3_000, phase_ns)
        best = min(best, (time.perf_counter_ns() - t0) / calls / 1e3)
    return best


def _steal_jiffies() -> int | None:
    """Time the hypervisor ran something else on our vCPUs (/proc/stat "steal"), or None."""
    try:
        with open("/proc/stat") as f:
            return int(f.readline().split()[8])
    except (OSError, IndexError, ValueError):
        return None


def bench_loop_timing(rate_hz: float = 1000.0, seconds: float = 10.0, spin_margin_us: float = 200.0,
                      rt: RtSettings | None = None) -> dict:
    """The paced empty loop plus the bookkeeping costs; ``rt`` knobs are applied to this process first."""
    knobs = [r.as_dict() for r in apply_rt(rt)] if rt is not None else []  # reported, not enforced
    lockstep = empty_loop(rate_hz, 2.0, realtime_factor=0)
    record_us = record_cost_us()
    steal0 = _steal_jiffies()
    paced = empty_loop(rate_hz, seconds, spin_margin_us)
    steal1 = _steal_jiffies()
    return {
        "rate_hz": rate_hz, "seconds": seconds, "spin_margin_us": spin_margin_us, "rt": knobs,
        "record_us": record_us,
        "tick_overhead_us": lockstep["wall_time_s"] / lockstep["ticks"] * 1e6,
        "paced": paced,
        "loadavg_1min": os.getloadavg()[0],
        "steal_ms": None if steal0 is None else (steal1 - steal0) * 1000 / os.sysconf("SC_CLK_TCK"),
    }


def format_table(result: dict) -> str:
    p = result["paced"]
    lines = [f"empty loop, {result['rate_hz']:g} Hz for {result['seconds']:g} s, spin margin "
             f"{result['spin_margin_us']:g} µs: {p['ticks']} ticks, {p['overruns']} overruns, "
             f"{p['skipped_periods']} skipped, achieved {p['achieved_rate_hz']:.1f} Hz",
             f"machine: load average {result['loadavg_1min']:.2f}, hypervisor steal "
             f"{result['steal_ms'] if result['steal_ms'] is not None else '?'} ms during the run",
             f"{'µs':<28}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}"]
    for label, s in (("wake lateness", p["wake_lateness_us"]), ("tick (5 empty phases)", p["compute_us"]["tick"])):
        lines.append(f"{label:<28}{s['p50']:>8.2f}{s['p99']:>8.2f}{s['p99_9']:>8.2f}{s['max']:>9.1f}")
    lines.append(f"LoopStats.record: {result['record_us']:.2f} µs/call; ticker bookkeeping "
                 f"(wait + 5 marks + end_tick, no sleep): {result['tick_overhead_us']:.2f} µs/tick")
    lines += [f"rt {k['knob']}: {k['status']} ({k['detail']})" for k in result["rt"]]
    return "\n".join(lines)
