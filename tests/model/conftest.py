"""Shared robots for the model tests: PUMA 560 and the two-link arm (D-H TOML), UR5 and Panda
(URDF from example-robot-data, skipped when it is not installed), random chains, and
Pinocchio twins of them (skipped when ``pin`` is not installed).

Fixtures:
* ``puma``, ``two_link``, ``ur5``, ``panda`` — Models (the Panda's two finger joints are
  locked at 0 and merged into the hand, so it is the 7-joint arm; flange = ``panda_hand``;
  the UR5's flange = ``tool0``, ROS-Industrial's flange frame);
* ``ur5_urdf``, ``panda_urdf`` — paths of the original URDF files;
* ``random_chain(n, seed, prismatic=True)`` — :func:`random_robots.make_random_chain`;
* ``pin`` — the pinocchio module; ``pin_ur5``, ``pin_panda`` — (pin.Model, pin.Data) read by
  Pinocchio from the original files; ``pin_twin(model)`` — (pin.Model, pin.Data) built from
  ``model.to_urdf()``; ``pin_q(pin_model, q)`` — our joint vector in Pinocchio's
  configuration space (continuous joints take (cos q, sin q)).
"""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pytest

from rtctl.model import Model, load_robot

from random_robots import make_random_chain  # noqa: E402  (tests/model is on sys.path)

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "configs" / "robots"


def example_robot_data(relative: str) -> Path:
    """A file of the example-robot-data package, or skip the test saying why."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install example-robot-data)")
    path = Path(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/{relative}"))
    if not path.exists():
        pytest.skip(f"example-robot-data has no {relative}")
    return path


@pytest.fixture(scope="session")
def puma() -> Model:
    return load_robot(ROBOTS / "puma560.toml")


@pytest.fixture(scope="session")
def two_link() -> Model:
    return load_robot(ROBOTS / "two_link.toml")


@pytest.fixture(scope="session")
def ur5_urdf() -> Path:
    return example_robot_data("ur_description/urdf/ur5_robot.urdf")


@pytest.fixture(scope="session")
def panda_urdf() -> Path:
    return example_robot_data("panda_description/urdf/panda.urdf")


PANDA_FINGERS = {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}


@pytest.fixture(scope="session")
def ur5(ur5_urdf) -> Model:
    from rtctl.model.urdf import load_urdf

    return load_urdf(ur5_urdf, flange_link="tool0")


@pytest.fixture(scope="session")
def panda(panda_urdf) -> Model:
    from rtctl.model.urdf import load_urdf

    return load_urdf(panda_urdf, lock=PANDA_FINGERS)


@pytest.fixture(scope="session")
def random_chain():
    return make_random_chain


@pytest.fixture(scope="session")
def pin():
    return pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the reference")


@pytest.fixture(scope="session")
def pin_twin(pin):
    def build(model: Model):
        pmodel = pin.buildModelFromXML(model.to_urdf())
        return pmodel, pmodel.createData()

    return build


def to_pin_q(pmodel, q) -> np.ndarray:
    """Our joint vector in Pinocchio's configuration space (continuous joints: cos, sin)."""
    out = np.zeros(pmodel.nq)
    for joint, value in zip(list(pmodel.joints)[1:], q):
        if joint.nq == 2:
            out[joint.idx_q:joint.idx_q + 2] = np.cos(value), np.sin(value)
        else:
            out[joint.idx_q] = value
    return out


@pytest.fixture(scope="session")
def pin_q():
    return to_pin_q


def random_states(model: Model, count: int, seed: int):
    """Seeded random (q, q̇, q̈) within the joint limits (or ±π where unlimited)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(model.q_min), model.q_min, -np.pi)
    hi = np.where(np.isfinite(model.q_max), model.q_max, np.pi)
    for _ in range(count):
        yield rng.uniform(lo, hi), rng.uniform(-2, 2, model.nq), rng.uniform(-5, 5, model.nq)


@pytest.fixture(scope="session")
def states():
    return random_states


@pytest.fixture(scope="session")
def pin_ur5(pin, ur5_urdf):
    """Pinocchio's own reading of the original UR5 URDF (independent of our loader)."""
    pmodel = pin.buildModelFromUrdf(str(ur5_urdf))
    return pmodel, pmodel.createData()


@pytest.fixture(scope="session")
def pin_panda(pin, panda_urdf):
    """Pinocchio's Panda with the fingers locked at 0, as in the ``panda`` fixture."""
    full = pin.buildModelFromUrdf(str(panda_urdf))
    locked = [full.getJointId(name) for name in PANDA_FINGERS]
    pmodel = pin.buildReducedModel(full, locked, pin.neutral(full))
    return pmodel, pmodel.createData()
