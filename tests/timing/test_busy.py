"""The loop's share of its core (rtctl/timing/busy.py), on fake clocks: per-second windows, the
warning against Linux's SCHED_FIFO budget, the Ticker's summary and the config rule on spin_us."""
from pathlib import Path

import pytest
import structlog

from rtctl.config import load_config
from rtctl.errors import ConfigError
from rtctl.summary_table import format_summary
from rtctl.timing.busy import WARN_FRACTION, BusyMeter, rt_budget
from rtctl.timing.clock import FakeClock
from rtctl.timing.scheduler import Ticker

P = 1_000_000  # 1 ms
S = 1_000_000_000


class FakeCpu:
    """The loop thread's CPU clock: advanced by the test for the time the thread is on a CPU."""

    def __init__(self):
        self.ns = 7_000

    def __call__(self):
        return self.ns


def loop(ticker, clock, cpu, ticks, compute_ns, spin_ns):
    """Ticks whose work takes ``compute_ns`` and whose wait spins ``spin_ns`` before waking."""
    for _ in range(ticks):
        cpu.ns += spin_ns  # the spin before this tick's deadline
        ticker.wait()
        clock.advance(compute_ns)
        cpu.ns += compute_ns
        ticker.mark(0)
        ticker.end_tick()


def test_the_share_per_second_is_compute_plus_spin_over_the_period():
    clock, cpu = FakeClock(0), FakeCpu()
    ticker = Ticker(P, clock=clock, busy=BusyMeter(cpu_clock=cpu))
    ticker.start()
    loop(ticker, clock, cpu, 1000, 150_000, 200_000)   # 35 % for a second
    loop(ticker, clock, cpu, 1000, 150_000, 750_000)   # then 90 %
    loop(ticker, clock, cpu, 500, 150_000, 200_000)
    busy = ticker.summary()["core_busy"]
    assert busy["max"] == pytest.approx(0.90, abs=0.002)
    assert busy["mean"] == pytest.approx((0.35 * 1000 + 0.90 * 1000 + 0.35 * 500) / 2500, abs=0.002)
    assert busy["budget"] is None
    assert ticker.busy.windows == 2  # whole seconds only: the last half second is in the mean


def test_lock_step_reports_no_share_it_never_sleeps():
    clock, cpu = FakeClock(0), FakeCpu()
    ticker = Ticker(P, clock=clock, realtime_factor=0, busy=BusyMeter(cpu_clock=cpu))
    ticker.start()
    loop(ticker, clock, cpu, 10, 150_000, 0)
    assert ticker.summary()["core_busy"] is None


@pytest.mark.parametrize("share, warned", [(0.95, True), (WARN_FRACTION * 0.95 + 0.01, True),
                                           (WARN_FRACTION * 0.95 - 0.01, False), (0.40, False)])
def test_a_second_near_the_fifo_budget_warns_once_per_ten_seconds(share, warned):
    clock, cpu = FakeClock(0), FakeCpu()
    meter = BusyMeter(limit=0.95, cpu_clock=cpu)
    meter.start(0)
    with structlog.testing.capture_logs() as logs:
        for second in range(1, 13):
            cpu.ns += round(share * S)
            meter.sample(second * S - 1)  # not yet a whole second
            meter.sample(second * S)
    warnings = [e for e in logs if e["event"] == "loop keeps its core busy"]
    assert meter.windows == 12 and meter.max_share == pytest.approx(share)
    if warned:
        assert len(warnings) == 2  # seconds 1 and 11
        assert warnings[0]["share"] == pytest.approx(share, abs=1e-3) and "spin_us" in warnings[0]["fix"]
    else:
        assert warnings == []


def test_without_a_budget_nothing_warns():
    cpu = FakeCpu()
    meter = BusyMeter(limit=None, cpu_clock=cpu)
    meter.start(0)
    with structlog.testing.capture_logs() as logs:
        cpu.ns += S
        meter.sample(S)
    assert logs == [] and meter.max_share == pytest.approx(1.0)


@pytest.mark.parametrize("runtime, period, expected", [("950000\n", "1000000\n", 0.95), ("-1\n", "1000000\n", None),
                                                       ("500000", "1000000", 0.5), ("x", "1000000", None)])
def test_rt_budget_reads_the_kernel_knobs(tmp_path, runtime, period, expected):
    (tmp_path / "runtime").write_text(runtime)
    (tmp_path / "period").write_text(period)
    assert rt_budget(str(tmp_path / "runtime"), str(tmp_path / "period")) == expected
    assert rt_budget(str(tmp_path / "absent"), str(tmp_path / "period")) is None


def test_the_summary_table_shows_the_share():
    summary = {"timing": {"ticks": 10, "core_busy": {"mean": 0.41, "max": 0.47, "budget": 0.95}}}
    text = format_summary(summary)
    assert "core busy 41 % mean, 47 % worst second   (SCHED_FIFO budget 95 %)" in text


PUMA = Path(__file__).resolve().parents[2] / "configs" / "robots" / "puma560.toml"


def loop_config(tmp_path, loop):
    path = tmp_path / "run.toml"
    path.write_text(f'[robot]\ndescription = "{PUMA}"\n[sim]\n[loop]\n{loop}\n')
    return path


def test_a_spin_over_half_the_period_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError) as e:
        load_config(loop_config(tmp_path, "rate_hz = 1000.0\nspin_us = 800.0"))
    assert e.value.key_path == "loop.spin_us" and "at most half the period (500 µs at 1000 Hz)" in str(e.value)
    assert load_config(loop_config(tmp_path, "rate_hz = 1000.0\nspin_us = 500.0")).loop.spin_us == 500.0


def test_the_default_spin_is_a_quarter_period_at_high_rates(tmp_path):
    assert load_config(loop_config(tmp_path, "rate_hz = 5000.0")).loop.spin_us == pytest.approx(50.0)
    assert load_config(loop_config(tmp_path, "rate_hz = 500.0")).loop.spin_us == 200.0
