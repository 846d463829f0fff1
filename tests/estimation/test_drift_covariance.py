"""The drift covariance Q̂ of the Sage–Husa filter, eq. (27), against the equations written out
in matrix form (docs/arma_kalman.md): (19)-(25) as listed there, the Joseph form of (23), and
Q̂(k+1) = (1 − d_k) Q̂(k) + d_k (K ε² Kᵀ + P(k+1|k+1) − P(k|k)), its diagonal kept, floored at
Q_min — with the safeguards the module documents (R̂ floored, the gain's R at least 10⁻⁹ hᵀPh,
(25) from ε² alone when ε² − hᵀPh < 0). The reference is plain numpy, one step per sample."""
import numpy as np
import pytest

from rtctl.estimation import SageHusa


class Reference:
    def __init__(self, p, lam, theta0, P0, R0, Q0, R_min, Q_min):
        self.lam, self.R_min, self.Q_min = lam, R_min, Q_min
        self.theta, self.P = theta0.copy(), np.diag(P0)
        self.r, self.R, self.Q = 0.0, max(R0, R_min), np.asarray(Q0, float).copy()
        self.k = 0

    def step(self, h, y):
        d = (1 - self.lam) / (1 - self.lam ** (self.k + 1))
        self.k += 1
        P_prev = self.P.copy()  # P(k|k)
        P_pred = self.P + np.diag(self.Q)  # (22); θ̂(k+1|k) = θ̂(k|k) with q̂ = 0 (19)
        s = h @ P_pred @ h
        pred = y - h @ self.theta
        eps = pred - self.r  # (20)
        R_gain = max(self.R, 1e-9 * s)
        K = P_pred @ h / (s + R_gain)  # (21)
        self.theta = self.theta + K * eps  # (18)
        I_Kh = np.eye(len(h)) - np.outer(K, h)
        self.P = I_Kh @ P_pred @ I_Kh.T + R_gain * np.outer(K, K)  # (23), Joseph form
        self.r = (1 - d) * self.r + d * pred  # (24)
        innov = eps ** 2 - s if eps ** 2 - s >= 0 else eps ** 2
        self.R = max((1 - d) * self.R + d * innov, self.R_min)  # (25)
        Q_full = (1 - d) * np.diag(self.Q) + d * (np.outer(K, K) * eps ** 2 + self.P - P_prev)  # (27)
        self.Q = np.maximum(np.diag(Q_full), self.Q_min)


@pytest.mark.parametrize("seed", range(3))
def test_the_drift_covariance_follows_eq_27(seed):
    rng = np.random.default_rng(seed)
    p, lam, steps = 3, 0.98, 400
    theta0, P0, Q0 = rng.normal(size=p), rng.uniform(0.5, 5.0, p), rng.uniform(1e-4, 1e-3, p)
    kw = dict(lam=lam, theta0=theta0, P0=P0, R0=0.1, Q0=Q0, R_min=1e-12, Q_min=1e-8)
    ours = SageHusa(1, p, adapt=("r", "R", "Q"), **kw)
    ref = Reference(p, **kw)
    theta = rng.normal(size=p)
    for _ in range(steps):
        theta += rng.normal(scale=0.01, size=p)  # coefficients that drift: Q̂ has something to find
        h = rng.normal(size=p)
        y = float(h @ theta + 0.3 + 0.1 * rng.normal())
        ours.update(0, h, y)
        ref.step(h, y)
    np.testing.assert_allclose(ours.Q_hat[:, 0], ref.Q, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(ours.theta[:, 0], ref.theta, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(ours.P[0], ref.P, rtol=1e-7, atol=1e-12)
    assert np.all(ref.Q > 10 * kw["Q_min"])  # a real estimate, not the floor
