"""How busy the loop keeps its core, against the share Linux lets a SCHED_FIFO thread take.

A paced loop sleeps until ``spin_us`` before each deadline and spins the rest, so its thread is
on a CPU for its compute plus the spin. Linux gives SCHED_FIFO threads at most
``sched_rt_runtime_us`` of every ``sched_rt_period_us`` (950 ms of each second by default);
a thread that takes more is stopped for the rest of the second — up to 50 ms, fifty missed
ticks at 1 kHz — while ordinary tasks run (since Linux 6.12 the "fair server" does the same
whenever one of them is waiting for that core). Measured on a 2-core VM: the C* job at 1 kHz
with 800 µs of spin kept its core 95 % busy and was stopped for 20–47 ms about every 2 s;
with 200 µs, 40 % busy and no stall. :class:`BusyMeter` measures the share per second and
warns before it gets there.
"""
from __future__ import annotations

import time

import structlog

log = structlog.get_logger("rtctl.loop")

RT_RUNTIME_US = "/proc/sys/kernel/sched_rt_runtime_us"
RT_PERIOD_US = "/proc/sys/kernel/sched_rt_period_us"
WINDOW_NS = 1_000_000_000  # Linux's default sched_rt_period_us
WARN_FRACTION = 0.8  # warn when a window takes more than this fraction of the budget
WARN_INTERVAL_NS = 10_000_000_000  # at most one warning per 10 s


def rt_budget(runtime_path: str = RT_RUNTIME_US, period_path: str = RT_PERIOD_US) -> float | None:
    """The share of each period SCHED_FIFO threads may use (0.95 by default); None when there is
    no limit (``sched_rt_runtime_us = -1``) or it cannot be read."""
    try:
        with open(runtime_path) as f:
            runtime = int(f.read())
        with open(period_path) as f:
            period = int(f.read())
    except (OSError, ValueError):
        return None
    if runtime < 0 or period <= 0:
        return None
    return runtime / period


class BusyMeter:
    """The loop thread's CPU time over each second of wall time (``window_ns``).

    ``sample(now_ns)`` once per tick costs one integer comparison; the thread's CPU clock is
    read only when a window is over. ``limit``: the budget to warn against (:func:`rt_budget`
    when the loop runs SCHED_FIFO), or None for no warning. Shares (the warning's and the
    summary's) are rounded to 0.001, i.e. 0.1 %: a budget in whole ms of the kernel's default
    1 s period reads exactly.
    """

    def __init__(self, limit: float | None = None, *, cpu_clock=time.thread_time_ns, window_ns: int = WINDOW_NS):
        if window_ns <= 0:
            raise ValueError("window_ns must be > 0")
        self.limit = limit
        self.cpu_clock = cpu_clock
        self.window_ns = int(window_ns)
        self.windows = 0
        self.max_share = 0.0
        self._start_wall = self._start_cpu = self._wall0 = self._cpu0 = 0
        self._window_end = 0
        self._last_warning_ns: int | None = None

    def start(self, now_ns: int) -> None:
        self._start_wall = self._wall0 = now_ns
        self._start_cpu = self._cpu0 = self.cpu_clock()
        self._window_end = now_ns + self.window_ns

    def sample(self, now_ns: int) -> None:
        if now_ns >= self._window_end:
            self._close(now_ns)

    def _close(self, now_ns: int) -> None:
        cpu = self.cpu_clock()
        share = (cpu - self._cpu0) / (now_ns - self._wall0)
        self.windows += 1
        self.max_share = max(self.max_share, share)
        self._wall0, self._cpu0, self._window_end = now_ns, cpu, now_ns + self.window_ns
        if self.limit is not None and share > WARN_FRACTION * self.limit and (
                self._last_warning_ns is None or now_ns - self._last_warning_ns >= WARN_INTERVAL_NS):
            self._last_warning_ns = now_ns
            log.warning("loop keeps its core busy", share=round(share, 3), budget=round(self.limit, 3),
                        detail="a SCHED_FIFO thread over its budget is stopped for the rest of the second "
                               "(up to 50 ms)", fix="lower [loop] spin_us, or the work per tick")

    def summary(self, now_ns: int) -> dict:
        """``mean`` over the whole run (None before any wall time has passed), ``max`` over whole
        windows (None before the first) and the ``budget``, each to 0.001."""
        wall = now_ns - self._start_wall
        mean = (self.cpu_clock() - self._start_cpu) / wall if wall > 0 else None
        return {"mean": None if mean is None else round(mean, 3),
                "max": round(self.max_share, 3) if self.windows else None,
                "budget": None if self.limit is None else round(self.limit, 3)}
