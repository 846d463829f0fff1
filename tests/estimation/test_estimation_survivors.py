"""Tests for the estimation mutants that survived the suite (issue 27, part 3; docs/mutation/estimation.md).

The drift mean's update (26) is checked step by step against the equation itself, from the
filter's own θ̂ before and after each step, and over a run against the printed equations
(rtctl.estimation.printed: plain numpy, none of the safeguards — with R̂ and Q̂ fixed they do not
act). The ARX order's bounds are the documented ones (docs/arma_kalman.md), in ArxOrder and in
``rtctl identify``'s own check (exit 2 naming the option); the non-finite check names each
quantity; identify's RMS prediction error is per channel, summed by hand.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rtctl.estimation import ArxOrder, SageHusa, identify, simulate
from rtctl.cli import main
from rtctl.estimation.printed import PrintedSageHusa
from rtctl.estimation.sage_husa import QUANTITIES, RCOV_HAT, R_HAT, first_nonfinite
from rtctl.telemetry import Recorder

P_DIM = 4


def _steps(seed, n):
    rng = np.random.default_rng(seed)
    return [(rng.normal(size=P_DIM) * rng.uniform(0.5, 2.0), float(rng.normal() * 3.0)) for _ in range(n)]


@pytest.mark.parametrize("seed", range(3))
def test_drift_mean_follows_equation_26_each_step(seed):
    """q̂(k+1) = (1 − d_k) q̂(k) + d_k (θ̂(k+1|k+1) − θ̂(k|k)), d_k = (1 − λ)/(1 − λ^(k+1))."""
    lam = 0.95
    f = SageHusa(1, P_DIM, lam=lam, P0=2.0, R0=0.3, adapt=("q",))
    for k, (h, y) in enumerate(_steps(seed, 40)):
        theta_before, q_before = f.theta[:, 0].copy(), f.q_hat[:, 0].copy()
        eps = f.update(0, h, y)
        assert abs(eps) > 1e-3  # ε² ≠ 1 matters for q̂ only through ε: keep it informative
        d = (1.0 - lam) / (1.0 - lam ** (k + 1))
        expected = (1.0 - d) * q_before + d * (f.theta[:, 0] - theta_before)
        np.testing.assert_allclose(f.q_hat[:, 0], expected, rtol=1e-9, atol=1e-12)


def test_drift_mean_run_matches_the_printed_equations():
    """With R̂ and Q̂ fixed, q̂ on: the same θ̂ and q̂ as (18)-(26) written out in numpy."""
    ours = SageHusa(1, P_DIM, lam=0.97, P0=1.5, R0=0.2, Q0=1e-3, adapt=("q",))
    ref = PrintedSageHusa(P_DIM, lam=0.97, theta0=np.zeros(P_DIM), P0=np.full(P_DIM, 1.5), r0=0.0, R0=0.2,
                          Q0=np.full(P_DIM, 1e-3), adapt=("q",))
    for h, y in _steps(7, 60):
        assert ours.update(0, h, y) == pytest.approx(ref.update(h, y), rel=1e-8, abs=1e-10)
    np.testing.assert_allclose(ours.q_hat[:, 0], ref.q, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(ours.theta[:, 0], ref.theta, rtol=1e-7, atol=1e-10)


@pytest.mark.parametrize(("name", "high"), [("na", 16), ("nb", 16), ("d", 64)])
def test_arx_order_bounds_are_the_documented_ones(name, high):
    """na, nb 1…16 and d 1…64 (docs/arma_kalman.md): the largest is taken, one more is refused."""
    assert getattr(ArxOrder(**{name: high}), name) == high
    with pytest.raises(ValueError, match=name):
        ArxOrder(**{name: high + 1})


def test_arx_order_cannot_be_changed_after_its_checks():
    """The bounds are checked at construction (and ``ArxOrder()`` is a shared default argument):
    an order that could be reassigned would skip them."""
    order = ArxOrder()
    with pytest.raises(dataclasses.FrozenInstanceError):
        order.na = 100_000
    assert hash(order) == hash(ArxOrder())  # a value: usable as a key


def _recording(path, rows=120):
    rng = np.random.default_rng(3)
    rec = Recorder(path, {"t": ((), "f8"), "q": (1, "f8"), "tau": (1, "f8")}, {"rate_hz": 100, "joints": ["a"]},
                   wait_when_full=True)
    for k in range(rows):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / 100, rng.normal(), rng.normal()
        rec.commit()
    rec.close()
    return str(path)


@pytest.mark.parametrize(("option", "high"), [("--na", 16), ("--nb", 16), ("--d", 64)])
def test_identify_command_takes_the_largest_documented_order_and_refuses_one_more(tmp_path, capsys, option, high):
    path = _recording(tmp_path / "run.msgpack")
    assert main(["identify", path, option, str(high)]) == 0
    capsys.readouterr()
    assert main(["identify", path, option, str(high + 1)]) == 2
    err = capsys.readouterr().err
    assert option in err and f"from 1 to {high}" in err, err


@pytest.mark.parametrize("bad", ["theta", "P", "r_hat", "R_hat", "q_hat", "Q_hat"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_first_nonfinite_names_the_quantity_that_went_bad(bad, value):
    """One quantity of channel 1 made non-finite at a time: that one is named (the ARMA/GMV
    controller's fault message reads it), and channel 0 is still clean."""
    f = SageHusa(2, 3, P0=1.0, R0=0.1, Q0=1e-4)
    where = {"theta": (f.theta, (2, 1)), "P": (f.P, (1, 2, 0)), "r_hat": (f.signals, (R_HAT, 1)),
             "R_hat": (f.signals, (RCOV_HAT, 1)), "q_hat": (f.q_hat, (1, 1)), "Q_hat": (f.Q_hat, (0, 1))}
    array, index = where[bad]
    array[index] = value
    names = {"theta": "coefficient estimate θ̂", "P": "covariance P", "r_hat": "noise mean r̂",
             "R_hat": "noise variance R̂", "q_hat": "drift mean q̂", "Q_hat": "drift covariance Q̂"}
    got = first_nonfinite(1, f.theta, f.P, f.q_hat, f.Q_hat, f.signals)
    assert got >= 0 and QUANTITIES[got] == names[bad]
    assert first_nonfinite(0, f.theta, f.P, f.q_hat, f.Q_hat, f.signals) == -1


def test_identify_reports_the_rms_prediction_error_per_channel():
    """eps_rms[j] = √(Σ_k ε_j(k)² / (N − 1)) for each channel j, summed by hand."""
    rng = np.random.default_rng(11)
    N, m = 300, 3
    u = rng.normal(size=(N, m))
    y = np.column_stack([simulate(ArxOrder(), [1.2, -0.5, 0.8, 0.3, 0.1], u[:, j], (j + 1) * 0.05 * rng.normal(size=N))
                         for j in range(m)])
    got = identify(y, u)
    assert got["eps"].shape == (N - 1, m)
    by_hand = [math.sqrt(sum(float(e) ** 2 for e in got["eps"][:, j]) / (N - 1)) for j in range(m)]
    assert got["eps_rms"].shape == (m,)
    np.testing.assert_allclose(got["eps_rms"], by_hand, rtol=1e-12)
