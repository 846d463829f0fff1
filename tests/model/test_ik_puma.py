"""Closed-form PUMA inverse kinematics: F∘IK = identity for every solution, the original joint
angles among the solutions, branch selection, and what the branch labels mean geometrically."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rtctl.errors import KinematicsError
from rtctl.model import load_robot
from rtctl.model import kinematics as K
from rtctl.model.ik_puma import ALL_CONFIGS, Arm, ArmConfig, Elbow, Wrist, configuration, is_puma_type
from rtctl.model.rotations import homogeneous, rot_axis

ROBOTS = Path(__file__).resolve().parents[2] / "configs" / "robots"


@pytest.fixture(scope="module")
def table1():
    return load_robot(ROBOTS / "table1_arm.toml")


@pytest.fixture(params=["puma", "table1"])
def arm(request):
    return request.getfixturevalue(request.param)


def random_qs(model, count, seed):
    rng = np.random.default_rng(seed)
    return [rng.uniform(model.q_min, model.q_max) for _ in range(count)]


def angle_error(a, b) -> float:
    return float(np.max(np.abs(np.remainder(np.asarray(a) - b + np.pi, 2 * np.pi) - np.pi)))


def test_structure_detection(puma, table1, ur5, panda, random_chain):
    assert is_puma_type(puma) and is_puma_type(table1)
    assert not is_puma_type(ur5) and not is_puma_type(panda) and not is_puma_type(random_chain(6, seed=1))
    with pytest.raises(KinematicsError, match="PUMA-type"):
        K.ik_solutions(ur5, K.fk(ur5, np.zeros(6)))


def test_every_solution_maps_back_and_the_original_is_among_them(arm):
    for q in random_qs(arm, 300, seed=1):
        pose = K.fk(arm, q)
        solutions = K.ik_solutions(arm, pose)
        assert len(solutions) == 8
        assert sorted(str(s.config) for s in solutions) == sorted(str(c) for c in ALL_CONFIGS)
        for s in solutions:
            np.testing.assert_allclose(K.fk(arm, s.q), pose, atol=1e-9)
            assert np.all(s.q > -np.pi) and np.all(s.q <= np.pi)
        assert min(angle_error(s.q, q) for s in solutions) < 1e-9


def test_tool_frame_is_accounted_for(puma):
    tool = homogeneous(rot_axis([0.0, 0.6, 0.8], 0.7), [0.02, -0.05, 0.25])  # a long, tilted torch
    tooled = puma.with_tool(tool)
    for q in random_qs(puma, 100, seed=3):
        pose = K.fk(tooled, q)
        solutions = K.ik_solutions(tooled, pose)
        for s in solutions:
            np.testing.assert_allclose(K.fk(tooled, s.q), pose, atol=1e-9)
        assert min(angle_error(s.q, q) for s in solutions) < 1e-9


def test_configuration_selects_the_branch_of_the_original(arm):
    for q in random_qs(arm, 200, seed=4):
        config = configuration(arm, q)
        back = K.ik(arm, K.fk(arm, q), config=config, within_limits=False)
        assert angle_error(back, q) < 1e-9


def test_each_requested_branch_is_returned(arm):
    q = np.radians([30.0, 40.0, -70.0, 50.0, 35.0, 20.0])
    pose = K.fk(arm, q)
    seen = set()
    for config in ALL_CONFIGS:
        sol = K.ik(arm, pose, config=config, within_limits=False)
        np.testing.assert_allclose(K.fk(arm, sol), pose, atol=1e-9)
        assert configuration(arm, sol) == config
        seen.add(tuple(np.round(sol, 9)))
    assert len(seen) == 8
    assert K.ik(arm, pose, config="lun", within_limits=False) is not None
    with pytest.raises(ValueError):
        ArmConfig.parse("xyz")


def test_labels_mean_what_they_say(arm):
    """Right arm: seen from above with the wrist ahead, the shoulder offset points right.
    Elbow up: the elbow is on the arm's upper side of the shoulder-wrist line. Noflip:
    sin θ5 ≥ 0. Checked from link positions, independently of the solver's formulas."""
    z0 = np.array([0.0, 0.0, 1.0])
    checked = 0
    for q in random_qs(arm, 200, seed=5):
        poses = K.link_poses(arm, q)
        shoulder, elbow, wrist = poses[1][:3, 3], poses[2][:3, 3], poses[4][:3, 3]
        z1 = poses[1][:3, 2]  # the shoulder axis (horizontal)
        offset = ((wrist - shoulder) @ z1) * z1  # the shoulder offset: waist axis → arm plane
        ahead = wrist - offset  # the arm's forward reach, seen from above
        ahead[2] = 0.0
        if np.linalg.norm(ahead) < 1e-3:
            continue
        right = np.cross(ahead, z0)
        upward = np.cross(right, wrist - shoulder)  # in the arm plane, ⟂ the shoulder-wrist line
        config = configuration(arm, q)
        assert (config.arm == Arm.RIGHT) == (offset @ right > 0)
        assert (config.elbow == Elbow.UP) == ((elbow - shoulder) @ upward > 0)
        assert (config.wrist == Wrist.NOFLIP) == (np.sin(q[4] + arm.dh.theta0[4]) >= 0)
        checked += 1
    assert checked > 150


def test_seed_picks_the_nearest_solution_within_limits(arm):
    """A seed next to q gives q back (branches can pass within 0.01 rad of each other where
    the arm or elbow is near its boundary, so the seed is 1e-6 away); and in general the answer
    is the in-limits solution nearest the seed."""
    rng = np.random.default_rng(6)
    for q in random_qs(arm, 100, seed=6):
        pose = K.fk(arm, q)
        back = K.ik(arm, pose, q_seed=q + 1e-6)
        np.testing.assert_allclose(back, q, atol=1e-9)
        seed = q + rng.uniform(-0.5, 0.5, 6)
        back = K.ik(arm, pose, q_seed=seed)
        assert np.all(back >= arm.q_min) and np.all(back <= arm.q_max)
        candidates = K.ik_solutions(arm, pose, q_seed=seed, within_limits=True)
        assert np.sum(np.abs(back - seed)) == min(np.sum(np.abs(s.q - seed)) for s in candidates)


def test_without_seed_the_answer_is_within_limits(arm):
    for q in random_qs(arm, 50, seed=7):
        pose = K.fk(arm, q)
        back = K.ik(arm, pose)
        np.testing.assert_allclose(K.fk(arm, back), pose, atol=1e-9)
        assert np.all(back >= arm.q_min) and np.all(back <= arm.q_max)


def test_wrist_singularity(arm):
    """q5 = 0: axes 4 and 6 align, only q4 + q6 counts; the seed's q4 is kept."""
    q = np.radians([10.0, 20.0, -40.0, 30.0, 0.0, 25.0]) - np.r_[0, 0, 0, 0, arm.dh.theta0[4], 0]
    pose = K.fk(arm, q)
    for s in K.ik_solutions(arm, pose, q_seed=np.radians([0, 0, 0, 50.0, 0, 0])):
        np.testing.assert_allclose(K.fk(arm, s.q), pose, atol=1e-9)
    back = K.ik(arm, pose, q_seed=np.radians([10.0, 20.0, -40.0, 50.0, 0.0, 0.0]))
    assert back[3] == pytest.approx(np.radians(50.0), abs=1e-12)
    np.testing.assert_allclose(K.fk(arm, back), pose, atol=1e-9)


def test_unreachable_poses_are_refused(arm):
    far = homogeneous(np.eye(3), [3.0, 0.0, 0.5])
    with pytest.raises(KinematicsError, match="out of reach"):
        K.ik(arm, far)
    # The wrist centre inside the cylinder the shoulder offset sweeps around the waist axis.
    offset = abs(arm.dh.d[1] + arm.dh.d[2])
    wrist_centre = homogeneous(np.eye(3), [0.3 * offset, 0.0, 0.3])
    pose = wrist_centre @ arm.flange @ arm.tool
    with pytest.raises(KinematicsError, match="shoulder-offset cylinder"):
        K.ik(arm, pose)


def test_no_branch_within_limits_is_reported(puma):
    q = np.radians([0.0, 45.0, -90.0, 0.0, 45.0, 0.0])
    lo, hi = puma.q_min.copy(), puma.q_max.copy()
    lo[0], hi[0] = -0.1, 0.1
    narrowed = replace(puma, q_min=lo, q_max=hi)
    pose = K.fk(narrowed, q)
    with pytest.raises(KinematicsError, match="configuration"):
        K.ik(narrowed, pose, config="lun")  # the left arm turns the waist by about 180°
    np.testing.assert_allclose(K.ik(narrowed, pose, config=configuration(puma, q)), q, atol=1e-9)
