"""A ticker built without a configuration (a script, the bench) paces as a run's ``[loop]``
that sets nothing: one overrun limit and one spin margin, not two that can drift apart."""
from rtctl.config import _loop
from rtctl.timing.clock import FakeClock
from rtctl.timing.scheduler import Ticker
from test_ticker import P, run_tick, slow


def test_a_ticker_stops_after_the_configurations_overrun_limit_by_default():
    loop = _loop(None)
    assert loop.overrun_limit == 50  # docs/architecture.md
    clock = FakeClock(0)
    ticker = Ticker(P, clock=clock)
    ticker.start()
    stops = [run_tick(ticker, clock, slow(1_500_000))[1] for _ in range(loop.overrun_limit)]
    assert stops == [False] * (loop.overrun_limit - 1) + [True]


def test_a_ticker_spins_the_configurations_margin_before_each_deadline_by_default():
    loop = _loop(None)  # (1 kHz: the margin is not cut to a quarter period)
    assert Ticker(P).clock.spin_margin_ns == round(1e3 * loop.spin_us) == 200_000  # docs/architecture.md
