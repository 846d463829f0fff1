"""With every adaptation off (fixed R, Q; r = q = 0) the Sage–Husa filter is a plain Kalman
filter on the random-walk coefficient model θ(k+1) = θ(k) + V, y = hᵀθ + W: θ̂ and P must equal
filterpy's KalmanFilter (F = I, H = hᵀ each step, Joseph-form update) on random data."""
import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from rtctl.estimation import SageHusa


@pytest.mark.parametrize("seed", range(4))
def test_equals_filterpy_kalman_filter(seed):
    rng = np.random.default_rng(seed)
    p, steps = int(rng.integers(2, 7)), 300
    theta0 = rng.normal(size=p)
    P0 = rng.uniform(0.1, 10.0, p)
    Q = rng.uniform(0.0, 1e-2, p)
    R = float(rng.uniform(0.01, 1.0))
    ours = SageHusa(1, p, lam=0.97, theta0=theta0, P0=P0, R0=R, Q0=Q, adapt=())
    kf = KalmanFilter(dim_x=p, dim_z=1)
    kf.x = theta0.reshape(p, 1).copy()
    kf.P = np.diag(P0)
    kf.Q = np.diag(Q)
    kf.R = np.array([[R]])
    kf.F = np.eye(p)
    for _ in range(steps):
        h = rng.normal(size=p) * rng.uniform(0.1, 3.0)
        y = float(rng.normal() * 2.0)
        kf.predict()
        kf.update(y, H=h.reshape(1, p))
        ours.update(0, h, y)
    np.testing.assert_allclose(ours.theta[:, 0], kf.x[:, 0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(ours.P[0], kf.P, rtol=0, atol=1e-10)
    assert np.abs(kf.P).max() > 1e-6  # not a trivially converged comparison
