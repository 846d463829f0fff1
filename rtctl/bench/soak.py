"""``rtctl bench soak``: the full stack over HIL for N minutes, and what a long run must hold.

``hil-sim`` plays the robot and its drives in its own process behind socketcand (by default
``configs/puma560_hil_mixed.toml``: the arm on CiA 402 drives, the wrist on MIT drives, one bus
each); the daemon runs here, as ``rtctl run`` would, with telemetry on. Reported:

* RSS when the loop starts and when it ends (goal: growth ≤ 1 MB);
* garbage collections during the loop (goal: none) — and the net number of objects the
  collector tracks that the loop left behind (``gc.get_count``: with automatic collection off,
  as the shipped configurations run, what a collection would have had to look at);
* overruns and the wake lateness p99, per minute of loop time;
* telemetry rows in the file against ticks (goal: equal);
* drives left enabled at the end, as hil-sim reports them (goal: none).

Take the numbers with the machine's load (printed): the loop shares the cores with everything else.
"""
from __future__ import annotations

import gc
import json
import os
import select
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from rtctl import logs
from rtctl.timing.stats import N_BUCKETS, percentiles_of

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "puma560_hil_mixed.toml"
GOALS = {"rss_growth_bytes": 1 << 20, "gc_collections": 0, "drives_enabled": 0}


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


class _PerMinute:
    """Wraps the daemon's tick: at each minute of loop time, a snapshot of the lateness
    histogram, overruns and ticks (into arrays allocated before the loop); the minute's
    largest lateness. Every other attribute is the tick's."""

    def __init__(self, tick, ticker, duration_s: float):
        slots = int(np.ceil(duration_s / 60.0)) + 2
        own = dict(inner=tick, ticker=ticker, counts=np.zeros((slots, N_BUCKETS), dtype=np.int64),
                   overruns=np.zeros(slots, dtype=np.int64), ticks=np.zeros(slots, dtype=np.int64),
                   max_late=np.zeros(slots), minute=0, next_t=60.0, end_t=duration_s)
        self.__dict__.update(own)

    def __call__(self, t: float):
        verdict = self.inner(t)
        late = self.ticker.lateness_ns
        if late > self.max_late[self.minute + 1]:
            self.max_late[self.minute + 1] = late
        if t >= self.next_t and self.next_t < self.end_t:  # (the last minute closes with the run)
            self.snapshot()
            self.__dict__["next_t"] += 60.0
        return verdict

    def snapshot(self) -> None:
        m = self.__dict__["minute"] = self.minute + 1
        stats = self.ticker.stats
        stats.copy_counts("wake_lateness", self.counts[m])
        self.overruns[m], self.ticks[m] = stats.overruns, stats.ticks

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def __setattr__(self, name, value):  # (the daemon sets the tick's trajectory on `move`)
        setattr(self.inner, name, value)

    def rows(self) -> list[dict]:
        out = []
        for m in range(1, self.minute + 1):
            p = percentiles_of(self.counts[m] - self.counts[m - 1], self.max_late[m])
            out.append({"minute": m, "ticks": int(self.ticks[m] - self.ticks[m - 1]),
                        "overruns": int(self.overruns[m] - self.overruns[m - 1]),
                        "lateness_p99_us": None if p["p99"] is None else p["p99"] / 1e3,
                        "lateness_max_us": p["max"] / 1e3 if p["max"] is not None else None})
        return out


def _soak_daemon(cfg, runtime, args, minutes: float):
    from rtctl.daemon import Daemon

    class SoakDaemon(Daemon):
        def _loop(self, server):
            collections = [0, False]  # count, counting

            def on_gc(phase, info):
                if collections[1] and phase == "start":
                    collections[0] += 1

            per_minute = self.tick = _PerMinute(self.tick, self.ticker, 60.0 * minutes)
            gc.callbacks.append(on_gc)
            self.soak = {"rss_start": rss_bytes(), "gc_count_start": gc.get_count()[0], "gc_enabled": gc.isenabled()}
            collections[1] = True
            try:
                super()._loop(server)
            finally:
                collections[1] = False
                self.soak.update(rss_end=rss_bytes(), gc_count_end=gc.get_count()[0], gc_collections=collections[0])
                gc.callbacks.remove(on_gc)
                per_minute.snapshot()  # the last (partial) minute
                self.soak["minutes"] = per_minute.rows()
                self.tick = per_minute.inner

    return SoakDaemon(cfg, runtime, args)


class HilSimProcess:
    """``hil-sim CONFIG --port 0`` in its own process: ``env`` to reach it, ``stop()`` → its exit report."""

    def __init__(self, config: Path, timeout: float = 120.0):
        self.proc = subprocess.Popen([sys.executable, "-m", "hil_sim.cli", str(config), "--port", "0",
                                      "--rt-priority", "70"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line:
            self.proc.kill()
            raise RuntimeError(f"hil-sim did not start: {self.proc.communicate()[1][-2000:]}")
        self.env = json.loads(line)["env"]

    def stop(self) -> dict:
        """Its exit report, with ``motor_events``: every motor on/off it reported."""
        self.proc.send_signal(signal.SIGTERM)
        out, err = self.proc.communicate(timeout=60)
        events = list(map(json.loads, filter(str.strip, out.splitlines())))
        exits = [e for e in events if e.get("event") == "exit"]
        if not exits:
            raise RuntimeError(f"hil-sim gave no exit report: {err[-2000:]}")
        return dict(exits[-1], motor_events=[e for e in events if e.get("event") in ("motor_on", "motor_off")])


def bench_soak(config=None, minutes: float = 10.0) -> dict:
    from rtctl.config import load_config
    from rtctl.runtime import build
    from rtctl.telemetry import read

    if minutes <= 0:
        raise ValueError("minutes must be positive")
    logs.configure("json", level="warning", stream=sys.stderr)
    config = Path(config or SHIPPED)
    load = os.getloadavg()
    sim = HilSimProcess(config)
    try:
        os.environ.update(sim.env)
        cfg = load_config(config)
        with tempfile.TemporaryDirectory(prefix="rtctl-soak-") as tmp:
            telemetry = Path(tmp) / "soak.msgpack"
            args = SimpleNamespace(telemetry=str(telemetry), socket=str(Path(tmp) / "rtctl.sock"),
                                   summary=str(Path(tmp) / "summary.json"), duration=60.0 * minutes, enforce_rt=False)
            daemon = _soak_daemon(cfg, build(cfg), args, minutes)
            code = daemon.run()
            summary = json.loads(Path(args.summary).read_text())
            rows = read(telemetry).rows
    finally:
        sim_exit = sim.stop()
    soak, timing = daemon.soak, summary["timing"]
    return {
        "config": str(config), "minutes": minutes, "exit_code": code, "stop_reason": summary["stop_reason"],
        "load_average_start": load, "load_average_end": os.getloadavg(),
        "rss_start_bytes": soak["rss_start"], "rss_end_bytes": soak["rss_end"],
        "rss_growth_bytes": soak["rss_end"] - soak["rss_start"],
        "gc_enabled_in_loop": soak["gc_enabled"], "gc_collections": soak["gc_collections"],
        "gc_tracked_objects_left": soak["gc_count_end"] - soak["gc_count_start"],
        "ticks": timing["ticks"], "overruns": timing["overruns"], "telemetry_rows": rows,
        "dropped_rows": summary.get("telemetry", {}).get("dropped_rows"),
        "per_minute": soak["minutes"],
        "drives": len(sim_exit["drives"]), "drives_enabled": sum(d["enabled"] for d in sim_exit["drives"]),
        "drives_left_enabled": [d for d in sim_exit["drives"] if d["enabled"]],
        "motor_events": sim_exit["motor_events"], "device_errors": {
            name: d.get("last_error") for name, d in summary["devices"].items()},
        "tracking_max_rad": summary["tracking_error_rad"]["max_all"], "goals": GOALS,
    }


def goals_met(r: dict) -> dict:
    return {"rss_growth": r["rss_growth_bytes"] <= GOALS["rss_growth_bytes"],
            "gc_collections": r["gc_collections"] == GOALS["gc_collections"],
            "rows_equal_ticks": r["telemetry_rows"] == r["ticks"],
            "drives_disabled": r["drives_enabled"] == GOALS["drives_enabled"]}


def format_table(r: dict) -> str:
    mib = 1 << 20
    met = goals_met(r)
    ok = lambda key: "ok" if met[key] else "MISSED"  # noqa: E731
    lines = [f"rtctl bench soak — {Path(r['config']).name}, {r['minutes']:g} min over HIL (socketcand), "
             f"exit {r['exit_code']} ({r['stop_reason']})",
             f"  load average at start {r['load_average_start'][0]:.2f}, at end {r['load_average_end'][0]:.2f} "
             f"(1 min; {os.cpu_count()} cores)",
             f"  RSS {r['rss_start_bytes'] / mib:.1f} → {r['rss_end_bytes'] / mib:.1f} MiB: "
             f"{r['rss_growth_bytes'] / 1024:+.0f} KiB (goal ≤ +1024 KiB) {ok('rss_growth')}",
             f"  GC collections in the loop: {r['gc_collections']} (goal 0) {ok('gc_collections')}; automatic GC "
             f"{'on' if r['gc_enabled_in_loop'] else 'off (gc_freeze)'}, tracked objects left {r['gc_tracked_objects_left']:+d}",
             f"  telemetry rows {r['telemetry_rows']} vs ticks {r['ticks']} {ok('rows_equal_ticks')} "
             f"(dropped {r['dropped_rows']})",
             f"  drives enabled at the end: {r['drives_enabled']} of {r['drives']} {ok('drives_disabled')}"
             + "".join(f"; {d['bus']}/{d['drive']:#x}" for d in r["drives_left_enabled"]),
             *(f"  {name}: {error}" for name, error in r["device_errors"].items() if error),
             f"  tracking max {r['tracking_max_rad'] * 1e3:.1f} mrad; overruns {r['overruns']} in {r['ticks']} ticks",
             f"  {'minute':>6} {'ticks':>7} {'overruns':>8} {'lateness p99 µs':>16} {'max µs':>10}"]
    for m in r["per_minute"]:
        p99 = "-" if m["lateness_p99_us"] is None else f"{m['lateness_p99_us']:.1f}"
        mx = "-" if m["lateness_max_us"] is None else f"{m['lateness_max_us']:.0f}"
        lines.append(f"  {m['minute']:>6} {m['ticks']:>7} {m['overruns']:>8} {p99:>16} {mx:>10}")
    return "\n".join(lines)
