"""Tests for timing mutants that survived the run of every mutant (docs/mutation/timing.md), part 2:
the core-busy meter (rtctl/timing/busy.py) and the tick's compiled bookkeeping
(rtctl/timing/record.py), each against the documented behaviour or Linux's:

* ``rt_budget``: a runtime of 0 is a budget of 0, a period of 0 gives no budget, a period of
  1 µs is a period;
* the meter's window is Linux's default ``sched_rt_period_us`` (1 s); ``window_ns`` must be
  > 0 and 1 ns will do;
* the warning: above 80 % of the budget (not at it), at most one per 10 s (a warning 10 s
  after the last one is allowed, 1 ns sooner it is not);
* shares are rounded to 0.001, in the warning and the summary; a summary at the start instant
  has no mean;
* ``bit_length`` is ``int.bit_length`` from 0; a phase not marked in a tick counts 0 even when
  its stamp from the last tick equals the wake (a clock that did not move).
"""
import pytest
import structlog

from rtctl.timing import record
from rtctl.timing.busy import WARN_FRACTION, BusyMeter, rt_budget
from rtctl.timing.clock import FakeClock
from rtctl.timing.scheduler import Ticker

S = 1_000_000_000
WARNING = "loop keeps its core busy"


class FakeCpu:
    """The loop thread's CPU clock, advanced by the test."""

    def __init__(self, ns=0):
        self.ns = ns

    def __call__(self):
        return self.ns


def _budget(tmp_path, runtime, period):
    (tmp_path / "runtime").write_text(runtime)
    (tmp_path / "period").write_text(period)
    return rt_budget(str(tmp_path / "runtime"), str(tmp_path / "period"))


def test_a_runtime_of_zero_is_a_budget_of_zero(tmp_path):
    """Linux: sched_rt_runtime_us = 0 gives SCHED_FIFO threads no time at all (only -1 is no limit)."""
    assert _budget(tmp_path, "0\n", "1000000\n") == 0.0


def test_a_period_of_zero_has_no_budget(tmp_path):
    assert _budget(tmp_path, "950000\n", "0\n") is None


def test_a_period_of_one_microsecond_is_a_period(tmp_path):
    """sched_rt_period_us takes 1 … INT_MAX (Documentation/scheduler/sched-rt-group.rst)."""
    assert _budget(tmp_path, "1\n", "1\n") == 1.0


def test_the_default_window_is_linux_s_default_rt_period_of_one_second():
    """Linux's default sched_rt_period_us is 1 000 000 µs: a window closes 1 s after the start, not before."""
    cpu = FakeCpu()
    meter = BusyMeter(cpu_clock=cpu)
    meter.start(0)
    meter.sample(S - 1)
    assert meter.windows == 0
    meter.sample(S)
    assert meter.windows == 1


def test_a_window_must_be_positive_and_one_nanosecond_will_do():
    with pytest.raises(ValueError):
        BusyMeter(window_ns=0)
    with pytest.raises(ValueError):
        BusyMeter(window_ns=-1)
    cpu = FakeCpu()
    meter = BusyMeter(cpu_clock=cpu, window_ns=1)
    meter.start(10)
    cpu.ns = 1
    meter.sample(11)
    assert meter.windows == 1 and meter.max_share == 1.0


def _warned_at(meter, cpu, times):
    """Sample a fully busy core at each time; the times a warning came."""
    warned, wall = [], 0
    with structlog.testing.capture_logs() as logs:
        for t in times:
            cpu.ns += t - wall  # the thread on its core all the time
            wall = t
            n = len(logs)
            meter.sample(t)
            if any(e["event"] == WARNING for e in logs[n:]):
                warned.append(t)
    return warned


def test_a_warning_comes_again_ten_seconds_after_the_last_and_not_sooner():
    """At most one warning per 10 s: exactly 10 s later is the next allowed; 10 s − 1 ns is too soon."""
    cpu = FakeCpu()
    meter = BusyMeter(limit=0.95, cpu_clock=cpu, window_ns=1)
    meter.start(0)
    times = [S, 11 * S - 1, 11 * S, 21 * S - 1, 21 * S]
    assert _warned_at(meter, cpu, times) == [S, 11 * S, 21 * S]


def test_a_window_at_exactly_the_warning_fraction_does_not_warn():
    """'more than this fraction of the budget': 0.4 of the core against a budget of 0.5 is at 80 %, not over."""
    cpu = FakeCpu()
    meter = BusyMeter(limit=0.5, cpu_clock=cpu, window_ns=5)
    meter.start(0)
    assert 2 / 5 == WARN_FRACTION * 0.5  # the share below is exactly at the threshold
    with structlog.testing.capture_logs() as logs:
        cpu.ns = 2
        meter.sample(5)  # 2 ns of CPU in 5 ns: 0.4
        assert logs == []
        cpu.ns = 5
        meter.sample(10)  # 3 in 5: 0.6, over
    assert [e["event"] for e in logs] == [WARNING]


def test_the_warning_gives_the_share_and_the_budget_to_a_thousandth():
    cpu = FakeCpu()
    meter = BusyMeter(limit=2 / 3, cpu_clock=cpu, window_ns=6)
    meter.start(0)
    with structlog.testing.capture_logs() as logs:
        cpu.ns = 5
        meter.sample(6)  # 5/6 of the core
    (warning,) = logs
    assert (warning["share"], warning["budget"]) == (0.833, 0.667)


def test_the_summary_gives_shares_to_a_thousandth():
    cpu = FakeCpu()
    meter = BusyMeter(limit=2 / 3, cpu_clock=cpu, window_ns=3)
    meter.start(0)
    cpu.ns = 1
    meter.sample(3)  # one window: 1/3
    assert meter.summary(6) == {"mean": 0.167, "max": 0.333, "budget": 0.667}  # mean 1 ns in 6


def test_a_summary_at_the_start_instant_has_no_mean():
    cpu = FakeCpu(123)
    meter = BusyMeter(cpu_clock=cpu)
    meter.start(5_000)
    assert meter.summary(5_000) == {"mean": None, "max": None, "budget": None}


def test_bit_length_is_int_bit_length_from_zero():
    """The docstring: int.bit_length of 0 ≤ x < 2⁶³ (plain Python when called from Python)."""
    xs = list(range(0, 300)) + [(1 << k) + d for k in range(1, 63) for d in (-1, 0, 1)] + [(1 << 63) - 1]
    assert [record.bit_length(x) for x in xs] == [x.bit_length() for x in xs]


def test_a_phase_not_marked_counts_zero_when_its_old_stamp_equals_the_wake():
    """Lock-step on a clock that does not move between ticks: phase b, marked last tick at the
    instant the next tick wakes, is not marked this tick and takes 0 (it took −7 ns before)."""
    clock = FakeClock(0)
    ticker = Ticker(1_000_000, clock=clock, realtime_factor=0, phases=("a", "b"))
    ticker.start()
    ticker.wait()
    clock.advance(10)
    ticker.mark(0)
    clock.advance(10)
    ticker.mark(1)
    ticker.end_tick()
    assert ticker.phase_ns.tolist() == [10, 10]
    ticker.wait()  # wakes at 20, b's stamp
    clock.advance(7)
    ticker.mark(0)
    ticker.end_tick()
    assert ticker.phase_ns.tolist() == [7, 0]

