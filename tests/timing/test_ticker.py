"""Scheduler policy on a fake clock: deterministic, no timed assertions."""
import json
import math
from fractions import Fraction

import pytest
import structlog

from rtctl.timing.clock import FakeClock
from rtctl.timing.scheduler import PHASES, RECORD, Ticker, due

P = 1_000_000  # 1 ms


def run_tick(ticker, clock, phase_ns=(100_000, 300_000, 50_000, 50_000, 0)):
    """One tick whose phases take the given times on the fake clock."""
    k = ticker.wait()
    for i, t in enumerate(phase_ns):
        clock.advance(t)
        ticker.mark(i)
    return k, ticker.end_tick()


def slow(total_ns):
    """Phase times of a tick lasting ``total_ns``, most of it in update."""
    return (100_000, total_ns - 200_000, 50_000, 50_000, 0)


def make(start_ns=5_000, **kw):
    clock = FakeClock(start_ns)
    ticker = Ticker(P, clock=clock, **kw)
    ticker.start()
    return ticker, clock


def test_deadlines_lie_exactly_on_the_grid():
    ticker, clock = make()
    ks = [run_tick(ticker, clock)[0] for _ in range(50)]
    assert ks == list(range(50))
    assert clock.sleeps == [5_000 + k * P for k in range(50)]
    s = ticker.summary()
    assert (s["overruns"], s["skipped_periods"], s["ticks"]) == (0, 0, 50)
    assert s["achieved_rate_hz"] == s["target_rate_hz"] == 1000.0 and s["wall_time_s"] == 0.05


@pytest.mark.parametrize("factor", [2.0, 0.5, 3.0, 1 / 3, 0.7])
def test_realtime_factor_scales_the_wall_clock_grid(factor):
    ticker, clock = make(realtime_factor=factor)
    for _ in range(40):
        run_tick(ticker, clock, (10_000,) * 5)
    f = Fraction(factor).limit_denominator(10**9)
    assert clock.sleeps == [5_000 + math.floor(k * P / f) for k in range(40)]
    assert ticker.sim_time_s == pytest.approx(39 * 1e-3)


def test_a_long_tick_skips_the_missed_periods_instead_of_catching_up():
    ticker, clock = make(start_ns=0)
    run_tick(ticker, clock)
    run_tick(ticker, clock)
    k, stop = run_tick(ticker, clock, slow(3_500_000))  # tick 2 ends at 5.5 ms
    assert (k, stop) == (2, False)
    wakes = []
    for _ in range(3):
        k, _ = run_tick(ticker, clock)
        wakes.append((k, clock.sleeps[-1]))
    # deadlines 3, 4, 5 ms were missed: the next tick is tick 6 at 6 ms, then 7 and 8 — no burst
    assert wakes == [(6, 6 * P), (7, 7 * P), (8, 8 * P)]
    s = ticker.summary()
    assert (s["overruns"], s["skipped_periods"], s["ticks"]) == (1, 3, 6)
    assert s["achieved_rate_hz"] == pytest.approx(6 / 9e-3)  # 6 ticks in 9 periods


def test_ending_exactly_on_the_next_deadline_is_not_an_overrun():
    ticker, clock = make(start_ns=0)
    run_tick(ticker, clock, (P, 0, 0, 0, 0))
    assert run_tick(ticker, clock)[0] == 1
    assert ticker.stats.overruns == 0
    run_tick(ticker, clock, (P + 1, 0, 0, 0, 0))  # one ns too long
    assert run_tick(ticker, clock)[0] == 4
    assert (ticker.stats.overruns, ticker.stats.skipped_periods) == (1, 1)


def test_a_tick_ending_exactly_on_a_later_deadline_runs_that_tick_on_time():
    ticker, clock = make(start_ns=0)
    run_tick(ticker, clock, (3 * P, 0, 0, 0, 0))  # tick 0 ends at 3 ms sharp: 1 and 2 are missed
    assert run_tick(ticker, clock, (0,) * 5)[0] == 3
    assert ticker.lateness_ns == 0
    assert (ticker.stats.overruns, ticker.stats.skipped_periods) == (1, 2)
    run_tick(ticker, clock, (2 * P + 1, 0, 0, 0, 0))  # tick 4 ends one ns past 6 ms: 5 and 6 are missed
    assert run_tick(ticker, clock, (0,) * 5)[0] == 7
    assert (ticker.stats.overruns, ticker.stats.skipped_periods) == (2, 4)


@pytest.mark.parametrize("factor, tick_ns, overruns", [
    (2.0, 800_000, True),  # 0.5 ms of wall time per period: a 0.8 ms tick overruns every time
    (0.5, 1_500_000, False),  # 2 ms of wall time per period: a 1.5 ms tick is on time
    (4.0, 300_000, True),
    (0.25, 3_900_000, False),
])
def test_overruns_are_judged_on_the_scaled_grid(factor, tick_ns, overruns):
    ticker, clock = make(start_ns=0, realtime_factor=factor, max_consecutive_overruns=5)
    stops = [run_tick(ticker, clock, slow(tick_ns))[1] for _ in range(6)]
    if overruns:
        assert ticker.stats.overruns == 6 and stops == [False] * 4 + [True, True]
    else:
        assert ticker.stats.overruns == 0 and not any(stops)


def test_a_late_wakeup_that_misses_the_next_deadline_counts_as_overrun():
    clock = FakeClock(0, wake_latency_ns=1_500_000)
    ticker = Ticker(P, clock=clock)
    ticker.start()
    assert run_tick(ticker, clock, (0,) * 5)[0] == 0  # woke at 1.5 ms, past tick 1's deadline
    assert (ticker.stats.overruns, ticker.stats.skipped_periods) == (1, 1)
    assert run_tick(ticker, clock, (0,) * 5)[0] == 2
    assert ticker.summary()["wake_lateness_us"]["max"] == 1500.0


def test_consecutive_overruns_request_a_safe_stop_and_a_good_tick_resets_the_count():
    ticker, clock = make(max_consecutive_overruns=3)
    with structlog.testing.capture_logs() as logs:
        for _ in range(2):
            assert run_tick(ticker, clock, slow(1_500_000))[1] is False
        assert ticker.consecutive_overruns == 2
        assert run_tick(ticker, clock)[1] is False  # good tick
        assert ticker.consecutive_overruns == 0
        results = [run_tick(ticker, clock, slow(1_500_000))[1] for _ in range(3)]
        assert results == [False, False, True]
        assert run_tick(ticker, clock)[1] is True  # latched
    stops = [r for r in logs if r["log_level"] == "error"]
    assert len(stops) == 1 and stops[0]["consecutive"] == 3
    s = ticker.summary()
    assert s["safe_stop_requested"] is True
    assert (s["overruns"], s["max_consecutive_overruns"]) == (5, 3)


def test_overrun_logs_are_throttled_to_one_per_second_with_phase_times_and_suppressed_count():
    ticker, clock = make(start_ns=0, max_consecutive_overruns=10**9)
    phases = (200_000, 1_000_000, 100_000, 100_000, 100_000)  # 1.5 ms: every tick overruns
    with structlog.testing.capture_logs() as logs:
        ends = []
        while clock.t < 2_500_000_000:
            run_tick(ticker, clock, phases)
            ends.append(clock.t)
    records = [r for r in logs if r["event"] == "tick overrun"]
    # the first overrun is logged; the next record is the first overrun ≥ 1 s after it
    logged_at = [ends[0]]
    for t in ends:
        if t - logged_at[-1] >= 1_000_000_000:
            logged_at.append(t)
    assert len(records) == len(logged_at) == 3
    assert records[0]["suppressed"] == 0
    assert [r["suppressed"] for r in records[1:]] == [
        ends.index(logged_at[i]) - ends.index(logged_at[i - 1]) - 1 for i in (1, 2)
    ]
    assert records[1]["suppressed"] > 400  # ~500 overruns per second at 2 ms per tick
    assert records[0]["phases_us"] == dict(zip(PHASES, (200.0, 1000.0, 100.0, 100.0, 100.0)))
    assert records[0]["skipped_periods"] == 1 and records[0]["late_us"] == 500.0
    assert all(r["log_level"] == "warning" for r in records)


def test_lock_step_never_sleeps_and_never_overruns():
    clock = FakeClock(0)
    ticker = Ticker(P, realtime_factor=0, clock=clock)
    ticker.start()
    ks = [run_tick(ticker, clock, slow(7_000_000))[0] for _ in range(100)]
    assert ks == list(range(100)) and clock.sleeps == []
    assert ticker.sim_time_s == pytest.approx(0.099)
    s = ticker.summary()
    assert (s["overruns"], s["ticks"], s["wake_lateness_us"]["count"]) == (0, 100, 0)
    assert s["target_rate_hz"] is None
    assert s["realtime_ratio"] == pytest.approx(1 / 7)  # 1 ms simulated per 7 ms of wall time


def test_an_unmarked_phase_reads_zero_not_the_previous_tick():
    ticker, clock = make()
    run_tick(ticker, clock, (1, 2, 3, 4, 5))
    ticker.wait()
    clock.advance(9)
    ticker.mark(RECORD)  # everything since the wake-up is booked on the last phase
    ticker.end_tick()
    assert ticker.phase_ns.tolist() == [0, 0, 0, 0, 9]


def test_phase_and_tick_times_reach_the_statistics():
    ticker, clock = make()
    for _ in range(10):
        run_tick(ticker, clock, (10, 20, 30, 40, 50))
    c = ticker.summary()["compute_us"]
    assert [c[name]["max"] for name in PHASES] == [0.01, 0.02, 0.03, 0.04, 0.05]
    assert c["tick"]["count"] == 10
    assert c["tick"]["p50"] == pytest.approx(0.15, rel=1 / 64)  # the histogram's resolution


def test_summary_is_json_serialisable():
    ticker, clock = make()
    run_tick(ticker, clock)
    json.dumps(ticker.summary(), allow_nan=False)


def test_due_runs_each_slot_once_and_a_skipped_slot_late():
    assert [k for k in range(12) if due(k - 1, k, 4)] == [0, 4, 8]
    assert all(due(k - 1, k, 1) for k in range(5))
    assert due(2, 6, 4)  # ticks 3-5 skipped: slot 4 runs late at tick 6
    assert not due(4, 6, 4)  # slot 4 already ran


def test_ticker_due_follows_the_skips():
    ticker, clock = make(start_ns=0)
    runs = []
    for phases in [slow(500_000)] * 3 + [slow(2_500_000)] + [slow(500_000)] * 4:
        ticker.wait()
        if ticker.due(3):
            runs.append(ticker.tick)
        for i, t in enumerate(phases):
            clock.advance(t)
            ticker.mark(i)
        ticker.end_tick()
    # ticks 0,1,2,3(long),6,7,8,9: slots 0, 3, 6, 9 each run exactly once
    assert runs == [0, 3, 6, 9]


@pytest.mark.parametrize("kw", [{"realtime_factor": -1}, {"realtime_factor": 1e-12}, {"max_consecutive_overruns": 0}])
def test_bad_arguments_are_refused(kw):
    with pytest.raises(ValueError):
        Ticker(P, clock=FakeClock(), **kw)


def test_every_divisor_runs_on_the_first_tick():
    ticker, clock = make()
    ticker.wait()
    assert all(ticker.due(d) for d in (1, 2, 3, 20))


def test_nanosecond_phase_times_reach_the_percentiles():
    ticker, clock = make()
    for _ in range(10):
        run_tick(ticker, clock, (10, 20, 30, 40, 50))
    c = ticker.summary()["compute_us"]
    assert [c[name]["p50"] for name in PHASES] == pytest.approx([0.01, 0.02, 0.03, 0.04, 0.05], rel=1 / 32)
