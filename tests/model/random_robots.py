"""Random robots for the model and controller tests: generic serial chains (random joint axes
and tree placements, some prismatic joints, physically consistent inertias, random flange and
tool) and random physically consistent inertial parameters. A module of its own (not a
conftest) so that other test folders can import it by a name no other folder uses."""
from __future__ import annotations

import numpy as np

from rtctl.model import PRISMATIC, REVOLUTE, Model
from rtctl.model.dh import inertial_params
from rtctl.model.rotations import homogeneous, rot_axis


def random_rotation(rng) -> np.ndarray:
    axis = rng.normal(size=3)
    return rot_axis(axis / np.linalg.norm(axis), rng.uniform(-np.pi, np.pi))


def random_params(rng) -> np.ndarray:
    """Physically consistent parameters: m > 0 and principal moments from positive second
    moments of the mass distribution (so the triangle inequality holds)."""
    m = rng.uniform(0.5, 5.0)
    second = rng.uniform(0.002, 0.05, size=3) * m
    principal = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    R = random_rotation(rng)
    return inertial_params(m, rng.uniform(-0.3, 0.3, size=3), R @ np.diag(principal) @ R.T)


def make_random_chain(n: int, seed: int, prismatic: bool = True) -> Model:
    rng = np.random.default_rng(seed)
    types = np.full(n, REVOLUTE, dtype=np.int64)
    if prismatic and n > 1:
        types[rng.choice(n, size=max(1, n // 4), replace=False)] = PRISMATIC
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return Model(
        name=f"random{n}_{seed}",
        joint_names=tuple(f"j{i + 1}" for i in range(n)),
        joint_types=types,
        parent=np.arange(n, dtype=np.int64) - 1,
        axis=axes,
        R_tree=np.array([random_rotation(rng) for _ in range(n)]),
        p_tree=rng.uniform(-0.5, 0.5, size=(n, 3)),
        params=np.array([random_params(rng) for _ in range(n)]),
        q_min=np.full(n, -2.0), q_max=np.full(n, 2.0),
        flange=homogeneous(random_rotation(rng), rng.uniform(-0.2, 0.2, 3)),
        tool=homogeneous(random_rotation(rng), rng.uniform(-0.2, 0.2, 3)),
    )
