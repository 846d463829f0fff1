"""Issue 26 item 14: small things a newcomer met — each is what the message says now."""
from __future__ import annotations

import logging
from types import SimpleNamespace

import numpy as np
from structlog.testing import capture_logs

from rtctl.progress import Progress


def test_the_progress_line_of_a_run_without_a_duration_has_no_duration_none():
    ticker = SimpleNamespace(wake_ns=0, stats=SimpleNamespace(ticks=5, overruns=0))
    state, ref = SimpleNamespace(position=np.zeros(2)), SimpleNamespace(q=np.ones(2))
    for duration in (None, 10.0):
        ticker.wake_ns = 0
        progress = Progress(1.0, duration, ticker, state, ref)
        ticker.wake_ns = 2_000_000_000
        with capture_logs() as logs:
            progress.tick(2.0)
        (line,) = logs
        assert line["event"] == "running" and line.get("duration", "absent") == (duration or "absent")


def test_python_cans_partial_socketcand_reads_are_counted_not_printed(caplog):
    from drivers.can_bus import PartialReads

    before = PartialReads.count
    logger = logging.getLogger("can.interfaces.socketcand.socketcand")
    with caplog.at_level(logging.WARNING):
        logger.warning("Got incomplete message => waiting for more data")
        logger.warning("Bad data: No opening < found => discarding entire buffer 'x'")  # a real problem: shown
    assert PartialReads.count == before + 1
    assert [r.getMessage()[:8] for r in caplog.records] == ["Bad data"]


def test_bench_guard_without_ompl_says_it_is_not_installed_and_how_to_get_it(monkeypatch):
    import importlib.util

    from rtctl.bench import guard

    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    why = guard._ompl({})["why"]
    assert why.startswith("OMPL is not installed") and "'.[bench]'" in why and "IndexError" not in why


def test_a_duration_of_1e300_is_refused_with_the_bound_not_nan_figures(write_config, recwarn):
    import pytest

    from rtctl.config import load_config
    from rtctl.errors import ConfigError, TrajectoryError
    from rtctl.trajectory import JointLimits, retarget
    from runtime_helpers import BASE

    limits = JointLimits(np.ones(2), np.ones(2), -3 * np.ones(2), 3 * np.ones(2))
    with pytest.raises(TrajectoryError) as e:
        retarget(0.0, np.zeros(2), np.zeros(2), np.zeros(2), [[0.5, 0.5]], limits, duration=1e300)
    assert "at most 1e+06 s" in str(e.value) and "nan" not in str(e.value)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]  # refused before any overflow
    with pytest.raises(ConfigError) as e:
        load_config(write_config(BASE.replace("velocity_scale = 0.4", "velocity_scale = 0.4\ndurations = [1e300, 1, 1]")))
    assert e.value.key_path == "trajectory.durations" and "up to 1e+06" in e.value.expected
