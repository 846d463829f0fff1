"""Numerical IK (damped Levenberg-Marquardt): converges back to reachable poses of real and
random chains within the joint limits; refuses unreachable ones."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.errors import KinematicsError
from rtctl.model import kinematics as K
from rtctl.model.ik_numeric import pose_error, rotation_vector
from rtctl.model.rotations import homogeneous, rot_axis


def random_qs(model, count, seed):
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(model.q_min), model.q_min, -np.pi)
    hi = np.where(np.isfinite(model.q_max), model.q_max, np.pi)
    return [rng.uniform(lo, hi) for _ in range(count)]


def check_converges(model, count, seed):
    for q in random_qs(model, count, seed):
        pose = K.fk(model, q)
        back = K.ik(model, pose, method="numeric")
        np.testing.assert_allclose(K.fk(model, back), pose, atol=1e-9)
        assert np.all(back >= model.q_min) and np.all(back <= model.q_max)


@pytest.mark.parametrize("robot", ["ur5", "panda", "puma"])
def test_real_arms(robot, request):
    check_converges(request.getfixturevalue(robot), 25, seed=1)


@pytest.mark.parametrize("n, seed", [(2, 1), (3, 2), (6, 3), (7, 4), (9, 5)])
def test_random_chains_with_prismatic_joints(random_chain, n, seed):
    check_converges(random_chain(n, seed=seed), 15, seed=seed)


def test_auto_uses_the_numeric_solver_for_non_puma_arms(ur5):
    q = np.array([0.3, -1.2, 1.4, -0.5, 0.8, 0.1])
    pose = K.fk(ur5, q)
    back = K.ik(ur5, pose, q_seed=q + 0.05)
    np.testing.assert_allclose(K.fk(ur5, back), pose, atol=1e-9)
    np.testing.assert_allclose(back, q, atol=1e-6)  # from a near seed: the nearby solution
    with pytest.raises(KinematicsError, match="configuration"):
        K.ik(ur5, pose, config="run")


def test_unreachable_pose_is_refused(ur5):
    with pytest.raises(KinematicsError, match="did not converge"):
        K.ik(ur5, homogeneous(np.eye(3), [2.5, 0.0, 0.3]), restarts=2)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-4, 0.5, 2.0, np.pi - 1e-4, np.pi - 1e-9, np.pi])
def test_rotation_vector_inverts_rodrigues(angle):
    rng = np.random.default_rng(7)
    for _ in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        v = rotation_vector(rot_axis(axis, angle))
        if angle > np.pi - 1e-6:  # θk and −θk name the same rotation at π
            v = v if v @ axis >= 0 else -v
        np.testing.assert_allclose(v, angle * axis, atol=1e-9 if angle > np.pi - 1e-3 else 1e-14)


def test_pose_error_is_zero_only_at_the_target(puma):
    T = K.fk(puma, np.full(6, 0.3))
    np.testing.assert_allclose(pose_error(T, T), 0.0, atol=1e-15)
    moved = homogeneous(rot_axis([0.0, 0.0, 1.0], 0.2), [0.1, 0.0, 0.0]) @ T
    e = pose_error(T, moved)
    np.testing.assert_allclose(e[3:], [0.0, 0.0, 0.2], atol=1e-12)
