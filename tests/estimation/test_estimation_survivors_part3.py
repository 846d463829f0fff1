"""More tests for the estimation mutants that survived mutation run estimation-s30 (the first
part: test_estimation_survivors_part2.py), each against a documented or hand-computed expectation."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.estimation import identify
from rtctl.estimation.identify import identify_run
from rtctl.errors import TelemetryError
from rtctl.telemetry import Recorder, read


def _recording(path, rows=30, rate=100):
    rng = np.random.default_rng(9)
    rec = Recorder(path, {"t": ((), "f8"), "q": (1, "f8"), "tau": (1, "f8")}, {"rate_hz": rate, "joints": ["a"]},
                   wait_when_full=True)
    for k in range(rows):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / rate, rng.normal(), rng.normal()
        rec.commit()
    rec.close()
    return str(path)


def test_a_period_of_one_tick_reads_every_tick(tmp_path):
    """period = 1/rate: resampled every period seconds is every recorded row (30 rows at 100 Hz)."""
    path = _recording(tmp_path / "run.msgpack")
    got = identify_run(path, period=0.01)
    assert got["samples"] == 30 and got["period"] == pytest.approx(0.01)
    tel = read(path)
    expected = identify(tel["q"].reshape(30), tel["tau"].reshape(30))
    np.testing.assert_array_equal(got["theta"], expected["theta"])


def test_a_period_of_three_ticks_reads_every_third_row(tmp_path):
    path = _recording(tmp_path / "run.msgpack")
    got = identify_run(path, period=0.03)
    assert got["samples"] == 10 and got["period"] == pytest.approx(0.03)


def test_a_period_shorter_than_a_tick_reads_every_tick(tmp_path):
    """Nothing finer than the recording exists: 0.004 s at 100 Hz is every row."""
    path = _recording(tmp_path / "run.msgpack")
    got = identify_run(path, period=0.004)
    assert got["samples"] == 30


def test_a_single_row_is_nothing_to_identify(tmp_path):
    """Telemetry's own refusal (require_rows: "nothing to identify", exit 2) for fewer than 2 rows."""
    path = _recording(tmp_path / "run.msgpack", rows=1)
    with pytest.raises(TelemetryError, match="nothing to identify: 1 rows recorded"):
        identify_run(path)
