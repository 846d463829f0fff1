"""The shipped PUMA 560 zones cover the configurations their comments describe: re-derived here
from the forward kinematics with the collision model stated in configs/robots/puma560.toml
(and the overhead conveyor of configs/puma560_guard_sim.toml), on a grid offset from the one
they were drawn from. The shipped trajectories and starts stay clear."""
import numpy as np
import pytest

from guard_helpers import ROOT
from rtctl.config import load_config
from rtctl.guard import point_violation
from rtctl.guard.kernels import clearances
from rtctl.model import load_robot
from rtctl.model.kinematics import link_poses

H, R_COLUMN, Z_COLUMN_TOP, R_ARM, WRIST_LOW, Z_CONVEYOR = 0.672, 0.20, -0.15, 0.06, 0.12, 1.40 - 0.672
CONFIGS = ROOT / "configs"


def sampled_collisions(step=1.5):
    model = load_robot(CONFIGS / "robots" / "puma560.toml")
    q2s = np.arange(-45.0 + 0.25, 225.0, step)
    q3s = np.arange(-225.0 + 0.25, 45.0, step)
    Q = np.zeros((len(q2s) * len(q3s), 6))
    Q[:, 1] = np.radians(np.repeat(q2s, len(q3s)))
    Q[:, 2] = np.radians(np.tile(q3s, len(q2s)))
    A, W = np.empty((len(Q), 3)), np.empty((len(Q), 3))
    for k, q in enumerate(Q):
        P = link_poses(model, q)
        A[k], W[k] = P[3][:3, 3], P[4][:3, 3]  # the forearm runs from body 3's origin to the wrist centre
    s = np.linspace(0.0, 1.0, 21)[None, :, None]
    X = A[:, None] + s * (W - A)[:, None]
    pedestal = np.any((np.hypot(X[..., 0], X[..., 1]) < R_COLUMN + R_ARM) & (X[..., 2] < Z_COLUMN_TOP + R_ARM), axis=1)
    floor = W[:, 2] < -H + WRIST_LOW
    conveyor = W[:, 2] > Z_CONVEYOR - WRIST_LOW
    return Q, pedestal, floor, conveyor


@pytest.fixture(scope="module")
def sampled():
    return sampled_collisions()


def test_the_robot_zones_cover_the_pedestal_and_floor_collisions(sampled):
    Q, pedestal, floor, _ = sampled
    scene = load_config(CONFIGS / "puma560_sim.toml").guard.scene
    depth = np.empty(len(Q))
    clearances(*scene.tables(), Q, depth)
    assert pedestal.sum() > 1000 and floor.sum() > 1000  # the model does produce collisions
    assert np.all(depth[pedestal | floor] < 0), np.degrees(Q[(pedestal | floor) & (depth >= 0)][:5, 1:3])
    # …and they are not wildly larger than the collisions (the slack is the drawing's 1–4°)
    inside = depth < 0
    print(f"zones {inside.mean():.3f} of the plane, collisions {(pedestal | floor).mean():.3f}")
    assert inside.sum() < 1.25 * (pedestal | floor).sum()


def test_the_conveyor_zone_covers_its_collisions(sampled):
    Q, pedestal, floor, conveyor = sampled
    scene = load_config(CONFIGS / "puma560_guard_sim.toml").guard.scene
    depth = np.empty(len(Q))
    clearances(*scene.tables(), Q, depth)
    assert conveyor.sum() > 1000 and np.all(depth[conveyor] < 0)


@pytest.mark.parametrize("name", ["puma560_sim.toml", "puma560_cstar_sim.toml", "puma560_hil_socketcand.toml",
                                  "puma560_guard_sim.toml"])
def test_shipped_starts_and_waypoints_are_clear(name):
    cfg = load_config(CONFIGS / name)  # waypoints inside a zone would not even load
    start = cfg.sim.data.get("initial_q", np.zeros(6)) if cfg.sim is not None else np.zeros(6)
    assert point_violation(cfg.guard.scene, start) is None
