"""Dynamics against Pinocchio (docs/cstar_slotine_li.md, "How it is verified"): RNEA, H, G, the standard regressor, the Christoffel C
and forward dynamics, over hundreds of seeded random states, error ≤ 1e-9 (relative to the
size of the reference where it exceeds 1).

Robots: PUMA 560 (D-H TOML → to_urdf → Pinocchio), UR5 and Panda (Pinocchio reads the original
URDF files itself, so our URDF reader is under test too), random chains with prismatic joints.
"""
import numpy as np
import pytest

from rtctl.model import dynamics as dyn

STATES = 200
TOL = 1e-9


@pytest.fixture(params=["puma", "ur5", "panda", "random7", "random12"])
def pair(request, pin_twin):
    """(our model, Pinocchio model, Pinocchio data) for one robot."""
    name = request.param
    if name.startswith("random"):
        n = int(name[6:])
        model = request.getfixturevalue("random_chain")(n, seed=100 + n)
        return model, *pin_twin(model)
    model = request.getfixturevalue(name)
    if name == "puma":
        return model, *pin_twin(model)
    return model, *request.getfixturevalue(f"pin_{name}")


def close(ours, ref, what):
    scale = max(1.0, float(np.max(np.abs(ref))))
    err = float(np.max(np.abs(ours - ref)))
    assert err <= TOL * scale, f"{what}: max error {err:.3g} (scale {scale:.3g})"


def full(H):
    """Pinocchio's crba fills the upper triangle only."""
    return np.triu(H) + np.triu(H, 1).T


def test_rnea_mass_matrix_gravity(pair, pin, pin_q, states):
    model, pm, pd = pair
    for q, qd, qdd in states(model, STATES, seed=1):
        pq = pin_q(pm, q)
        close(dyn.rnea(model, q, qd, qdd), pin.rnea(pm, pd, pq, qd, qdd), "rnea")
        close(dyn.mass_matrix(model, q), full(pin.crba(pm, pd, pq)), "H")
        close(dyn.gravity(model, q), pin.computeGeneralizedGravity(pm, pd, pq), "G")


def test_christoffel_coriolis_matrix(pair, pin, pin_q, states):
    model, pm, pd = pair
    for q, qd, _ in states(model, STATES, seed=2):
        C = pin.computeCoriolisMatrix(pm, pd, pin_q(pm, q), qd)
        close(dyn.coriolis_matrix(model, q, qd, "christoffel"), C, "C")


def test_regressor_column_by_column(pair, pin, pin_q, states):
    model, pm, pd = pair
    for q, qd, qdd in states(model, STATES // 2, seed=3):
        Y = pin.computeJointTorqueRegressor(pm, pd, pin_q(pm, q), qd, qdd)
        close(dyn.regressor(model, q, qd, qdd), Y, "Y")


def test_forward_dynamics_with_and_without_armature(pair, pin, pin_q, states):
    model, pm, pd = pair
    armature = np.linspace(0.05, 0.3, model.nq)
    rng = np.random.default_rng(4)
    for q, qd, _ in states(model, STATES, seed=4):
        tau = rng.uniform(-20, 20, model.nq)
        pq = pin_q(pm, q)
        pm.armature[:] = 0.0
        close(dyn.forward_dynamics(model, q, qd, tau), pin.aba(pm, pd, pq, qd, tau), "aba")
        pm.armature[:] = armature
        close(dyn.forward_dynamics(model, q, qd, tau, armature), pin.aba(pm, pd, pq, qd, tau), "aba+armature")
    pm.armature[:] = 0.0


def test_model_parameters_are_pinocchios(pair):
    model, pm, _ = pair
    for i in range(model.nq):
        close(model.params[i], pm.inertias[i + 1].toDynamicParameters(), f"params[{i}]")
