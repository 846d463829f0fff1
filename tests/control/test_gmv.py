"""The GMV law against the polynomial (Clarke–Gawthrop) form computed independently with numpy,
and the closed-loop poles of a known ARX plant against the roots of B + (ρ/b₀)(1 − z⁻¹)A."""
import numpy as np
import pytest
from numpy.polynomial import polynomial as npp

from rtctl.control.gmv import gmv_control
from rtctl.estimation import ArxOrder


def clarke_gawthrop_u(theta, r_hat, y, y_hist, u_hist, order, y_star, rho):
    """u(k) from 1 = A E + z⁻ᵈ F, G = E B, ŷ(k+d|k) = F y(k) + G u(k) + E(1) r̂ and
    ρ (u(k) − u(k−1)) = b₀ (y* − ŷ(k+d|k)), all in polynomials of z⁻¹ (ascending coefficients)."""
    na, d = order.na, order.d
    A = np.concatenate([[1.0], -np.asarray(theta[:na])])
    B = np.asarray(theta[na:])
    toeplitz = np.array([[A[i - j] if 0 <= i - j < len(A) else 0.0 for j in range(d)] for i in range(d)])
    E = np.linalg.solve(toeplitz, np.eye(d)[0])  # A E ≡ 1 (mod z⁻ᵈ)
    rest = npp.polysub([1.0], npp.polymul(A, E))
    assert np.allclose(rest[:d], 0.0)
    F = rest[d:]
    G = npp.polymul(E, B)
    ys = np.concatenate([[y], y_hist])  # y(k), y(k−1), …
    phi = sum(F[i] * ys[i] for i in range(len(F))) + sum(G[i] * u_hist[i - 1] for i in range(1, len(G))) \
        + E.sum() * r_hat
    g0 = G[0]
    return (g0 * (y_star - phi) + rho * u_hist[0]) / (g0 * g0 + rho)


@pytest.mark.parametrize("d", [1, 2, 3])
@pytest.mark.parametrize("seed", range(5))
def test_u_equals_the_polynomial_form(d, seed):
    rng = np.random.default_rng(seed)
    order = ArxOrder(int(rng.integers(1, 4)), int(rng.integers(1, 4)), d)
    theta = rng.normal(size=order.p)
    y_hist, u_hist = rng.normal(size=order.na), rng.normal(size=order.memory)
    y, r_hat, y_star, rho = rng.normal(), rng.normal(), rng.normal(), rng.uniform(0.01, 2.0)
    ours = gmv_control(theta, r_hat, y, y_hist, u_hist, order, y_star, rho)
    reference = clarke_gawthrop_u(theta, r_hat, y, y_hist, u_hist, order, y_star, rho)
    assert ours == pytest.approx(reference, rel=1e-10, abs=1e-12)


def test_saturation_clamps_and_rejects_bad_arguments():
    order = ArxOrder(2, 2, 1)
    theta = np.array([2.0, -1.0, 1e-4, 1e-4, 0.0])
    assert gmv_control(theta, 0.0, 0.0, [0, 0], [0, 0, 0], order, 1.0, 1e-9, u_max=50.0) == 50.0
    assert gmv_control(theta, 0.0, 0.0, [0, 0], [0, 0, 0], order, -1.0, 1e-9, u_max=50.0) == -50.0
    with pytest.raises(ValueError):
        gmv_control(theta[:4], 0.0, 0.0, [0, 0], [0, 0, 0], order, 1.0, 1e-9)
    with pytest.raises(ValueError):
        gmv_control(theta, 0.0, 0.0, [0, 0], [0, 0, 0], order, 1.0, 0.0)


@pytest.mark.parametrize("d", [1, 2])
@pytest.mark.parametrize("sigma", [0.05, 0.3])
def test_closed_loop_poles_are_the_roots_of_b_plus_rho_a(d, sigma):
    """Plant: a sampled double integrator with B = b₀ (1 + 0.5 z⁻¹), known exactly; the law with
    the true θ and y* = 0 from random initial conditions. The output obeys the closed-loop
    recursion C(z⁻¹) y = 0; fitting C by least squares from the simulated y gives its roots."""
    order = ArxOrder(2, 1, d)
    b0 = 2e-4
    theta = np.array([2.0, -1.0, b0, 0.5 * b0])
    rho = sigma * b0 ** 2
    A = np.array([1.0, -2.0, 1.0])
    C = npp.polyadd(theta[2:], (rho / b0) * npp.polymul([1.0, -1.0], A))  # B + (ρ/b₀)(1 − z⁻¹) A
    expected = np.sort_complex(np.roots(C))  # roots in z of zᵈᵉᵍ C(z⁻¹)
    assert np.abs(expected).max() < 1.0  # a stable case
    rng = np.random.default_rng(d)
    y_hist, u_hist = list(rng.normal(size=2)), list(rng.normal(size=order.memory) * 1e3)
    ys = []
    for _ in range(12 + order.memory):
        y = 2.0 * y_hist[0] - y_hist[1] + b0 * u_hist[d - 1] + 0.5 * b0 * u_hist[d]
        u = gmv_control(theta, 0.0, y, y_hist, u_hist, order, 0.0, rho)
        y_hist, u_hist = [y] + y_hist[:-1], [u] + u_hist[:-1]
        ys.append(y)
    ys = np.array(ys[order.memory:])  # past the start-up, where the initial u are not the law's
    k = len(C) - 1
    X = np.column_stack([ys[k - j:len(ys) - j] for j in range(1, k + 1)])
    coeffs, *_ = np.linalg.lstsq(X, -ys[k:] * C[0], rcond=None)
    fitted = np.sort_complex(np.roots(np.concatenate([[C[0]], coeffs])))
    np.testing.assert_allclose(fitted, expected, atol=1e-6)
