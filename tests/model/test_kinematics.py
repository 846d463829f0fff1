"""Forward and differential kinematics against independent references: the paper's D-H
product (eqs. 1-3) written out here, Pinocchio's frame placements and frame Jacobians, and
central finite differences of fk."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rtctl.model import load_robot
from rtctl.model import kinematics as K
from rtctl.model.rotations import homogeneous, rot_axis

ROBOTS = Path(__file__).resolve().parents[2] / "configs" / "robots"


@pytest.fixture(scope="module")
def table1():
    return load_robot(ROBOTS / "table1_arm.toml")


def random_states(model, count, seed):
    """Seeded random (q, q̇) within the joint limits (±π where unlimited)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(model.q_min), model.q_min, -np.pi)
    hi = np.where(np.isfinite(model.q_max), model.q_max, np.pi)
    for _ in range(count):
        yield rng.uniform(lo, hi), rng.uniform(-2, 2, model.nq), None


def random_rotation(rng):
    axis = rng.normal(size=3)
    return rot_axis(axis / np.linalg.norm(axis), rng.uniform(-np.pi, np.pi))


def paul_A(alpha, a, d, theta):
    """ⁱ⁻¹Aᵢ as the paper's matrix (1), element by element."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array([[ct, -ca * st, sa * st, a * ct],
                     [st, ca * ct, -sa * ct, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def dh_tool_pose(model, q):
    """F = A₁ A₂ … Aₙ · tool (eqs. 3, 7), independent of the tree-walking fk."""
    T = np.eye(4)
    for i in range(model.nq):
        T = T @ paul_A(model.dh.alpha[i], model.dh.a[i], model.dh.d[i], q[i] + model.dh.theta0[i])
    return T @ model.tool


@pytest.mark.parametrize("robot", ["puma", "table1"])
def test_fk_equals_the_dh_product(robot, request):
    model = request.getfixturevalue(robot)
    for q, _, _ in random_states(model, 200, seed=1):
        np.testing.assert_allclose(K.fk(model, q), dh_tool_pose(model, q), atol=1e-12)


def test_puma_home_pose_is_corkes(puma):
    """Corke's mdl_puma560 at qz: tool at (0.4521, −0.15005, 0.4318), identity orientation."""
    np.testing.assert_allclose(K.fk(puma, np.zeros(6)), homogeneous(np.eye(3), [0.4521, -0.15005, 0.4318]), atol=1e-12)


ALL_ROBOTS = ["puma", "table1", "ur5", "panda", "random6", "random9"]


def robot_model(name, request, random_chain):
    if name.startswith("random"):
        n = int(name[6:])
        return random_chain(n, seed=n)
    return request.getfixturevalue(name)


@pytest.mark.parametrize("robot", ALL_ROBOTS)
def test_fk_and_link_poses_equal_pinocchio(robot, request, random_chain, pin, pin_twin, pin_q):
    model = robot_model(robot, request, random_chain)
    pmodel, pdata = pin_twin(model)
    tool = pmodel.getFrameId("tool", pin.BODY)
    for q, _, _ in random_states(model, 100, seed=2):
        pin.forwardKinematics(pmodel, pdata, pin_q(pmodel, q))
        pin.updateFramePlacements(pmodel, pdata)
        np.testing.assert_allclose(K.fk(model, q), pdata.oMf[tool].homogeneous, atol=1e-12)
        poses = K.link_poses(model, q)
        for i in range(model.nq):
            np.testing.assert_allclose(poses[i], pdata.oMi[i + 1].homogeneous, atol=1e-12)


@pytest.mark.parametrize("robot", ALL_ROBOTS)
def test_jacobian_equals_pinocchio_frame_jacobian(robot, request, random_chain, pin, pin_twin, pin_q):
    model = robot_model(robot, request, random_chain)
    pmodel, pdata = pin_twin(model)
    tool = pmodel.getFrameId("tool", pin.BODY)
    for q, _, _ in random_states(model, 50, seed=3):
        expected = pin.computeFrameJacobian(pmodel, pdata, pin_q(pmodel, q), tool, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(K.jacobian(model, q), expected, atol=1e-12)


def finite_difference_jacobian(model, q, h=1e-6):
    """Central differences: linear rows from the tool position, angular rows from
    R(q + h eᵢ) R(q − h eᵢ)ᵀ ≈ 1 + 2h [ω]×."""
    J = np.zeros((6, model.nq))
    for i in range(model.nq):
        dq = np.zeros(model.nq)
        dq[i] = h
        Tp, Tm = K.fk(model, q + dq), K.fk(model, q - dq)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        S = Tp[:3, :3] @ Tm[:3, :3].T
        J[3:, i] = np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / (4 * h)
    return J


@pytest.mark.parametrize("robot", ALL_ROBOTS)
def test_jacobian_matches_finite_differences(robot, request, random_chain):
    """Truncation (h² ≈ 1e-12) and rounding (ε/h ≈ 1e-10) errors of the differences bound the
    agreement: 1e-8 (measured worst ≈ 1e-9)."""
    model = robot_model(robot, request, random_chain)
    for q, _, _ in random_states(model, 30, seed=4):
        np.testing.assert_allclose(K.jacobian(model, q), finite_difference_jacobian(model, q), atol=1e-8)


def test_prismatic_columns(random_chain):
    model = random_chain(8, seed=5)
    prismatic = np.flatnonzero(model.joint_types == 1)
    assert prismatic.size
    q = np.zeros(model.nq)
    J = K.jacobian(model, q)
    np.testing.assert_allclose(J[3:, prismatic], 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(J[:3, prismatic], axis=0), 1.0, atol=1e-12)


def test_tool_frame_composes_on_the_right(puma, random_chain):
    rng = np.random.default_rng(6)
    for model in (puma, random_chain(6, seed=7)):
        tool = homogeneous(random_rotation(rng), rng.uniform(-0.3, 0.3, 3))
        bare, tooled = model.with_tool(np.eye(4)), model.with_tool(tool)
        for q, _, _ in random_states(model, 20, seed=8):
            np.testing.assert_allclose(K.fk(tooled, q), K.fk(bare, q) @ tool, atol=1e-12)


def test_tool_twist_is_the_derivative_of_the_pose(puma):
    """v = ṗ and [ω]× = Ṙ Rᵀ along a path q(t) = q0 + t q̇ (central differences in t)."""
    h = 1e-6
    for q, qd, _ in random_states(puma, 20, seed=9):
        Tp, Tm, T = K.fk(puma, q + h * qd), K.fk(puma, q - h * qd), K.fk(puma, q)
        Rdot = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h)
        W = Rdot @ T[:3, :3].T
        expected = np.concatenate([(Tp[:3, 3] - Tm[:3, 3]) / (2 * h), [W[2, 1], W[0, 2], W[1, 0]]])
        np.testing.assert_allclose(K.tool_twist(puma, q, qd), expected, atol=1e-8)


def test_joint_rates_invert_tool_twist_where_regular(puma, table1, panda):
    for model in (puma, table1, panda):
        checked = 0
        for q, qd, _ in random_states(model, 60, seed=10):
            qd_back, info = K.joint_rates(model, q, K.tool_twist(model, q, qd))
            if info.singular:
                continue
            checked += 1
            assert info.damping == 0.0 and info.residual < 1e-9
            if model.nq == 6:  # square: the solve is exact; redundant: a rate giving the same twist
                np.testing.assert_allclose(qd_back, qd, atol=1e-9)
        assert checked >= 40


def test_joint_rates_least_squares_for_short_chains(two_link):
    q = np.array([0.3, 0.7])
    qd = np.array([0.5, -1.0])
    back, info = K.joint_rates(two_link, q, K.tool_twist(two_link, q, qd))
    np.testing.assert_allclose(back, qd, atol=1e-9)
    assert info.residual < 1e-9 and not info.singular


def elbow_stretched_q3(model):
    """θ₃ with the forearm in line with the upper arm: (a₃, sin α₃ d₄) ∥ x₂."""
    dh = model.dh
    return np.arctan2(np.sin(dh.alpha[2]) * dh.d[3], dh.a[2]) - dh.theta0[2]


@pytest.mark.parametrize("robot", ["puma", "table1"])
def test_joint_rates_report_known_singularities(robot, request):
    model = request.getfixturevalue(robot)
    rng = np.random.default_rng(11)
    twist = rng.normal(size=6)
    q = np.radians([20.0, 30.0, -60.0, 40.0, 30.0, 10.0])
    wrist = q.copy()
    wrist[4] = 0.0  # axes 4 and 6 aligned
    elbow = q.copy()
    elbow[2] = elbow_stretched_q3(model)
    _, regular = K.joint_rates(model, q, twist)
    assert not regular.singular and regular.sigma_min > 0.05
    for singular_q in (wrist, elbow):
        qd, info = K.joint_rates(model, singular_q, twist, damping=0.05)
        assert info.singular and info.sigma_min < 1e-12 and info.manipulability < 1e-12
        assert info.damping == pytest.approx(0.05)
        # Damped least squares: each gain σ/(σ² + λ²) ≤ 1/(2λ) keeps the rates bounded.
        assert np.linalg.norm(qd) <= np.linalg.norm(twist) / (2 * 0.05) + 1e-9
        assert info.residual > 0.0


def test_damping_fades_in_continuously(puma):
    """λ grows from 0 at the threshold: approaching the wrist singularity q5 → 0 the rates stay
    bounded and the solution changes continuously."""
    twist = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.2])
    q = np.radians([20.0, 30.0, -60.0, 40.0, 0.0, 10.0])
    norms = []
    for q5 in np.linspace(0.2, 0.0, 41):
        q[4] = q5
        qd, info = K.joint_rates(puma, q, twist)
        norms.append(np.linalg.norm(qd))
    assert max(norms) < np.linalg.norm(twist) / (2 * 0.05) + 10.0
    assert np.max(np.abs(np.diff(norms))) < 2.0


def test_link_poses_end_in_the_tool_pose(random_chain):
    model = random_chain(7, seed=12)
    for q, _, _ in random_states(model, 10, seed=13):
        np.testing.assert_allclose(K.link_poses(model, q)[-1] @ model.flange @ model.tool, K.fk(model, q), atol=1e-12)


def test_revolute_joint_turns_about_its_axis(random_chain):
    """Moving only joint i by δ turns everything after it by Rot(zᵢ, δ) about a point on zᵢ."""
    model = random_chain(5, seed=14, prismatic=False)
    q = np.zeros(5)
    for i in range(5):
        poses = K.link_poses(model, q)
        z = poses[i][:3, :3] @ model.axis[i]
        o = poses[i][:3, 3]
        dq = np.zeros(5)
        dq[i] = 0.4
        R = rot_axis(z, 0.4)
        T0, T1 = K.fk(model, q), K.fk(model, q + dq)
        np.testing.assert_allclose(T1[:3, :3], R @ T0[:3, :3], atol=1e-12)
        np.testing.assert_allclose(T1[:3, 3], o + R @ (T0[:3, 3] - o), atol=1e-12)
