"""The safeguards under attack (hypothesis): innovations repeatedly smaller than hᵀPh (R̂'s
update would go negative), outliers, and a constant input that excites nothing, with every
adaptation switched on (r̂, R̂, q̂, Q̂), with covariance forgetting, in both noise forms. R̂ stays ≥ its floor > 0,
Q̂ ≥ 0 and diagonal by construction, P symmetric and positive semidefinite, everything finite."""
import numpy as np
from hypothesis import given, settings, strategies as st

from rtctl.estimation import SageHusa

P_DIM = 5


def _check(f):
    assert np.all(np.isfinite(f.theta)) and np.all(np.isfinite(f.P)) and np.all(np.isfinite(f.signals))
    assert np.all(np.isfinite(f.q_hat)) and np.all(np.isfinite(f.Q_hat))
    assert f.R_hat[0] >= f.R_min > 0
    assert np.all(f.Q_hat >= 0)
    P = f.P[0]
    assert np.array_equal(P, P.T)
    assert np.linalg.eigvalsh(P).min() >= -1e-9 * max(1.0, np.abs(P).max())


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), attack=st.sampled_from(["tiny_innovations", "outliers", "constant_input"]),
       forget=st.booleans(), lam=st.floats(0.9, 0.999), scale=st.floats(1e-6, 1e3),
       noise_form=st.sampled_from(["sage_husa", "residual"]))
def test_estimates_stay_sane_under_attack(seed, attack, forget, lam, scale, noise_form):
    rng = np.random.default_rng(seed)
    f = SageHusa(1, P_DIM, lam=lam, theta0=rng.normal(size=P_DIM), P0=rng.uniform(0, 10, P_DIM), R0=1e-3,
                 Q0=rng.uniform(0, 1e-3, P_DIM), adapt=("r", "R", "q", "Q"), forget_covariance=forget,
                 noise_form=noise_form)
    h_const = rng.normal(size=P_DIM) * scale
    for k in range(250):
        h = h_const if attack == "constant_input" else rng.normal(size=P_DIM) * scale
        prior = float(h @ (f.theta[:, 0] + f.q_hat[:, 0])) + f.r_hat[0]
        if attack == "tiny_innovations":  # ε ≈ 0 while hᵀPh > 0: ε² − hᵀPh < 0 every step
            y = prior + 1e-9 * rng.normal()
        elif attack == "outliers":
            y = prior + rng.normal() * (1e6 if rng.random() < 0.1 else 1e-2) * scale
        else:
            y = prior + 1e-3 * rng.normal()
        f.update(0, h, y)
        _check(f)
