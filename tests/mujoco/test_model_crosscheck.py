"""rtctl's rigid-body model against MuJoCo's (an independent engine): H(q), C(q, q̇) q̇ + G(q) and
inverse dynamics on the shipped robots, the inertias MuJoCo needs made physical, and the payload
folded into the last link against MuJoCo's separate payload body."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hil_sim.mujoco_model import physical_inertia, physical_model, to_mjcf
from hil_sim.payload import Payload, fold_payload
from rtctl.model import load_robot
from rtctl.model.dynamics import gravity, mass_matrix, rnea

mujoco = pytest.importorskip("mujoco", reason="the `mujoco` extra is not installed")

ROBOTS = Path(__file__).resolve().parents[2] / "configs" / "robots"
SHIPPED = sorted(p.name for p in ROBOTS.glob("*.toml") if p.stem != "leg")


def engine(model, payload=None):
    mm = mujoco.MjModel.from_xml_string(to_mjcf(model, timestep=1e-3, payload=payload))
    return mm, mujoco.MjData(mm)


def states(model, k, seed):
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(model.q_min, -np.pi), np.minimum(model.q_max, np.pi)
    for _ in range(k):  # inside the limits: no limit constraint in MuJoCo's inverse dynamics
        yield rng.uniform(lo, hi), rng.uniform(-3, 3, model.nq), rng.uniform(-5, 5, model.nq)


def mujoco_dynamics(mm, d, q, qd, qdd):
    d.qpos[:], d.qvel[:] = q, qd
    mujoco.mj_forward(mm, d)
    M = np.zeros((mm.nv, mm.nv))
    mujoco.mj_fullM(mm, d, M)
    bias = d.qfrc_bias.copy()
    d.qacc[:] = qdd
    mujoco.mj_inverse(mm, d)
    return M, bias, d.qfrc_inverse.copy()


def relative(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-12)


@pytest.mark.parametrize("robot", SHIPPED)
def test_mass_matrix_bias_and_inverse_dynamics_equal_mujocos(robot):
    """To 1e-9 relative where the two models agree: rtctl's model with the inertias MuJoCo
    accepts (physical_model) — H = mj_fullM, C q̇ + G = qfrc_bias, RNEA = mj_inverse, G at q̇ = 0."""
    model, _ = physical_model(load_robot(ROBOTS / robot))
    mm, d = engine(model)
    for q, qd, qdd in states(model, 25, seed=hash(robot) % 1000):
        M, bias, inverse = mujoco_dynamics(mm, d, q, qd, qdd)
        assert relative(mass_matrix(model, q), M) < 1e-9
        assert relative(rnea(model, q, qd, np.zeros(model.nq)), bias) < 1e-9
        assert relative(rnea(model, q, qd, qdd), inverse) < 1e-9
        _, g, _ = mujoco_dynamics(mm, d, q, np.zeros(model.nq), np.zeros(model.nq))
        assert relative(gravity(model, q), g) < 1e-9


def test_the_inertias_mujoco_needs_are_the_nearest_physical_ones_and_change_what_they_must():
    """The PUMA's published data has two inertias no rigid body has; the waist's change (a massless
    link turning about its own axis at the base) leaves the dynamics as they were, the elbow's
    changes H by the amount said in docs/mujoco.md."""
    puma = load_robot(ROBOTS / "puma560.toml")
    fixed, changed = physical_model(puma)
    assert [name for name, _, _ in changed] == ["waist", "elbow"]
    for name, before, after in changed:
        a, b, c = sorted(after)
        assert a + b == pytest.approx(c, rel=1e-9) and after[2] == pytest.approx(sorted(before)[2])
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(50):
        q = rng.uniform(-np.pi, np.pi, 6)
        H0, H1 = mass_matrix(puma, q), mass_matrix(fixed, q)
        worst = max(worst, relative(H1, H0))
    assert 1e-4 < worst < 5e-3  # measured 2.4e-3: the elbow's two smaller moments raised by 3.75 g·m² each
    waist_only = puma.with_params(np.where(np.arange(6)[:, None] == 0, fixed.params, puma.params))
    for _ in range(20):
        q, qd = rng.uniform(-np.pi, np.pi, 6), rng.uniform(-2, 2, 6)
        np.testing.assert_allclose(mass_matrix(waist_only, q), mass_matrix(puma, q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(rnea(waist_only, q, qd, qd), rnea(puma, q, qd, qd), rtol=0, atol=1e-12)
    I = np.diag([1.0, 2.0, 2.5])
    assert physical_inertia(I) is I  # physical: kept as it is


def test_a_payload_folded_into_the_last_link_equals_mujocos_payload_body():
    """Two independent computations of the same physics: rtctl adds the payload's 10 parameters to
    the last link (fold_payload), MuJoCo welds a body at the flange (here turned and offset, so
    that the flange's rotation counts)."""
    model, _ = physical_model(load_robot(ROBOTS / "puma560.toml"))
    c, s = np.cos(0.7), np.sin(0.7)
    flange = np.array([[1, 0, 0, 0.02], [0, c, -s, -0.01], [0, s, c, 0.06], [0, 0, 0, 1.0]])
    model = replace(model, flange=flange @ model.flange)
    payload = Payload(2.0, np.array([0.01, -0.02, 0.05]), np.array([0.004, 0.005, 0.003, 0.0005, -0.0002, 0.0001]))
    folded = fold_payload(model, payload)
    mm, d = engine(model, payload)
    for q, qd, qdd in states(model, 25, seed=7):
        M, bias, inverse = mujoco_dynamics(mm, d, q, qd, qdd)
        assert relative(mass_matrix(folded, q), M) < 1e-9
        assert relative(rnea(folded, q, qd, np.zeros(6)), bias) < 1e-9
        assert relative(rnea(folded, q, qd, qdd), inverse) < 1e-9
    assert relative(mass_matrix(folded, np.zeros(6)), mass_matrix(model, np.zeros(6))) > 1e-2  # it matters
