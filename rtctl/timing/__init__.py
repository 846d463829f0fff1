"""Timing side of the runtime: the fixed-rate ticker, its statistics, real-time knobs, doctor.

- :mod:`rtctl.timing.clock` — monotonic clock with sleep-then-spin; a fake clock for tests
- :mod:`rtctl.timing.scheduler` — :class:`Ticker` (deadlines, overrun policy), :func:`due`
- :mod:`rtctl.timing.stats` — :class:`LoopStats` (log-bucket histograms, O(1) memory)
- :mod:`rtctl.timing.busy` — :class:`BusyMeter` (the loop's share of its core against Linux's SCHED_FIFO budget)
- :mod:`rtctl.timing.rt` — :func:`apply_rt` (SCHED_FIFO, affinity, mlockall, timer slack, GC freeze)
- :mod:`rtctl.timing.doctor` — :func:`doctor`, :func:`format_doctor` (machine readiness, with advice;
  import it from its module: the package does not re-export it, so the module name stays usable)
"""
from rtctl.timing.busy import BusyMeter, rt_budget
from rtctl.timing.clock import FakeClock, MonotonicClock
from rtctl.timing.rt import KnobReport, KnobStatus, RtSettings, apply_rt
from rtctl.timing.scheduler import DAEMON_PHASES, PHASES, RECORD, READ, SAFETY, SERVE, UPDATE, WRITE, Ticker, due
from rtctl.timing.stats import LoopStats

__all__ = [
    "FakeClock", "MonotonicClock", "Ticker", "due", "LoopStats", "BusyMeter", "rt_budget",
    "RtSettings", "KnobReport", "KnobStatus", "apply_rt",
    "PHASES", "READ", "UPDATE", "SAFETY", "WRITE", "RECORD", "DAEMON_PHASES", "SERVE",
]
