"""The consistency projection (rtctl.control.consistency): the pseudo-inertia, the 4×4 Jacobi
eigen-solver against numpy, and the two properties the Lyapunov argument needs: the result is
(to tolerance) physically consistent, and the P⁻¹-distance to any consistent π never grows."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from rtctl.control.consistency import MAX_CORRECTIONS, TOLERANCE, positive_definite4, project_link, pseudo_inertia, \
    quadratic_form_gradient, symmetric_eigen4

from random_robots import random_params


def pseudo(p):
    out = np.zeros((4, 4))
    pseudo_inertia(p, out)
    return out


def scratch():
    return np.zeros((4, 4)), np.zeros((4, 4)), np.zeros(10), np.zeros(4)


def test_pseudo_inertia_is_the_second_moment_matrix():
    """A cloud of point masses: P(π) = Σ m_k [x_k; 1][x_k; 1]ᵀ, π from the masses directly."""
    rng = np.random.default_rng(0)
    pts, masses = rng.normal(size=(7, 3)), rng.uniform(0.1, 2, 7)
    J = sum(m * (x @ x * np.eye(3) - np.outer(x, x)) for m, x in zip(masses, pts))
    p = np.array([masses.sum(), *(masses @ pts), J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]])
    expected = sum(m * np.outer([*x, 1.0], [*x, 1.0]) for m, x in zip(masses, pts))
    np.testing.assert_allclose(pseudo(p), expected, rtol=1e-12, atol=1e-12)
    a = np.zeros(10)
    for _ in range(5):
        x = rng.normal(size=4)
        quadratic_form_gradient(x, a)
        assert abs(a @ p - x @ expected @ x) < 1e-10


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_jacobi_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(4, 4)) * 10.0 ** rng.uniform(-4, 2)
    M = M + M.T
    A, V = M.copy(), np.zeros((4, 4))
    symmetric_eigen4(A, V)
    scale = np.abs(M).max()
    np.testing.assert_allclose(np.sort(np.diag(A)), np.linalg.eigvalsh(M), atol=1e-12 * scale)
    np.testing.assert_allclose(V @ np.diag(np.diag(A)) @ V.T, M, atol=1e-11 * scale)


@pytest.mark.parametrize("M", [
    np.diag([1.0, 2.0, 3.0, 4.0]) + 0.3 * (np.eye(4, k=3) + np.eye(4, k=-3)),  # coupled to the last axis only
    np.array([[4.0, 0.0, 0.0, 1.0], [0.0, 3.0, 0.0, 0.5], [0.0, 0.0, 2.0, 0.25], [1.0, 0.5, 0.25, 1.0]]),
    np.array([[1.0, 0.5, 0.0, 0.0], [0.5, 1.5, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0], [0.0, 0.0, 0.0, 3.0]]),  # θ = 0.5
    # θ = 0: equal diagonal entries, as a link symmetric about an axis (I_xx = I_yy) gives
    np.array([[2.0, 0.7, 0.0, 0.1], [0.7, 2.0, 0.0, 0.1], [0.0, 0.0, 3.0, 0.0], [0.1, 0.1, 0.0, 1.0]]),
])
def test_jacobi_matches_numpy_on_sparse_couplings(M):
    A, V = M.copy(), np.zeros((4, 4))
    symmetric_eigen4(A, V)
    np.testing.assert_allclose(np.sort(np.diag(A)), np.linalg.eigvalsh(M), atol=1e-12)
    np.testing.assert_allclose(V @ np.diag(np.diag(A)) @ V.T, M, atol=1e-11)
    np.testing.assert_allclose(V.T @ V, np.eye(4), atol=1e-12)


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_projection_is_consistent_and_non_expansive(seed):
    rng = np.random.default_rng(seed)
    truth = random_params(rng)
    gamma = rng.uniform(0.05, 20, 10)
    p = truth * rng.uniform(-1.5, 2.5, 10) + rng.normal(0, 0.3, 10)  # often inconsistent
    before = pseudo(p)
    q = p.copy()
    corrections = project_link(q, gamma, *scratch())
    after = np.linalg.eigvalsh(pseudo(q))
    if np.linalg.eigvalsh(before)[0] >= -TOLERANCE * np.trace(before):
        assert corrections == 0 and np.array_equal(q, p)
    elif corrections < MAX_CORRECTIONS:  # otherwise it stopped short (the next call continues)
        assert after[0] >= -TOLERANCE * abs(np.trace(pseudo(q))) * 1.0001
    # Non-expansive in the P⁻¹ metric towards every consistent π (the truth, and others).
    for target in (truth, random_params(rng)):
        d_before = np.sum((p - target) ** 2 / gamma)
        d_after = np.sum((q - target) ** 2 / gamma)
        assert d_after <= d_before * (1 + 1e-12) + 1e-15


def test_projection_mostly_reaches_the_set():
    """Gross random violations: the tolerance is met within one call (MAX_CORRECTIONS) nearly always."""
    rng = np.random.default_rng(1)
    reached = 0
    for _ in range(200):
        p = random_params(rng) * rng.uniform(-1.5, 2.5, 10)
        project_link(p, rng.uniform(0.05, 20, 10), *scratch())
        P = pseudo(p)
        reached += np.linalg.eigvalsh(P)[0] >= -TOLERANCE * abs(np.trace(P)) * 1.0001
    assert reached >= 180


def test_small_violations_take_a_few_corrections():
    """What an Euler step does to a consistent estimate (the in-loop case)."""
    rng = np.random.default_rng(4)
    counts = []
    for _ in range(200):
        truth = random_params(rng)
        p = truth + rng.normal(0, 0.02, 10) * np.abs(truth).max()
        counts.append(project_link(p, rng.uniform(0.05, 20, 10), *scratch()))
        P = pseudo(p)
        assert np.linalg.eigvalsh(P)[0] >= -TOLERANCE * abs(np.trace(P)) * 1.0001
    assert np.percentile(counts, 90) <= 3 and max(counts) < MAX_CORRECTIONS


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=4, max_size=4), st.integers(0, 2**32 - 1), st.floats(0, 1e-3))
def test_the_cholesky_shortcut_says_positive_definite_exactly_when_numpy_does(eig, seed, shift):
    """positive_definite4 (the projection's test before any eigenvector) against numpy's
    eigenvalues of A + shift·1, on matrices built with known eigenvalues, some near zero."""
    Q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(4, 4)))
    A = Q @ np.diag(eig) @ Q.T
    A = 0.5 * (A + A.T)
    low = np.linalg.eigvalsh(A)[0] + shift
    if abs(low) < 1e-9:  # (rounding decides there, in both)
        return
    assert positive_definite4(A, shift, np.zeros((4, 4))) == (low > 0)


def test_a_consistent_link_is_left_bit_for_bit_with_no_correction():
    """The in-loop case on nearly every tick: nothing to correct, nothing moved."""
    rng = np.random.default_rng(7)
    for _ in range(100):
        p = random_params(rng)
        before = p.copy()
        assert project_link(p, rng.uniform(0.05, 20, 10), *scratch()) == 0
        assert np.array_equal(p, before)


def test_nan_parameters_are_not_taken_for_consistent():
    assert not positive_definite4(np.full((4, 4), np.nan), 0.0, np.zeros((4, 4)))
