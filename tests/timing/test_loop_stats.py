"""Histogram statistics against numpy on known data, within the stated bin resolution."""
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rtctl.timing.stats import MAX_VALUE_NS, N_BUCKETS, LoopStats, bucket_bounds, bucket_index

RES = 1 / 64  # a percentile is the middle of a bucket at most 1/32 of its value wide


@given(st.integers(min_value=0, max_value=MAX_VALUE_NS))
def test_every_value_lies_in_its_bucket_and_buckets_are_at_most_1_32_wide(x):
    i = bucket_index(x)
    low, width = bucket_bounds(i)
    assert 0 <= i < N_BUCKETS
    assert low <= x < low + width
    assert width == 1 or width <= x / 32


def test_bucket_index_is_monotonic_and_clamps():
    xs = np.unique(np.geomspace(1, MAX_VALUE_NS, 5000).astype(np.int64))
    idx = [bucket_index(int(x)) for x in xs]
    assert idx == sorted(idx)
    assert bucket_index(-5) == 0
    assert bucket_index(10 * MAX_VALUE_NS) == N_BUCKETS - 1


def filled(data):
    s = LoopStats(phases=("a",))
    for x in data:
        s.record(int(x), [int(x) // 2], int(x) * 3)
    return s


@pytest.mark.parametrize(
    "data",
    [
        np.random.default_rng(1).lognormal(np.log(5_000), 1.0, 100_000),  # µs-scale latencies
        np.random.default_rng(2).exponential(300_000, 20_001),
        np.random.default_rng(3).integers(0, 200, 997),  # exact region below 64 ns and just above
        # heavy tail; not exactly 0.1 % slow, where numpy's float rank (0.999·n) rounds up one sample
        np.r_[np.full(9_000, 2_000), np.full(989, 50_000), np.full(11, 3_000_000)],
    ],
)
def test_percentiles_agree_with_numpy_within_the_bin_resolution(data):
    data = data.astype(np.int64)
    s = filled(data)
    for row, values in (("wake_lateness", data), ("a", data // 2), ("tick", data * 3)):
        p = s.percentiles_ns(row)
        assert p["count"] == len(data)
        assert p["max"] == values.max()
        for name, q in (("p50", 50), ("p99", 99), ("p99_9", 99.9)):
            exact = np.percentile(values, q, method="inverted_cdf")
            assert abs(p[name] - exact) <= RES * exact + 0.5, (row, name)
            # numpy's default (linear) interpolates between neighbours: within a bucket width
            assert p[name] == pytest.approx(np.percentile(values, q), rel=2 * RES, abs=1)


def test_tail_percentiles_see_the_rare_slow_ticks():
    s = filled(np.r_[np.full(9_990, 1_000), np.full(10, 1_000_000)])
    p = s.percentiles_ns("wake_lateness")
    assert p["p99"] == pytest.approx(1_000, rel=RES)
    assert p["p99_9"] == pytest.approx(1_000, rel=RES)  # 10 of 10 000 is exactly 0.1 %
    s = filled(np.r_[np.full(9_989, 1_000), np.full(11, 1_000_000)])
    assert s.percentiles_ns("wake_lateness")["p99_9"] == pytest.approx(1_000_000, rel=RES)


def test_empty_rows_and_lock_step_rows():
    s = LoopStats()
    assert s.percentiles_ns("tick") == {"count": 0, "p50": None, "p99": None, "p99_9": None, "max": None}
    s.record(None, [1, 2, 3, 4, 5], 15)
    assert s.percentiles_ns("wake_lateness")["count"] == 0
    assert s.percentiles_ns("update") == {"count": 1, "p50": 2.0, "p99": 2.0, "p99_9": 2.0, "max": 2.0}


def test_memory_does_not_grow_with_the_run_length():
    s = LoopStats()
    before = len(s._counts)
    for x in range(0, 10**12, 10**8):
        s.record(x, [x] * 5, x)
    assert len(s._counts) == before == N_BUCKETS * 7
    assert s.percentiles_ns("tick")["max"] == 10**12 - 10**8  # max is exact even past the clamp


def test_summary_reports_rates_and_overruns_in_microseconds():
    s = LoopStats()
    for _ in range(1000):
        s.record(2_000, [1_000] * 5, 5_000)
    s.record_overrun(3, 1)
    s.record_overrun(1, 2)
    out = s.summary(wall_time_s=2.0, period_s=1e-3, realtime_factor=1.0)
    assert (out["ticks"], out["overruns"], out["skipped_periods"], out["max_consecutive_overruns"]) == (1000, 2, 4, 2)
    assert out["achieved_rate_hz"] == 500.0 and out["target_rate_hz"] == 1000.0
    assert out["realtime_ratio"] == 0.5
    assert out["wake_lateness_us"]["p50"] == pytest.approx(2.0, rel=RES)
    assert out["compute_us"]["tick"]["max"] == 5.0


def test_copy_counts_takes_exactly_one_rows_histogram():
    stats = LoopStats(("a", "b"))
    for x in (1_000, 50_000, 50_000, 2_000_000):
        stats.record(x, [x // 2, 7], x)
    out = np.full(N_BUCKETS, -1, dtype=np.int64)
    stats.copy_counts("wake_lateness", out)
    assert out.sum() == 4 and out[bucket_index(50_000)] == 2 and out[bucket_index(2_000_000)] == 1
    stats.copy_counts("a", out)
    assert out.sum() == 4 and out[bucket_index(25_000)] == 2


@given(st.lists(st.integers(min_value=-5, max_value=4 * MAX_VALUE_NS), min_size=3, max_size=3))
def test_the_compiled_record_puts_each_value_in_bucket_index_s_bucket(values):
    """record_tick (compiled) against the Python bucket_index, values from negative to past the clamp."""
    lateness, compute, phase = values
    s = LoopStats(phases=("a",))
    s.record(lateness, [phase], compute)
    for row, x in (("wake_lateness", lateness), ("tick", compute), ("a", phase)):
        r = s.rows.index(row)
        counts = s._counts[r * N_BUCKETS:(r + 1) * N_BUCKETS]
        assert counts.sum() == 1 and counts[bucket_index(max(x, 0))] == 1
        assert s._max[r] == max(x, 0) if x <= MAX_VALUE_NS else s._max[r] == x


def test_phase_times_come_from_the_marks_and_an_unmarked_phase_counts_zero():
    s = LoopStats(phases=("a", "b", "c"))
    phase_ns = np.zeros(3, dtype=np.int64)
    s.record_marks(np.array([1_500, 700, 4_000]), 1_000, 4_200, None, phase_ns)  # b's stamp predates the wake
    assert phase_ns.tolist() == [500, 0, 2_500]
    assert s.percentiles_ns("tick")["max"] == 3_200 and s.percentiles_ns("wake_lateness")["count"] == 0
