"""Both laws' recursions against their matrix forms (docs/cstar_slotine_li.md): with K_D = 0,
C*: τ = H q̈_r + C* q̇_r + G; classic: τ = H q̈_r + C q̇_r + G with the Christoffel C; and
dπ̂/dt = −P Yᵀ s with the explicit regressor of the matching factorisation."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.control.base import Reference
from rtctl.control.slotine_li import SlotineLi
from rtctl.control.slotine_li_kernels import phi_into
from rtctl.hal.joints import JointCommand, JointState
from rtctl.model import dynamics as dyn
from rtctl.model.spatial import inertia

KINDS = {"cstar": "cstar", "classic": "christoffel"}


def matrix_form(model, law, q, qd, q_d, qd_d, qdd_d, lam, kd, gamma):
    qdr = qd_d - lam * (q - q_d)
    qddr = qdd_d - lam * (qd - qd_d)
    s = qd - qdr
    H, G = dyn.mass_matrix(model, q), dyn.gravity(model, q)
    C = dyn.coriolis_matrix(model, q, qd, KINDS[law])
    Y = dyn.slotine_li_regressor(model, q, qd, qdr, qddr, KINDS[law])
    return H @ qddr + C @ qdr + G - kd * s, -(gamma.ravel() * (Y.T @ s)).reshape(-1, 10), Y, s


def random_case(model, rng):
    n = model.nq
    q_d = rng.uniform(-1.5, 1.5, n)
    return (q_d + rng.normal(0, 0.2, n), rng.uniform(-2, 2, n), q_d, rng.uniform(-2, 2, n), rng.uniform(-5, 5, n),
            rng.uniform(0.5, 20, n), rng.uniform(0.1, 3, (n, 10)))


def robots(random_chain, puma):
    return [puma] + [random_chain(n, seed) for n, seed in ((3, 1), (4, 2), (5, 3), (7, 4), (9, 5))]


@pytest.mark.parametrize("law", ["cstar", "classic"])
def test_recursion_equals_matrix_form(law, random_chain, puma):
    rng = np.random.default_rng(7)
    for model in robots(random_chain, puma):
        for _ in range(3):
            q, qd, q_d, qd_d, qdd_d, lam, gamma = random_case(model, rng)
            params_hat = model.params * rng.uniform(0.3, 1.7, (model.nq, 1))  # estimates ≠ truth
            c = SlotineLi(model, law=law, lam=lam, kd=0.0, gamma=gamma, params0=params_hat)
            tau, params_dot = c.compute(q, qd, q_d, qd_d, qdd_d)
            ref_tau, _, _, _ = matrix_form(model.with_params(params_hat), law, q, qd, q_d, qd_d, qdd_d, lam, 0.0, gamma)
            _, ref_dot, _, _ = matrix_form(model, law, q, qd, q_d, qd_d, qdd_d, lam, 0.0, gamma)
            scale = max(1.0, np.abs(ref_tau).max())
            assert np.abs(tau - ref_tau).max() <= 1e-10 * scale, model.name
            assert np.abs(params_dot - ref_dot).max() <= 1e-10 * max(1.0, np.abs(ref_dot).max()), model.name


def test_laws_differ_for_three_joints_and_damping_enters(random_chain):
    """Proposition 1 seen through the controller: a 3+-joint chain gives different torques
    for the two laws (so the comparison above can fail); K_D s is subtracted per joint."""
    model = random_chain(5, 11)
    rng = np.random.default_rng(3)
    q, qd, q_d, qd_d, qdd_d, lam, gamma = random_case(model, rng)
    taus = {law: SlotineLi(model, law=law, lam=lam, kd=0.0, gamma=gamma).compute(q, qd, q_d, qd_d, qdd_d)[0]
            for law in KINDS}
    assert np.abs(taus["cstar"] - taus["classic"]).max() > 1e-3
    kd = rng.uniform(1, 50, model.nq)
    tau_kd, _ = SlotineLi(model, law="cstar", lam=lam, kd=kd, gamma=gamma).compute(q, qd, q_d, qd_d, qdd_d)
    s = qd - (qd_d - lam * (q - q_d))
    np.testing.assert_allclose(tau_kd, taus["cstar"] - kd * s, rtol=0, atol=1e-10)


def test_phi_is_the_inertia_bilinear_form():
    rng = np.random.default_rng(0)
    out = np.zeros((1, 10))
    for _ in range(20):
        x, y, p = rng.normal(size=6), rng.normal(size=6), rng.normal(size=10)
        phi_into(np.stack([x, y])[None], 0, 0, 1, out, 0)
        assert out[0] @ p == pytest.approx(x @ inertia(p) @ y, rel=1e-12, abs=1e-12)


def test_compute_is_pure_and_update_integrates(puma):
    rng = np.random.default_rng(5)
    q, qd, q_d, qd_d, qdd_d, lam, gamma = random_case(puma, rng)
    c = SlotineLi(puma, lam=lam, kd=10.0, gamma=gamma, params0="scaled", params_scale=0.6)
    first = c.compute(q, qd, q_d, qd_d, qdd_d)
    second = c.compute(q, qd, q_d, qd_d, qdd_d)
    np.testing.assert_array_equal(first[0], second[0])
    np.testing.assert_array_equal(c.params_hat, 0.6 * puma.params)
    state, ref, cmd = JointState(6), Reference(6), JointCommand(6)
    state.position[:], state.velocity[:], ref.q[:], ref.qd[:], ref.qdd[:] = q, qd, q_d, qd_d, qdd_d
    c.update(0.0, state, ref, cmd)  # first update: nothing to integrate yet
    np.testing.assert_array_equal(cmd.tau_ff, first[0])
    c.update(0.002, state, ref, cmd)  # explicit Euler over the 2 ms since the previous update
    np.testing.assert_allclose(c.params_hat, 0.6 * puma.params + 0.002 * first[1], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(c.internals["params_hat"], c.params_hat.ravel())
    c.reset(state)
    np.testing.assert_array_equal(c.params_hat, 0.6 * puma.params)


def test_dead_zone_stops_adaptation_only(puma):
    rng = np.random.default_rng(9)
    q, qd, q_d, qd_d, qdd_d, lam, gamma = random_case(puma, rng)
    s_norm = np.linalg.norm(qd - (qd_d - lam * (q - q_d)))
    plain = SlotineLi(puma, lam=lam, kd=50.0, gamma=gamma).compute(q, qd, q_d, qd_d, qdd_d)
    inside = SlotineLi(puma, lam=lam, kd=50.0, gamma=gamma, dead_zone=1.01 * s_norm).compute(q, qd, q_d, qd_d, qdd_d)
    outside = SlotineLi(puma, lam=lam, kd=50.0, gamma=gamma, dead_zone=0.99 * s_norm).compute(q, qd, q_d, qd_d, qdd_d)
    np.testing.assert_array_equal(inside[0], plain[0])
    assert not inside[1].any() and np.abs(plain[1]).max() > 0
    np.testing.assert_array_equal(outside[1], plain[1])


@pytest.mark.parametrize("speed", [1.0, 0.01])  # rad/s: the Coulomb term saturated, and inside its band v_c
def test_motor_model_adds_the_known_drive_train(puma, speed):
    rng = np.random.default_rng(2)
    q, qd, q_d, qd_d, qdd_d, lam, gamma = random_case(puma, rng)
    qd = speed * qd
    bare = SlotineLi(puma, lam=lam, kd=50.0, gamma=gamma).compute(q, qd, q_d, qd_d, qdd_d)[0]
    with_motor = SlotineLi(puma, lam=lam, kd=50.0, gamma=gamma, motor_model=True).compute(q, qd, q_d, qd_d, qdd_d)[0]
    m, qddr = puma.motors, qdd_d - lam * (qd - qd_d)
    expected = bare + m.armature * qddr + m.viscous * qd + m.coulomb * np.tanh(qd / 0.01)
    np.testing.assert_allclose(with_motor, expected, rtol=1e-12, atol=1e-12)
