"""Identification by the adaptive filter on a known ARX(2, 2, 1) plant, and how the forgetting
factor λ sets the time it takes to follow a change.

Tolerances (derived, not tuned): the coefficient errors are compared with the standard errors of
the least-squares fit *with an intercept* on the same data, σ_θ = √diag(R (H̃ᵀH̃)⁻¹), H̃ = [h(k)ᵀ 1]
(the filter estimates the noise mean too, so that is the reference it can at best match); r̂ is an
exponentially weighted mean of the prediction errors with weight 1 − λ, whose standard deviation
is √(R (1 − λ)/(1 + λ)); R̂ averages ε² (variance 2R²) with the same weights. Each within 4 σ."""
import numpy as np
import pytest

from rtctl.estimation import ArxOrder, SageHusa, identify, simulate

ORDER = ArxOrder(2, 2, 1)
THETA = np.array([1.5, -0.7, 1.0, 0.5, 0.2])  # poles 0.75 ± 0.37j: a stable, oscillating plant
R_MEAN, R_VAR = 0.5, 0.01  # noise of non-zero mean


def _plant_data(seed, N=5000):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=N)
    y = simulate(ORDER, THETA, u, R_MEAN + np.sqrt(R_VAR) * rng.normal(size=N))
    return y, u


def _ls_sigma(y, u):
    N = len(y)
    H = np.column_stack([y[2:-1], y[1:-2], u[2:-1], u[1:-2], u[:-3], np.ones(N - 3)])
    return np.sqrt(np.diag(R_VAR * np.linalg.inv(H.T @ H)))


@pytest.mark.parametrize("seed, lam", [(0, 0.99), (1, 0.995), (2, 0.98)])
def test_converges_to_the_plant_and_the_noise_mean(seed, lam):
    y, u = _plant_data(seed)
    res = identify(y, u, ORDER, lam=lam, P0=100.0, R0=1.0)  # from θ̂ = 0, r̂ = 0, R̂ 100× too large
    sigma = _ls_sigma(y, u)
    theta_err = res["theta"][0] - THETA
    assert np.all(np.abs(theta_err) < 4 * sigma[:5]), theta_err / sigma[:5]
    r_sigma = np.hypot(np.sqrt(R_VAR * (1 - lam) / (1 + lam)), sigma[5])
    assert abs(res["r_hat"][0] - R_MEAN) < 4 * r_sigma, (res["r_hat"][0], r_sigma)
    R_sigma = R_VAR * np.sqrt(2 * (1 - lam) / (1 + lam))
    assert abs(res["R_hat"][0] - R_VAR) < 4 * R_sigma, (res["R_hat"][0], R_sigma)


def _at_rest_filter(lam, h, theta):
    """Converged on a plant at rest: exact θ̂, P = 0, r̂ = 0 (a noise-free history of N0 steps)."""
    f = SageHusa(1, len(theta), lam=lam, theta0=theta, P0=0.0, R0=1e-6, adapt=("r",))
    for _ in range(400):
        f.update(0, h, float(h @ theta))
    return f


@pytest.mark.parametrize("lam", [0.95, 0.98, 0.995])
def test_noise_mean_absorbs_a_coefficient_step_at_the_rate_lambda_predicts(lam):
    """At rest (the hold after a move) h is constant, so a step Δ in one coefficient is a constant
    prediction error Δ·h_j, which r̂ absorbs (it is what the paper's virtual noise is for): after N
    more samples the innovation is Π(1 − d_k) ≈ λ^N of the jump, within 5 % after
    N = ⌈ln 0.05 / ln λ⌉ samples (59, 149, 598) and not much sooner."""
    h = np.array([0.8, 0.8, 3.0, 3.0, 3.0])  # y(k−1) = y(k−2) = 0.8 rad, u = 3 N·m held
    f = _at_rest_filter(lam, h, THETA)
    stepped = THETA.copy()
    stepped[2] += 0.2  # b0 steps
    jump = 0.2 * h[2]
    N = int(np.ceil(np.log(0.05) / np.log(lam)))
    eps = np.array([f.update(0, h, float(h @ stepped)) for _ in range(N + 1)])  # eps[j]: after j samples
    assert eps[0] == pytest.approx(jump, rel=1e-9)
    assert abs(eps[N]) <= 0.05 * jump < abs(eps[N // 2])
    k = 400 + np.arange(N + 1)
    d = (1 - lam) / (1 - lam ** (k + 1))
    predicted = jump * np.concatenate([[1.0], np.cumprod(1 - d)[:-1]])
    np.testing.assert_allclose(eps, predicted, rtol=1e-6)


@pytest.mark.parametrize("lam", [0.9, 0.95])
def test_covariance_forgetting_tracks_a_coefficient_step_within_the_lambda_horizon(lam):
    """With ``forget_covariance`` (RLS forgetting, P(k+1|k) = P/λ) and an exciting input the
    coefficient itself follows: for a noise-free plant θ̃(k+N) = λ^N P(k+N) P(k)⁻¹ θ̃(k), and P
    is stationary under stationary excitation, so the error falls to ≈ λ^N of the step — within
    10 % after N = ⌈ln 0.05 / ln λ⌉ samples (5 % up to the fluctuation of P), not before N/3."""
    rng = np.random.default_rng(3)
    N = int(np.ceil(np.log(0.05) / np.log(lam)))
    K0 = 600
    theta = np.tile(THETA, (K0 + N, 1))
    theta[K0:, 2] += 0.3
    u = rng.normal(size=K0 + N)
    y = simulate(ORDER, theta, u, np.zeros(K0 + N))
    f = SageHusa(1, 5, lam=lam, theta0=0.0, P0=100.0, R0=1e-4, adapt=(), forget_covariance=True)
    track = []
    for k in range(1, K0 + N):
        h = np.array([y[k - 1], y[k - 2] if k >= 2 else 0.0, u[k - 1], u[k - 2] if k >= 2 else 0.0,
                      u[k - 3] if k >= 3 else 0.0])
        f.update(0, h, y[k])
        track.append(f.theta[2, 0])
    err = np.abs(np.array(track[K0 - 1:]) - THETA[2] - 0.3) / 0.3
    assert abs(track[K0 - 2] - THETA[2]) < 1e-6  # converged before the step
    assert err[-1] < 0.10, err[-1]
    assert err[N // 3] > 0.10, err[N // 3]
