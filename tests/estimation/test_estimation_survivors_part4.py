"""Tests for the estimation mutants that survived the full mutation run with the earlier
survivor tests (27 of 704; docs/mutation/estimation.md says which are caught here and why the rest are
equivalent). Each test names what it kills and checks a value worked out by hand: a history
shift of three samples, the regressor of three lags, identify's ε and y − hᵀθ̂(k|k−1) for its
first two steps, the residual form (27′) on a step whose sample is exactly 0 (exact fractions),
the documented "no subnormals" of λᵏ, and K = 0 in (26), (27) when s = 0.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from rtctl.estimation import ArxOrder, SageHusa, identify, push_history, regressor_into
from rtctl.estimation.sage_husa import RCOV_HAT


def test_push_history_shifts_every_slot_of_a_three_sample_history():
    """(Mutant: the y loop stepping by −2). Newest first (arx module docstring): y_hist = [y(k−1),
    y(k−2), y(k−3)] = [1, 2, 3] and a push of y(k) = 9 gives [9, 1, 2]; the same for u with
    d + nb = 3. The other channel is untouched."""
    y_hist = np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    u_hist = np.array([[4.0, 40.0], [5.0, 50.0], [6.0, 60.0]])
    push_history(0, y_hist, u_hist, 9.0, 7.0)
    assert y_hist[:, 0].tolist() == [9.0, 1.0, 2.0]
    assert u_hist[:, 0].tolist() == [7.0, 4.0, 5.0]
    assert y_hist[:, 1].tolist() == [10.0, 20.0, 30.0] and u_hist[:, 1].tolist() == [40.0, 50.0, 60.0]
    push_history(0, y_hist, u_hist, 8.0, 6.0)
    assert y_hist[:, 0].tolist() == [8.0, 9.0, 1.0] and u_hist[:, 0].tolist() == [6.0, 7.0, 4.0]


def test_regressor_of_three_lags_after_four_samples():
    """The y loop stepping by −2, as identify uses it: ARX(3, 1, 1), histories started as identify starts them (y(0)
    repeated, u = 0), then y(0…3), u(0…3) pushed: eq. (15) gives h(4) = [y(3), y(2), y(1), u(3),
    u(2)] (d = 1)."""
    order = ArxOrder(3, 1, 1)
    y = [0.5, 1.0, 2.0, 3.0]
    u = [10.0, 20.0, 30.0, 40.0]
    y_hist = np.full((order.na, 1), y[0])
    u_hist = np.zeros((order.memory, 1))
    h = np.zeros(order.p)
    for k in range(4):
        push_history(0, y_hist, u_hist, y[k], u[k])
    regressor_into(0, y_hist, u_hist, order.d, h)
    # h(4) = [y(3), y(2), y(1), u(3), u(2)]
    assert h.tolist() == [3.0, 2.0, 1.0, 40.0, 30.0]


def test_identify_returns_each_steps_innovation_in_its_own_row():
    """(Mutant: ε or y − hᵀθ̂(k|k−1) written one row early: the first step's value lands in the
    last row, a rotation that leaves eps_rms unchanged). ARX(1, 1, 1), y = [0, 1, 0.5],
    u = [1, 0, 0]; defaults θ̂(0) = 0, r̂(0) = 0, r̂ adapted with d_0 = 1.
    Step 1: h(1) = [y(0), u(0), u(−1)] = [0, 1, 0]; pred = y(1) − 0 = 1 = ε(1) (r̂ = 0);
    θ̂(1) = K ε with K ∝ P h = [0, ·, 0]; r̂(1) = (1 − 1)·0 + 1·pred = 1.
    Step 2: h(2) = [y(1), u(1), u(0)] = [1, 0, 1] ⟂ θ̂(1): pred = y(2) = 0.5, ε(2) = 0.5 − r̂(1) = −0.5."""
    got = identify([0.0, 1.0, 0.5], [1.0, 0.0, 0.0], ArxOrder(1, 1, 1))
    assert got["eps"].tolist() == [[1.0], [-0.5]]
    assert got["prediction_error"].tolist() == [[1.0], [0.5]]


def test_residual_drift_covariance_keeps_a_sample_of_exactly_zero():
    """(Mutant: `sample <= 0` instead of `< 0`). (27′): an entry of K ε² Kᵀ + P(k+1|k+1) − P(k|k) that
    is negative is taken from K ε² Kᵀ alone; one that is 0 is not negative and stays 0.
    p = 1, h = 1, P(0) = 3, Q̂(0) = 0, R̂ = 1, y = 2 (θ̂ = 0, r̂ = 0): S = 4, K = 3/4, ε = 2,
    P(1|1) = P R / (P + R) = 3/4, so the sample is 9/16·4 + 3/4 − 3 = 0 and with d_0 = 1 Q̂(1) = 0
    (the biased sample would be K²ε² = 9/4). All of it dyadic: exact in floating point too."""
    P, R, eps = Fraction(3), Fraction(1), Fraction(2)
    K = P / (P + R)
    sample = K * K * eps * eps + P * R / (P + R) - P
    assert sample == 0 and K * K * eps * eps == Fraction(9, 4)
    f = SageHusa(1, 1, P0=3.0, R0=1.0, Q0=0.0, Q_min=0.0, adapt=("Q",), noise_form="residual")
    assert f.update(0, [1.0], 2.0) == 2.0
    assert f.P[0, 0, 0] == 0.75
    assert f.Q_hat[0, 0] == float(sample)


def test_the_fading_factor_never_holds_a_subnormal_number():
    """(Mutant: the flush of λ^(k+1) to 0 disabled). sage_husa_step keeps ``fade`` = λᵏ "no
    subnormals" (arithmetic on a subnormal operand is slow on x86: a microcode assist): with λ = 0.01, λᵏ
    passes below the smallest normal double (2.2·10⁻³⁰⁸) after ~154 steps and must be 0 from there
    on, never in between. d_k = (1 − λ)/(1 − λ^(k+1)) is 1 − λ either way."""
    tiny = np.finfo(float).tiny
    f = SageHusa(1, 1, lam=0.01, adapt=("r",))
    seen = []
    for k in range(200):
        f.update(0, [0.0], 1.0)
        value = float(f.fade[0])
        seen.append(value)
        assert value == 0.0 or value >= tiny, (k, value)
    assert seen[-1] == 0.0 and seen[0] == pytest.approx(0.01)


@pytest.mark.parametrize("R_hat", [np.nan, 0.0])
def test_without_variance_along_h_drift_estimates_stay_whatever_R_hat_is(R_hat):
    """(Mutant: S = min(R_gain, R_min), or the floor's test negated, in the branch s ≤ 0). There
    "y carries no news about θ" and K = 0 for (26), (27) (sage_husa_step): q̂ = (1 − d)q̂ + d(q̂ + 0)
    = q̂ and Q̂ = (1 − d)Q̂ + d(0 + P(k+1|k) − P(k|k)) = Q̂ (P(k+1|k) = P + Q̂, P then untouched).
    S divides Ph = 0 there and only its floor R_min > 0 keeps 0/S = 0; the floor engages when R̂
    has left its domain — a diverged R̂ (NaN) or one below R_min (0, written by hand): then the
    gain's R is R_REL·s = 0 and S without the floor would be 0 (0/0 = NaN in q̂ and Q̂).
    h = 0, q̂(0) = 0.5, Q̂(0) = 0.25, d_0 = 1."""
    f = SageHusa(1, 2, P0=1.0, q0=0.5, Q0=0.25, adapt=("q", "Q"))
    f.signals[RCOV_HAT, 0] = R_hat
    f.update(0, [0.0, 0.0], 1.0)
    assert f.q_hat[:, 0].tolist() == [0.5, 0.5]
    assert f.Q_hat[:, 0].tolist() == [0.25, 0.25]
    assert f.theta[:, 0].tolist() == [0.5, 0.5]  # θ̂(1|0) = θ̂(0) + q̂, and K = 0
