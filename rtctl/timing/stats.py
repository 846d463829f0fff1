"""Always-on loop statistics in O(1) memory: log-bucketed histograms of nanosecond times.

Each histogram has 32 linear sub-buckets per power of two (HdrHistogram's layout with
5 significant bits): values below 64 ns get a bucket each (exact), a value ``x ≥ 64`` lands
in a bucket of width ``2^(bit_length(x) − 6)``, i.e. at most 1/32 of ``x``. A percentile
is reported as the middle of its bucket, so it is within **1/64 ≈ 1.6 %** of the exact
order statistic (``numpy.percentile(..., method="inverted_cdf")``); the maximum is exact.
Values of ``2^40 − 1`` ns (18 min) and more count in the last bucket (the maximum stays
exact). A one-hour run at 1 kHz costs the same memory as a one-second one: 7 rows × 1152
counters.

The loop records a tick in one compiled call from its phase marks (:mod:`rtctl.timing.record`),
with no allocation: ``rtctl bench loop-timing`` measures its cost.
"""
from __future__ import annotations

import numpy as np

SUB_BITS = 5  # 2^5 = 32 sub-buckets per octave
_LINEAR = 2 << SUB_BITS  # values below 64 have exact buckets
MAX_VALUE_NS = (1 << 40) - 1
N_BUCKETS = ((MAX_VALUE_NS.bit_length() - SUB_BITS - 1) << SUB_BITS) + _LINEAR
PERCENTILES = (("p50", 50, 100), ("p99", 99, 100), ("p99_9", 999, 1000))


def bucket_index(x: int) -> int:
    """Histogram bucket of a non-negative integer ``x`` (negative → 0, huge → last)."""
    if x < _LINEAR:
        return x if x > 0 else 0
    if x > MAX_VALUE_NS:
        x = MAX_VALUE_NS
    s = x.bit_length() - SUB_BITS - 1
    return (s << SUB_BITS) + (x >> s)


def bucket_bounds(i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest value and width of buckets ``i`` (the inverse of :func:`bucket_index`)."""
    i = np.asarray(i, dtype=np.int64)
    shift = np.maximum((i >> SUB_BITS) - 1, 0)
    low = np.where(i < _LINEAR, i, (i - (shift << SUB_BITS)) << shift)
    return low, np.int64(1) << shift


def percentiles_of(counts, max_ns: float) -> dict:
    """count, p50, p99, p99_9, max of a histogram in this layout (``counts`` per bucket, the
    largest value ``max_ns`` exact), in ns (None when it is empty)."""
    counts = np.asarray(counts, dtype=np.int64)
    n = int(counts.sum())
    out = {"count": n}
    if n == 0:
        return out | {name: None for name, _, _ in PERCENTILES} | {"max": None}
    cum = np.cumsum(counts)
    for name, num, den in PERCENTILES:
        rank = -(-n * num // den)  # ceil(n·q) in integers: the inverted-CDF order statistic
        low, width = bucket_bounds(np.searchsorted(cum, rank))
        out[name] = min(float(low + (width - 1) / 2), float(max_ns))
    out["max"] = float(max_ns)
    return out


class LoopStats:
    """Per-tick timing statistics: wake lateness, whole-tick compute time and each phase's.

    Row 0 is wake lateness (actual wake − deadline), row 1 the tick's compute time
    (wake → end of tick), rows 2… the phases, in the order given.
    """

    def __init__(self, phases=("read", "update", "safety", "write", "record")):
        self.phases = tuple(phases)
        self.rows = ("wake_lateness", "tick") + self.phases
        from rtctl.timing.record import record_tick  # (numba: not before a command needs it)

        self._record = record_tick
        self._counts = np.zeros(N_BUCKETS * len(self.rows), dtype=np.int64)  # row r at offset r·N_BUCKETS
        self._max = np.zeros(len(self.rows), dtype=np.int64)
        self.ticks = 0
        self.overruns = 0
        self.skipped_periods = 0
        self.max_consecutive_overruns = 0

    def record(self, lateness_ns: int | None, phase_ns, compute_ns: int) -> None:
        """Add one tick. ``lateness_ns`` is None when nothing waited (lock-step mode);
        ``phase_ns`` is a sequence of ints, one per phase. (The loop itself records through
        :meth:`record_marks`, from its phase marks and with no allocation.)"""
        phase_ns = np.asarray(phase_ns, dtype=np.int64)
        self.record_marks(np.cumsum(phase_ns), 0, int(compute_ns), lateness_ns, np.empty_like(phase_ns))

    def record_marks(self, stamps, wake_ns: int, end_ns: int, lateness_ns: int | None, phase_ns) -> None:
        """Add one tick from its marks: ``stamps`` (int64 array, one per phase) are the clock at
        each phase's end, ``phase_ns`` receives the phase times (0 for a phase whose stamp is not
        after ``wake_ns``: not marked this tick). One compiled call
        (:func:`rtctl.timing.record.record_tick`)."""
        self.ticks += 1
        self._record(self._counts, self._max, stamps, wake_ns, end_ns,
                     0 if lateness_ns is None else lateness_ns, lateness_ns is not None, phase_ns)

    def record_overrun(self, skipped: int, consecutive: int) -> None:
        self.overruns += 1
        self.skipped_periods += skipped
        if consecutive > self.max_consecutive_overruns:
            self.max_consecutive_overruns = consecutive

    def percentiles_ns(self, row: str) -> dict:
        """count, p50, p99, p99_9, max of one row, in ns (None when the row is empty)."""
        r = self.rows.index(row)
        return percentiles_of(self._counts[r * N_BUCKETS:(r + 1) * N_BUCKETS], int(self._max[r]))

    def copy_counts(self, row: str, out: np.ndarray) -> None:
        """The row's histogram (N_BUCKETS counts) into ``out``: a snapshot to diff later."""
        r = self.rows.index(row)
        out[:] = self._counts[r * N_BUCKETS:(r + 1) * N_BUCKETS]

    def summary(self, wall_time_s: float, period_s: float, realtime_factor: float) -> dict:
        """JSON-able digest in µs: counts, percentiles, overruns, achieved rate."""

        def us(row):
            p = self.percentiles_ns(row)
            return {k: (v if k == "count" or v is None else round(v / 1e3, 3)) for k, v in p.items()}

        sim_time_s = self.ticks * period_s
        return {
            "ticks": self.ticks,
            "overruns": self.overruns,
            "skipped_periods": self.skipped_periods,
            "max_consecutive_overruns": self.max_consecutive_overruns,
            "period_us": round(period_s * 1e6, 3),
            "realtime_factor": realtime_factor,
            "target_rate_hz": realtime_factor / period_s if realtime_factor > 0 else None,
            "achieved_rate_hz": self.ticks / wall_time_s if wall_time_s > 0 else None,
            "wall_time_s": wall_time_s,
            "sim_time_s": sim_time_s,
            "realtime_ratio": sim_time_s / wall_time_s if wall_time_s > 0 else None,
            "wake_lateness_us": us("wake_lateness"),
            "compute_us": {row: us(row) for row in self.rows[1:]},
            "resolution": "log buckets, 32 per octave: percentiles within 1.6 %, max exact",
        }
