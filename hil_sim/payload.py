"""A payload at the flange that the controller's model does not know (``[sim] payload``).

The embedded plant folds it into the last link's inertial parameters (:func:`fold_payload`); the
MuJoCo plant adds it as a body of its own welded at the flange (:mod:`hil_sim.mujoco_model`), so
the two are computed independently and a test compares them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Payload:
    """A rigid body fixed to the flange: ``mass`` (kg), centre of mass ``com`` (m, flange frame) and
    ``inertia`` about it [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (kg·m², flange frame)."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def inertia_matrix(self) -> np.ndarray:
        Ixx, Iyy, Izz, Ixy, Ixz, Iyz = self.inertia
        return np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]], float)

    @classmethod
    def from_table(cls, t) -> "Payload":
        """``payload = { mass = 2.0, com = [0, 0, 0.05], inertia = [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] }``
        (inertia about the centre of mass; default: a point mass)."""
        p = cls(t.float("mass", positive=True), t.vector("com", 3, [0.0, 0.0, 0.0]),
                t.vector("inertia", 6, [0.0] * 6))
        moments = np.linalg.eigvalsh(p.inertia_matrix())
        if moments.min() < 0 or 2 * moments.max() > moments.sum() + 1e-12:
            raise t.error("inertia", f"the inertia of a rigid body (principal moments ≥ 0, each at most the sum of "
                                     f"the other two), got moments {np.round(moments, 6).tolist()}")
        t.done()
        return p


def fold_payload(model, payload: Payload):
    """``model`` with ``payload`` added to its last link's 10 inertial parameters (body frame, about
    the body origin): the flange places the payload's frame in the last body."""
    R, p = model.flange[:3, :3], model.flange[:3, 3]
    m = payload.mass
    c = R @ payload.com + p
    J = R @ payload.inertia_matrix() @ R.T + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    params = np.array(model.params, float)
    params[-1] += [m, *(m * c), J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]]
    return model.with_params(params)
