"""The real clock's contract (never early, survives signals) and the bench's shape — no timing asserts."""
import signal
import time

import pytest

from rtctl.bench.loop_timing import empty_loop, format_table
from rtctl.timing.clock import FakeClock, MonotonicClock


@pytest.mark.parametrize("margin", [0, 50_000, 10**9])
def test_the_real_clock_never_wakes_before_the_deadline(margin):
    clock = MonotonicClock(spin_margin_ns=margin)
    for _ in range(20):
        deadline = time.monotonic_ns() + 300_000
        clock.sleep_until_ns(deadline)
        assert time.monotonic_ns() >= deadline
    clock.sleep_until_ns(time.monotonic_ns() - 10**9)  # a past deadline returns at once


def test_a_signal_during_the_sleep_runs_its_handler_and_the_sleep_resumes():
    """A 20 ms timer during a 100 ms sleep: the handler runs, and the sleep still ends no earlier
    than its deadline. A machine that stalls the process past the deadline delivers the signal
    after the sleep, which tests nothing: up to five tries for one that lands inside it."""
    fired = []
    old = signal.signal(signal.SIGALRM, lambda *_: fired.append(time.monotonic_ns()))
    try:
        inside = 0
        for _ in range(5):
            fired.clear()
            signal.setitimer(signal.ITIMER_REAL, 0.02)
            deadline = time.monotonic_ns() + 100_000_000
            MonotonicClock(spin_margin_ns=0).sleep_until_ns(deadline)
            assert deadline <= time.monotonic_ns()  # never early, interrupted or not
            signal.setitimer(signal.ITIMER_REAL, 0)
            inside += len(fired) == 1 and fired[0] < deadline
            if inside:
                break
        assert inside, "the timer's signal never arrived during the sleep"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def test_fake_clock_moves_only_when_told():
    clock = FakeClock(10, wake_latency_ns=3)
    clock.sleep_until_ns(5)  # in the past: no jump back
    assert clock.now_ns() == 13
    clock.sleep_until_ns(100)
    clock.advance(7)
    assert (clock.now_ns(), clock.sleeps) == (110, [5, 100])
    with pytest.raises(ValueError):
        MonotonicClock(spin_margin_ns=-1)


def test_the_empty_loop_bench_returns_a_full_summary():
    s = empty_loop(2000, 0.05)
    assert s["ticks"] <= 100 <= s["ticks"] + s["skipped_periods"]  # a skip may jump past the end
    assert s["wake_lateness_us"]["count"] == s["ticks"] and s["wake_lateness_us"]["p50"] >= 0
    result = {"rate_hz": 2000, "seconds": 0.05, "spin_margin_us": 200, "rt": [], "record_us": 1.0,
              "tick_overhead_us": 3.0, "paced": s, "loadavg_1min": 0.5, "steal_ms": None}
    assert "wake lateness" in format_table(result)


def test_the_real_clock_sleeps_on_the_monotonic_clock_and_spins_only_the_margin(monkeypatch):
    """One absolute sleep on CLOCK_MONOTONIC to deadline − margin, then the spin: a clock that
    spun the whole way (or slept on another clock, returning at once) would keep its core busy
    and run into Linux's SCHED_FIFO budget (rtctl/timing/busy.py)."""
    clock = MonotonicClock(200_000)
    calls = []

    def nanosleep(clock_id, flags, ts_ref, remain):
        ts = ts_ref._obj
        wake = ts.tv_sec * 1_000_000_000 + ts.tv_nsec
        calls.append((clock_id, flags, wake))
        time.sleep(max(0, wake - time.monotonic_ns()) / 1e9)
        return 0

    monkeypatch.setattr(clock, "_nanosleep", nanosleep)
    deadline = time.monotonic_ns() + 30_000_000
    clock.sleep_until_ns(deadline)
    assert calls == [(time.CLOCK_MONOTONIC, 1, deadline - 200_000)]  # TIMER_ABSTIME = 1 (<time.h>)
    assert time.monotonic_ns() >= deadline
    calls.clear()
    clock.sleep_until_ns(time.monotonic_ns() + 100_000)  # within the margin: spin only
    assert calls == []
