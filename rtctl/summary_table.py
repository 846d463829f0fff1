"""The run summary as a small table for a person at a terminal (``rtctl run`` with console
logs); scripts read the JSON summary (``--summary``) or the ``summary`` log line instead."""
from __future__ import annotations

import math

from rtctl.timing import DAEMON_PHASES

_DASH = "–"


def format_summary(summary: dict) -> str:
    timing = summary.get("timing") or {}
    tracking = summary.get("tracking_error_rad") or {}
    safety = summary.get("safety") or {}
    lines = [f"run summary — {summary.get('stop_reason') or 'not started'} (exit {summary.get('exit_code')})"]

    rate, ratio = timing.get("achieved_rate_hz"), timing.get("realtime_ratio")
    lines.append(f"  ticks {timing.get('ticks', 0)}   overruns {timing.get('overruns', 0)}   "
                 f"rate {_num(rate, '.1f')} Hz   {_num(ratio, '.2f')}× real time")
    busy = timing.get("core_busy")
    if busy:
        budget = f"   (SCHED_FIFO budget {_percent(busy.get('budget'))})" if busy.get("budget") is not None else ""
        lines.append(f"  core busy {_percent(busy.get('mean'))} mean, {_percent(busy.get('max'))} "
                     f"worst second{budget}")

    rows = [("wake lateness", timing.get("wake_lateness_us") or {})]
    compute = timing.get("compute_us") or {}
    rows += [("compute " + name, compute.get(name) or {}) for name in ("tick", *DAEMON_PHASES) if name in compute]
    lines.append(f"  {'µs':<18}{'p50':>10}{'p99':>10}{'max':>10}")
    for label, stats in rows:
        lines.append(f"  {label:<18}" + "".join(f"{_num(stats.get(k), '.1f'):>10}" for k in ("p50", "p99", "max")))

    rms, worst = tracking.get("rms") or {}, tracking.get("max") or {}
    if rms:
        names = list(rms)
        width = max(9, *(len(n) + 1 for n in names))
        lines.append(f"  {'tracking (mrad)':<18}" + "".join(f"{n:>{width}}" for n in names) + f"{'all':>{width}}")
        for label, per_joint, overall in (("rms", rms, tracking.get("rms_all")),
                                          ("max", worst, tracking.get("max_all"))):
            values = [per_joint.get(n) for n in names] + [overall]
            lines.append(f"  {label:<18}" + "".join(f"{_num(_milli(v), '.3f'):>{width}}" for v in values))

    faults = safety.get("faults") or []
    if faults:
        lines.append(f"  faults {len(faults)}: " + "; ".join(f"{f['kind']} ({f['reason']})" for f in faults[:3])
                     + (" …" if len(faults) > 3 else ""))
    else:
        lines.append("  faults none")
    tele = summary.get("telemetry")
    if tele:
        lines.append(f"  telemetry {tele['path']} ({tele['rows']} rows, {tele['dropped_rows']} dropped)")
    return "\n".join(lines)


def _percent(value) -> str:
    return _DASH if value is None else f"{100 * value:.0f} %"


def _milli(value):
    return None if value is None else 1e3 * value


def _num(value, spec: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return _DASH
    return format(value, spec)
