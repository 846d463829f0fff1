"""The loop's pacing and statistics, the cases a run of every rtctl/timing mutant found
unchecked in scheduler.py and stats.py (docs/mutation/timing.md). Each expectation is the
documented behaviour, worked out here by hand:

* the ticker: a period of 0 ns is refused, 1 ns taken; an overrun limit of 1 is taken, 0 not;
  overruns are logged at most once per second (999 999 999 ns later is suppressed); the log's
  µs keep their fractions; deadlines are exact integers on any clock, so a tick 1 ns past its
  deadline overruns even at 2^60 ns; after an overrun on a clock that did not start at 0 the
  next tick is the first grid point not yet past; the realtime factor is the nearest fraction
  with a denominator ≤ 10^9; a run's summary counts its last period and reports how busy the
  core was only once a tick ran;
* the statistics: the documented bucket layout (32 per octave, width 2^(bit_length − 6), 1152
  buckets, the last one for 2^40 − 1 ns and more, the maximum exact); a percentile is the
  middle of its bucket; the summary's µs carry 3 decimals (1 ns), the period too; no rate for
  a wall time of 0; no overruns means a longest run of 0; ``compute_us`` is the tick and its
  phases, not lateness.
"""
from fractions import Fraction

import numpy as np
import pytest
import structlog

from rtctl.timing.clock import FakeClock
from rtctl.timing.scheduler import PHASES, Ticker
from rtctl.timing.stats import MAX_VALUE_NS, N_BUCKETS, LoopStats, bucket_bounds, bucket_index, percentiles_of
from test_ticker import P, make, run_tick



@pytest.mark.parametrize("kw, refused", [({"period_ns": 0}, True), ({"period_ns": 1}, False),
                                         ({"period_ns": P, "max_consecutive_overruns": 0}, True),
                                         ({"period_ns": P, "max_consecutive_overruns": 1}, False)])
def test_a_period_of_one_ns_and_an_overrun_limit_of_one_are_the_least_taken(kw, refused):
    if refused:
        with pytest.raises(ValueError):
            Ticker(clock=FakeClock(), **kw)
    else:
        Ticker(clock=FakeClock(), **kw)


def _overrun_at(ticker, clock, end_ns):
    """Run one tick that ends at ``end_ns`` on the clock."""
    ticker.wait()
    clock.advance(end_ns - clock.t)
    ticker.mark(len(PHASES) - 1)
    ticker.end_tick()


@pytest.mark.parametrize("gap_ns, logged", [(999_999_999, 1), (1_000_000_000, 2)])
def test_overrun_records_are_at_least_a_second_apart(gap_ns, logged):
    ticker, clock = make(start_ns=0, max_consecutive_overruns=10**9)
    with structlog.testing.capture_logs() as logs:
        _overrun_at(ticker, clock, 1_500_000)  # tick 0 ends past tick 1's deadline
        first = clock.t
        _overrun_at(ticker, clock, first + gap_ns)  # a tick that overran by far more
    assert len([r for r in logs if r["event"] == "tick overrun"]) == logged


def test_the_overrun_record_keeps_fractions_of_a_microsecond():
    clock = FakeClock(0, wake_latency_ns=1_250)
    ticker = Ticker(P, clock=clock, max_consecutive_overruns=10**9)
    ticker.start()
    with structlog.testing.capture_logs() as logs:
        run_tick(ticker, clock, (100_500, 900_000, 0, 0, 750))  # ends 1 001 250 + 1 250 ns after the start
    record = next(r for r in logs if r["event"] == "tick overrun")
    assert record["wake_lateness_us"] == 1.25
    assert record["late_us"] == 2.5  # 1 002 500 − 1 000 000 ns
    assert record["phases_us"]["read"] == 100.5 and record["phases_us"]["record"] == 0.75


def test_deadlines_are_exact_integers_on_any_clock():
    start = 2 ** 60 + 136  # where a float's steps are 256 ns: start + 1 ms in floats is 56 ns late
    ticker, clock = make(start_ns=start)
    assert ticker.deadline_ns(3) == start + 3 * P and isinstance(ticker.deadline_ns(3), int)
    _overrun_at(ticker, clock, start + P + 1)  # 1 ns past tick 1's deadline
    assert ticker.summary()["overruns"] == 1


def test_after_an_overrun_the_next_tick_is_the_first_grid_point_not_yet_past():
    ticker, clock = make(start_ns=7_000_000_000)
    _overrun_at(ticker, clock, 7_000_000_000 + 3_500_000)  # tick 0 ends 3.5 periods in
    assert ticker.wait() == 4 and clock.sleeps[-1] == 7_000_000_000 + 4 * P


@pytest.mark.parametrize("factor", [0.123456789, 2 ** -0.5, 1 / 7])
def test_the_realtime_factor_is_the_nearest_fraction_with_a_denominator_up_to_a_billion(factor):
    """tick k is due at start + k · period / f, f the nearest fraction n/d with d ≤ 10^9."""
    f = Fraction(factor).limit_denominator(10 ** 9)
    ticker, clock = make(start_ns=0, realtime_factor=factor)
    k = 10 ** 13  # (far enough for a fraction nearer still to move the deadline)
    assert ticker.deadline_ns(k) == k * P * f.denominator // f.numerator


def test_a_runs_summary_counts_its_last_period_and_the_core_once_a_tick_ran():
    ticker, clock = make(start_ns=0)
    before = ticker.summary()
    assert before["core_busy"] is None and before["wall_time_s"] == 0.0
    run_tick(ticker, clock, (100_000, 0, 0, 0, 0))  # tick 0 ends 0.1 ms in
    after = ticker.summary()
    assert after["wall_time_s"] == 0.001  # until its period is over
    assert after["core_busy"] is not None


@pytest.mark.parametrize("x", [64, 100, 1000, 65_535, 10 ** 9, 2 ** 39 + 12345])
def test_a_bucket_is_2_to_the_bit_length_minus_6_wide(x):
    low, width = bucket_bounds(bucket_index(x))
    assert int(width) == 2 ** (x.bit_length() - 6) and low <= x < low + width


def test_the_layout_has_1152_buckets_the_last_for_all_from_2_to_the_40_and_an_exact_max():
    assert N_BUCKETS == 1152 and MAX_VALUE_NS == 2 ** 40 - 1
    assert bucket_index(2 ** 40 - 1) == bucket_index(2 ** 45) == N_BUCKETS - 1
    assert bucket_index(2 ** 39) < N_BUCKETS - 1
    stats = LoopStats()
    stats.record(None, [2 ** 45, 0, 0, 0, 0], 2 ** 45)
    assert stats.percentiles_ns("read")["max"] == 2 ** 45


@pytest.mark.parametrize("x, middle", [(1000, 992 + 7.5), (10, 10.0), (70, 70.5)])
def test_a_percentile_is_the_middle_of_its_bucket(x, middle):
    """1000 is in [992, 1008): its middle, 999.5; 10 has a bucket of its own; 70 is in [70, 72)."""
    counts = np.zeros(N_BUCKETS, dtype=np.int64)
    counts[bucket_index(x)] = 5
    assert percentiles_of(counts, max_ns=10 ** 6)["p50"] == middle


def test_the_summary_is_in_microseconds_to_the_nanosecond():
    stats = LoopStats()
    for _ in range(3):
        stats.record(1000, [1000, 1, 2, 3, 4], 1010)
    s = stats.summary(wall_time_s=0.003, period_s=0.0012345678, realtime_factor=1.0)
    assert s["period_us"] == 1234.568
    values = [v for row in [s["wake_lateness_us"], *s["compute_us"].values()] for k, v in row.items() if k != "count"]
    assert all(round(v * 1000) == pytest.approx(v * 1000, abs=1e-9) for v in values)
    assert s["wake_lateness_us"]["p50"] == 1.0  # 999.5 ns, to the ns
    assert list(s["compute_us"]) == ["tick", *PHASES]
    assert s["max_consecutive_overruns"] == 0


def test_no_rate_for_a_wall_time_of_zero():
    s = LoopStats().summary(wall_time_s=0.0, period_s=0.001, realtime_factor=1.0)
    assert s["achieved_rate_hz"] is None and s["realtime_ratio"] is None
