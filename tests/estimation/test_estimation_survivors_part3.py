"""More tests for the estimation mutants that survived mutation run estimation-s30 (the first
part: test_estimation_survivors_part2.py), each against a documented or hand-computed expectation."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.cli import main
from rtctl.errors import RtctlError
from rtctl.estimation import ArxOrder, SageHusa, identify
from rtctl.estimation.sage_husa import RCOV_HAT, R_HAT, first_nonfinite
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


def test_arx_order_default_is_the_papers_and_the_commands():
    """n = 2, d = 1 (the paper's; ``rtctl identify``'s --na, --nb, --d defaults 2, 2, 1)."""
    assert (ArxOrder().na, ArxOrder().nb, ArxOrder().d) == (2, 2, 1)


def test_two_recorded_rows_are_enough(tmp_path):
    """N ≥ 2: two rows give one filter step."""
    got = identify_run(_recording(tmp_path / "run.msgpack", rows=2))
    assert got["samples"] == 2 and got["eps"].shape == (1, 1)


def test_a_recording_without_its_rate_has_no_period(tmp_path):
    path = tmp_path / "run.msgpack"
    rec = Recorder(path, {"t": ((), "f8"), "q": (1, "f8"), "tau": (1, "f8")}, {"joints": ["a"]}, wait_when_full=True)
    for k in range(10):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k, 0.1 * k, 1.0
        rec.commit()
    rec.close()
    assert identify_run(path)["period"] is None
    with pytest.raises(RtctlError, match="does not say its rate"):
        identify_run(path, period=0.02)


def test_identify_command_prints_one_line_per_joint_and_no_note_for_a_complete_run(tmp_path, capsys):
    path = tmp_path / "run.msgpack"
    rec = Recorder(path, {"t": ((), "f8"), "q": (2, "f8"), "tau": (2, "f8")}, {"rate_hz": 100, "joints": ["hip", "knee"]},
                   wait_when_full=True)
    rng = np.random.default_rng(1)
    for k in range(20):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / 100, rng.normal(size=2), rng.normal(size=2)
        rec.commit()
    rec.close()
    assert main(["identify", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert not any(line.startswith("note:") for line in lines), lines
    assert [line.split()[0] for line in lines[-2:]] == ["hip", "knee"]
    assert len(lines[-1].split()) == 1 + 5 + 3  # name, a1 a2 b0 b1 b2, r̂ R̂ rms ε


@pytest.mark.parametrize("noise_form", ["sage_husa", "residual"])
def test_R_sample_is_eps_squared_when_s_is_zero(noise_form):
    """h = 0: s = 0, K = 0, both (25) and (25′) give ε²; d_0 = 1: R̂(1) = ε² = 9 for y = 3."""
    f = SageHusa(1, 2, R0=0.5, adapt=("R",), noise_form=noise_form)
    f.update(0, [0.0, 0.0], 3.0)
    assert f.R_hat[0] == pytest.approx(9.0, rel=1e-15)


def test_R_sample_of_exactly_zero_is_not_replaced():
    """(25): ε² − hᵀP(1|0)h, replaced by ε² only when negative. h = 2, P = 1: s = 4; y = 2: ε² = 4,
    the sample is 0 and with d_0 = 1 R̂(1) = 0, floored at R_min."""
    f = SageHusa(1, 1, P0=1.0, R0=1.0, R_min=1e-12, adapt=("R",))
    f.update(0, [2.0], 2.0)
    assert f.R_hat[0] == 1e-12


@pytest.mark.parametrize(("a", "b"), [("theta", "Q_hat"), ("theta", "q_hat"), ("q_hat", "Q_hat"), ("r_hat", "R_hat")])
def test_first_nonfinite_flags_any_two_estimates_whose_sum_overflows(a, b):
    """"finite values whose sum overflowed (≈ 1e308: diverged all the same)"."""
    f = SageHusa(1, 2)
    where = {"theta": (f.theta, (1, 0)), "q_hat": (f.q_hat, (1, 0)), "Q_hat": (f.Q_hat, (1, 0)),
             "r_hat": (f.signals, (R_HAT, 0)), "R_hat": (f.signals, (RCOV_HAT, 0))}
    for name in (a, b):
        array, index = where[name]
        array[index] = 1e308
    assert first_nonfinite(0, f.theta, f.P, f.q_hat, f.Q_hat, f.signals) >= 0


@pytest.mark.parametrize("value", [True, 2.0])
@pytest.mark.parametrize("name", ["na", "nb", "d"])
def test_arx_order_refuses_a_bool_or_a_float(name, value):
    """Orders are integers ("must be an integer from 1 to …"): True and 2.0 are not."""
    with pytest.raises(ValueError, match=name):
        ArxOrder(**{name: value})
