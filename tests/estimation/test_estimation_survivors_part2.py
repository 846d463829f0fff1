"""Tests for the estimation mutants that survived the suite (mutation run estimation-s30).

Each checks a documented expectation, computed by hand: the printed equation (27) on one
scalar step; the bound 0 < λ < 1 of the printed reference; the coefficient names θ = [a_1 …
a_na, b_0 … b_nb] (arx module docstring, ``rtctl identify --help``); the gain's R ≥ 10⁻⁹ hᵀPh
(sage_husa module docstring); the filter's options are keywords; ``rtctl identify --joints``
names the first unknown joint and exits 2.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from rtctl.cli import main
from rtctl.estimation import ArxOrder, SageHusa
from rtctl.estimation.printed import PrintedSageHusa
from rtctl.telemetry import Recorder


def test_printed_drift_covariance_is_equation_27_on_a_hand_computed_step():
    """p = 1, h = 2, y = 3, θ̂(0) = 0, P(0) = 1, Q̂(0) = 1/2, r̂ = 0, R̂ = 1, only Q̂ adapted; by hand:
    d_0 = 1; P(1|0) = 3/2; ε = 3; s = hPh = 6; K = (3/2)·2/(6 + 1) = 3/7; P(1|1) = (1 − 2K)·3/2 = 3/14;
    (27): Q̂(1) = 0·Q̂(0) + 1·(K²ε² + P(1|1) − P(0|0)) = 81/49 + 3/14 − 1 = 85/98.
    Step 2, h = 1, y = 0: d_1 = (1 − λ)/(1 − λ²) = 1/(1 + λ) with λ = 1/2: 2/3."""
    f = PrintedSageHusa(1, lam=0.5, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.5], adapt=("Q",))
    assert f.update([2.0], 3.0) == pytest.approx(3.0)
    np.testing.assert_allclose(f.theta, [9 / 7], rtol=1e-12)
    np.testing.assert_allclose(f.P, [[3 / 14]], rtol=1e-12)
    np.testing.assert_allclose(f.Q, [[85 / 98]], rtol=1e-12)
    # step 2, in exact fractions from the equations (19)-(23), (27)
    theta, P, Q, R = Fraction(9, 7), Fraction(3, 14), Fraction(85, 98), Fraction(1)
    h, y, d = Fraction(1), Fraction(0), Fraction(2, 3)
    P_pred = P + Q  # (22)
    eps = y - h * theta  # (20), r̂ = 0, q̂ = 0
    K = P_pred * h / (h * P_pred * h + R)  # (21)
    P_new = (1 - K * h) * P_pred  # (23)
    Q_new = (1 - d) * Q + d * (K * K * eps * eps + P_new - P)  # (27)
    assert f.update([1.0], 0.0) == pytest.approx(float(eps), rel=1e-12)
    np.testing.assert_allclose(f.Q, [[float(Q_new)]], rtol=1e-12)


@pytest.mark.parametrize("lam", [0.0, 1.0, 1.5, -0.5])
def test_printed_reference_refuses_a_forgetting_factor_outside_0_1(lam):
    """0 < λ < 1 (the module docstring of sage_husa, which the printed reference follows)."""
    with pytest.raises(ValueError, match="lam"):
        PrintedSageHusa(1, lam=lam, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.0])


def test_printed_reference_takes_a_forgetting_factor_just_inside_0_1():
    for lam in (1e-9, 1.0 - 1e-9):
        assert PrintedSageHusa(1, lam=lam, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.0]).lam == lam


@pytest.mark.parametrize(("na", "nb"), [(1, 1), (2, 2), (3, 1), (1, 4)])
def test_arx_coefficient_names_are_a1_to_a_na_then_b0_to_b_nb(na, nb):
    """θ = [a_1 … a_na, b_0 … b_nb] (eq. 14): one name per coefficient, in that order."""
    order = ArxOrder(na, nb, 1)
    expected = [f"a{j}" for j in range(1, na + 1)] + [f"b{j}" for j in range(0, nb + 1)]
    assert order.names() == expected
    assert len(order.names()) == order.p


def test_gain_never_trusts_y_more_than_1e9_times_the_prediction():
    """The gain uses max(R̂, 10⁻⁹ hᵀPh): with R̂ at a floor of 10⁻¹² ≪ 10⁻⁹·s, one step with
    h = 1, P = 1 (s = 1) leaves P(1|1) = s R_gain/(s + R_gain) = 10⁻⁹/(1 + 10⁻⁹) (module
    docstring), not ≈ 10⁻¹²; θ̂ moves by the fraction s/(s + R_gain) of ε."""
    f = SageHusa(1, 1, lam=0.9, P0=1.0, R0=1e-12, R_min=1e-12, adapt=())
    f.update(0, [1.0], 1.0)
    R_gain = 1e-9 * 1.0
    np.testing.assert_allclose(f.P[0, 0, 0], R_gain / (1.0 + R_gain), rtol=1e-5)
    np.testing.assert_allclose(f.theta[0, 0], 1.0 / (1.0 + R_gain), rtol=1e-12)


def test_filter_options_are_keywords():
    """SageHusa(m, p, *, lam=…, …): m and p by position or by name, every option by name only
    (a positional 0.5 must not silently become λ)."""
    f = SageHusa(m=2, p=3, lam=0.9)
    assert (f.m, f.p, f.lam) == (2, 3, 0.9)
    with pytest.raises(TypeError):
        SageHusa(2, 3, 0.9)


def _recording(path, rows=40):
    rng = np.random.default_rng(4)
    rec = Recorder(path, {"t": ((), "f8"), "q": (2, "f8"), "tau": (2, "f8")}, {"rate_hz": 100, "joints": ["a", "b"]},
                   wait_when_full=True)
    for k in range(rows):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / 100, rng.normal(size=2), rng.normal(size=2)
        rec.commit()
    rec.close()
    return str(path)


@pytest.mark.parametrize(("joints", "named"), [(["zz"], "zz"), (["a,yy", "zz"], "yy"), (["xx", "b", "ww"], "xx")])
def test_identify_names_the_first_unknown_joint_and_exits_2(tmp_path, capsys, joints, named):
    path = _recording(tmp_path / "run.msgpack")
    assert main(["identify", path, "--joints", *joints]) == 2
    err = capsys.readouterr().err
    assert f"unknown joint {named!r}" in err and "a, b" in err, err
