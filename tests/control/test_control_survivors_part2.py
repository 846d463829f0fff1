"""The computed-torque law and the consistency projection, the cases a run of every
rtctl/control mutant found unchecked (docs/mutation/control.md). Each expectation is
independent of the code under test:

* computed torque is τ = RNEA(q, q̇, q̈*) with q̈* = q̈_d − K_d (q̇ − q̇_d) − K_p (q − q_d),
  checked against Pinocchio's RNEA;
* the projection stops at the documented tolerance, λ_min ≥ −10⁻⁹ · |tr P| (docs/
  cstar_slotine_li.md): a link with λ_min = −0.9 · 10⁻⁹ |tr| is left alone, one with
  −1.1 · 10⁻⁹ |tr| is corrected — on a pseudo-inertia whose diagonal and off-diagonal entries
  all count, so the tolerance's scale is the trace and nothing else;
* a call makes at most 16 corrections (the documented bound), a zero gain freezes a link
  (nothing moves, nothing divides by zero), and the count over links starts at 0;
* a gain below 0 is refused (−0.5 too); computed torque from a configuration models the drive
  train unless ``motor_model = false`` (its class docstring).
"""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.control.base import Reference
from rtctl.control.computed_torque import ARMATURE, ComputedTorque
from rtctl.control.consistency import project_consistent, project_link
from rtctl.hal.joints import JointCommand, JointState


def _to_pin_q(pm, q):
    out = np.zeros(pm.nq)
    for joint, value in zip(list(pm.joints)[1:], q):
        out[joint.idx_q:joint.idx_q + joint.nq] = (np.cos(value), np.sin(value)) if joint.nq == 2 else value
    return out


def test_computed_torque_is_pinocchios_rnea_of_the_pd_corrected_acceleration(puma):
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the reference")
    pm = pin.buildModelFromXML(puma.to_urdf())
    pd = pm.createData()
    n = puma.nq
    rng = np.random.default_rng(11)
    kp, kd = rng.uniform(10, 100, n), rng.uniform(1, 10, n)
    c = ComputedTorque("ct", puma, kp, kd, motor_model=False)
    state, ref, command = JointState(n), Reference(n), JointCommand(n)
    for _ in range(5):
        state.position[:], state.velocity[:] = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
        ref.packed[:] = rng.uniform(-1, 1, (3, n))
        c.update(0.0, state, ref, command)
        a = ref.qdd - kd * (state.velocity - ref.qd) - kp * (state.position - ref.q)
        expected = pin.rnea(pm, pd, _to_pin_q(pm, state.position), state.velocity, a)
        np.testing.assert_allclose(command.tau_ff, expected, rtol=1e-9, atol=1e-9)


def test_computed_torque_with_its_motor_model_adds_the_armatures_share(puma):
    """At rest (q̇ = 0: no viscous or Coulomb term) the drive train adds armature · q̈*."""
    model = puma
    assert model.motors is not None and np.any(model.motors.armature)
    n = model.nq
    with_motors = ComputedTorque("ct", model, 50.0, 5.0)
    without = ComputedTorque("ct", model, 50.0, 5.0, motor_model=False)
    state, ref = JointState(n), Reference(n)
    state.position[:] = 0.3
    ref.q[:], ref.qdd[:] = 0.5, 2.0
    taus = []
    for c in (with_motors, without):
        command = JointCommand(n)
        c.update(0.0, state, ref, command)
        taus.append(command.tau_ff.copy())
    qdd_star = 2.0 - 50.0 * (0.3 - 0.5)
    np.testing.assert_allclose(taus[0] - taus[1], model.motors.armature * qdd_star, rtol=1e-12, atol=1e-12)


def _link_with(lambda_min_over_trace, seed=3):
    """A link's 10 parameters whose pseudo-inertia P has λ_min = given · |tr P|, built from a
    rotated second-moment block so that every entry of P is significant."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    eig = np.array([1.0, 2.0, 1.5, 0.0])
    trace = eig.sum()
    eig[3] = lambda_min_over_trace * trace / (1 - lambda_min_over_trace)  # tr includes λ_min itself
    P = Q @ np.diag(eig) @ Q.T
    P = 0.5 * (P + P.T)
    S, h, m = P[:3, :3], P[:3, 3], P[3, 3]
    J = np.trace(S) * np.eye(3) - S
    p = np.array([m, *h, J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]])
    low = np.linalg.eigvalsh(P)[0] / abs(np.trace(P))
    assert low == pytest.approx(lambda_min_over_trace, rel=1e-6) and min(abs(P[np.triu_indices(4)])) > 1e-3
    return p


def _scratch():
    return np.zeros((4, 4)), np.zeros((4, 4)), np.zeros(10), np.zeros(4)


@pytest.mark.parametrize("seed", range(5))
def test_the_projection_stops_at_minus_1e_9_of_the_trace(seed):
    inside, outside = _link_with(-0.9e-9, seed), _link_with(-1.1e-9, seed)
    before = inside.copy()
    assert project_link(inside, np.ones(10), *_scratch()) == 0 and np.array_equal(inside, before)
    assert project_link(outside, np.ones(10), *_scratch()) >= 1


def test_a_call_makes_at_most_16_corrections():
    """Gross violations (random factors in [−1.5, 2.5]): some need more than a call allows."""
    from random_robots import random_params

    rng = np.random.default_rng(1)
    counts = [project_link(random_params(rng) * rng.uniform(-1.5, 2.5, 10), rng.uniform(0.05, 20, 10), *_scratch())
              for _ in range(200)]
    assert max(counts) == 16


def test_a_zero_gain_freezes_an_inconsistent_link():
    p = _link_with(-0.1)
    before = p.copy()
    assert project_link(p, np.zeros(10), *_scratch()) == 0 and np.array_equal(p, before)


def test_the_count_over_consistent_links_is_zero():
    params = np.array([_link_with(0.01, seed) for seed in range(3)])
    assert project_consistent(params, np.ones((3, 10)), *_scratch()[:3], np.zeros((3, 4))) == 0


def test_a_negative_gain_is_refused():
    from rtctl.control.gains import per_joint
    from rtctl.errors import ConfigError
    from rtctl.tomltable import Table

    for value in (-0.5, [1.0, -0.5, 1.0]):
        with pytest.raises(ConfigError, match="kp"):
            per_joint(Table({"kp": value}, "run.toml", "controllers[0]"), "kp", 3)


def test_computed_torque_from_a_configuration_models_the_drive_train_unless_told_not_to(puma):
    from types import SimpleNamespace

    from rtctl.tomltable import Table

    def configured(**options):
        t = Table({"kp": 50.0, "kd": 5.0, **options}, "run.toml", "controllers[0]")
        return ComputedTorque.from_config(SimpleNamespace(options=t, name="ct", joints=None, divisor=1), puma)

    np.testing.assert_array_equal(configured().gains[ARMATURE], puma.motors.armature)
    assert not configured(motor_model=False).gains[ARMATURE].any()
