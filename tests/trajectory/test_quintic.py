"""Quintic segments against independent references: a direct 6×6 solve, the published
min-jerk peaks (15/8 Δ/T, 10/√3 Δ/T²) and dense sampling."""
import numpy as np
import pytest

from rtctl.trajectory.quintic import (_FINE, PEAK_ACCELERATION, PEAK_VELOCITY, braking_target, coefficients,
                                      extrema, rest_to_rest_duration, shortest_duration)


def _solve(q0, v0, a0, q1, v1, a1, T):
    """The boundary conditions as a linear system in the six coefficients."""
    A = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0],
                  [1, T, T**2, T**3, T**4, T**5], [0, 1, 2 * T, 3 * T**2, 4 * T**3, 5 * T**4],
                  [0, 0, 2, 6 * T, 12 * T**2, 20 * T**3]], dtype=float)
    return np.linalg.solve(A, [q0, v0, a0, q1, v1, a1])


def test_coefficients_match_direct_solve():
    rng = np.random.default_rng(1)
    for _ in range(50):
        b = rng.normal(size=6)
        T = rng.uniform(0.05, 5.0)
        np.testing.assert_allclose(coefficients(*b, T), _solve(*b, T), rtol=1e-9, atol=1e-9)


def test_min_jerk_peaks_are_the_published_ones():
    delta, T = 0.7, 1.3
    c = coefficients(0.0, 0.0, 0.0, delta, 0.0, 0.0, T)
    np.testing.assert_allclose(c, [0, 0, 0, 10 * delta / T**3, -15 * delta / T**4, 6 * delta / T**5], atol=1e-12)
    s = np.linspace(0, T, 200001)
    v = np.polynomial.polynomial.polyval(s, np.polynomial.polynomial.polyder(c))
    a = np.polynomial.polynomial.polyval(s, np.polynomial.polynomial.polyder(c, 2))
    assert np.max(np.abs(v)) == pytest.approx(PEAK_VELOCITY * delta / T, rel=1e-9)
    assert np.max(np.abs(a)) == pytest.approx(PEAK_ACCELERATION * delta / T**2, rel=1e-7)
    e = extrema(c[None], T)[:, 0]
    np.testing.assert_allclose(e, [0, delta, PEAK_VELOCITY * delta / T, PEAK_ACCELERATION * delta / T**2], atol=1e-12)


def test_extrema_agree_with_dense_sampling():
    rng = np.random.default_rng(2)
    c = coefficients(rng.normal(size=5), rng.normal(size=5), rng.normal(size=5),
                     rng.normal(size=5), rng.normal(size=5), rng.normal(size=5), 0.8)
    s = np.linspace(0, 0.8, 400001)
    P = np.polynomial.polynomial
    for j in range(5):
        q = P.polyval(s, c[j])
        v = P.polyval(s, P.polyder(c[j]))
        a = P.polyval(s, P.polyder(c[j], 2))
        np.testing.assert_allclose(extrema(c, 0.8)[:, j], [q.min(), q.max(), np.abs(v).max(), np.abs(a).max()], rtol=1e-8)


def test_rest_to_rest_duration_is_the_binding_limit():
    # joint 0 velocity-bound: T = 15/8 · 2 / 1; joint 1 acceleration-bound: T = √(10/√3 · 3 / 0.5)
    T = rest_to_rest_duration([2.0, 0.0], [1.0, 1.0], [100.0, 1.0])
    assert T == pytest.approx(3.75)
    T = rest_to_rest_duration([0.0, 3.0], [1.0, 100.0], [100.0, 0.5])
    assert T == pytest.approx(np.sqrt(10 / np.sqrt(3) * 3 / 0.5))
    assert rest_to_rest_duration([0.0, 0.0], [1.0, 1.0], [1.0, 1.0]) == 0.0


def test_shortest_duration_scan_finds_the_closed_form_from_rest():
    rng = np.random.default_rng(3)
    for _ in range(5):
        q0, q1 = rng.uniform(-1, 1, 4), rng.uniform(-1, 1, 4)
        vm, am = rng.uniform(0.5, 2, 4), rng.uniform(0.5, 4, 4)
        closed = rest_to_rest_duration(q1 - q0, vm, am)
        T = shortest_duration(q0, np.zeros(4), np.zeros(4), q1, vm, am)
        assert closed * (1 - 1e-9) <= T <= closed * _FINE[1] / _FINE[0] * 1.001


def test_shortest_duration_with_initial_motion_fits_and_is_short():
    q0, v0, a0, q1 = np.array([0.0]), np.array([0.9]), np.array([-0.5]), np.array([0.2])
    vm, am = np.array([1.0]), np.array([2.0])
    T = shortest_duration(q0, v0, a0, q1, vm, am)
    e = extrema(coefficients(q0, v0, a0, q1, 0, 0, T), T)
    assert e[2, 0] <= 1.0 + 1e-9 and e[3, 0] <= 2.0 + 1e-9
    Tm = T * _FINE[0] / _FINE[1]  # the previous candidate did not fit
    e = extrema(coefficients(q0, v0, a0, q1, 0, 0, Tm), Tm)
    assert e[2, 0] > 1.0 or e[3, 0] > 2.0


def test_braking_quintic_has_a_cubic_velocity_decay():
    q0, v0, a0, T = np.array([0.3]), np.array([0.8]), np.array([1.0]), 0.7
    c = coefficients(q0, v0, a0, braking_target(q0, v0, a0, T), 0.0, 0.0, T)
    assert abs(c[0, 5]) < 1e-12  # quartic position
    s = np.linspace(0, 1, 1001)
    v = np.polynomial.polynomial.polyval(s * T, np.polynomial.polynomial.polyder(c[0]))
    np.testing.assert_allclose(v, 0.8 * (1 - s) ** 2 * (1 + 2 * s) + 1.0 * T * s * (1 - s) ** 2, atol=1e-12)
