"""The simulated robot: rigid-body dynamics plus the drive train, integrated in substeps.

    (H(q) + diag(armature)) q̈ = τ_motor − C(q, q̇) q̇ − G(q) − τ_friction
    τ_friction = b q̇ + τ_c · tanh(q̇ / v_c)        (viscous + smoothed Coulomb)

τ_motor is the commanded torque clamped to the drives' limits and held over the period.
Integration (``integrator``), with ``substeps`` fixed steps h per period, bit-for-bit reproducible:

* ``"euler"`` (default): semi-implicit (symplectic) Euler, q̇ ← q̇ + h q̈(q, q̇); q ← q + h q̇ —
  cheap and stable at this stiffness (:func:`plant_step`);
* ``"rk4"``: the classical fourth-order Runge–Kutta method on (q, q̇), four dynamics evaluations
  per step, for studies that need accurate trajectories (:func:`plant_step_rk4`).

The whole period is one compiled call over preallocated arrays; :meth:`Plant.step` allocates nothing.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.compiled import kernel
from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.forward_dynamics import forward_dynamics_kernel
from rtctl.model.robot import COULOMB_VELOCITY


# The plant's per-joint vectors are the rows of one array, so that a period is one compiled call
# with a dozen arguments rather than twenty (each array argument costs the call from Python).
ROWS = ("q", "qd", "qdd", "tau_cmd", "tau_max", "tau_applied", "armature", "viscous", "coulomb", "tau")
Q, QD, QDD, TAU_CMD, TAU_MAX, TAU_APPLIED, ARMATURE, VISCOUS, COULOMB, TAU = range(len(ROWS))


@kernel
def _acceleration(joint, geom, params, gravity, X, body, Ic, H, rows, q, qd, coulomb_velocity):
    """q̈ of the plant at (q, q̇) under the held motor torque, into ``rows[QDD]``."""
    tau, tau_applied, viscous, coulomb = rows[TAU], rows[TAU_APPLIED], rows[VISCOUS], rows[COULOMB]
    for i in range(q.shape[0]):
        tau[i] = tau_applied[i] - viscous[i] * qd[i] - coulomb[i] * math.tanh(qd[i] / coulomb_velocity)
    forward_dynamics_kernel(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, rows[ARMATURE], rows[QDD])


@kernel
def plant_step(joint, geom, params, gravity, X, body, Ic, H, rows, coulomb_velocity, dt, substeps):
    """One period of semi-implicit Euler steps; ``rows``: the plant's vectors (``ROWS``)."""
    q, qd, qdd, tau = rows[Q], rows[QD], rows[QDD], rows[TAU]
    tau_applied, viscous, coulomb = rows[TAU_APPLIED], rows[VISCOUS], rows[COULOMB]
    n = q.shape[0]
    for i in range(n):
        tau_applied[i] = min(max(rows[TAU_CMD, i], -rows[TAU_MAX, i]), rows[TAU_MAX, i])
    h = dt / substeps
    for _ in range(substeps):
        for i in range(n):
            tau[i] = tau_applied[i] - viscous[i] * qd[i] - coulomb[i] * math.tanh(qd[i] / coulomb_velocity)
        forward_dynamics_kernel(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, rows[ARMATURE], qdd)
        for i in range(n):
            qd[i] += h * qdd[i]
            q[i] += h * qd[i]


@kernel
def plant_step_rk4(joint, geom, params, gravity, X, body, Ic, H, rows, coulomb_velocity, dt, substeps, stage):
    """As :func:`plant_step` with classical RK4 steps; ``stage``: scratch (4, n) for the stage
    position, velocity and the accumulated increments."""
    q, qd, qdd = rows[Q], rows[QD], rows[QDD]
    n = q.shape[0]
    for i in range(n):
        rows[TAU_APPLIED, i] = min(max(rows[TAU_CMD, i], -rows[TAU_MAX, i]), rows[TAU_MAX, i])
    h = dt / substeps
    qs, vs, dq, dv = stage[0], stage[1], stage[2], stage[3]
    weights = (1.0, 2.0, 2.0, 1.0)
    offsets = (0.5, 0.5, 1.0)
    for _ in range(substeps):
        for i in range(n):
            qs[i], vs[i], dq[i], dv[i] = q[i], qd[i], 0.0, 0.0
        for s in range(4):
            _acceleration(joint, geom, params, gravity, X, body, Ic, H, rows, qs, vs, coulomb_velocity)
            w = weights[s]
            for i in range(n):
                dq[i] += w * vs[i]
                dv[i] += w * qdd[i]
            if s < 3:
                c = offsets[s] * h
                for i in range(n):
                    qs[i] = q[i] + c * vs[i]
                    vs[i] = qd[i] + c * qdd[i]
        for i in range(n):
            q[i] += h / 6.0 * dq[i]
            qd[i] += h / 6.0 * dv[i]


INTEGRATORS = ("euler", "rk4")


class Plant:
    def __init__(self, model, *, substeps: int = 4, friction_scale: float = 1.0, armature: bool = True,
                 coulomb_velocity: float = COULOMB_VELOCITY, q0=None, integrator: str = "euler"):
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
        self.model = model
        n = model.nq
        self.integrator = integrator
        self._stage = np.zeros((4, n))
        self.substeps = int(substeps)
        self.arrays = model_arrays(model)
        self.data = Data(model)
        self.rows = np.zeros((len(ROWS), n))
        for i, name in enumerate(ROWS):  # each vector a view of its row, for the devices and tests
            setattr(self, name if name != "tau" else "_tau", self.rows[i])
        motors = model.motors
        if motors is not None:
            if armature:
                self.armature[:] = motors.armature
            self.viscous[:] = motors.viscous * friction_scale
            self.coulomb[:] = motors.coulomb * friction_scale
        self.coulomb_velocity = float(coulomb_velocity)
        self.tau_max[:] = np.where(np.isfinite(model.tau_max), model.tau_max, 1e300)
        if q0 is not None:
            self.q[:] = q0
        self.time = 0.0
        a, d = self.arrays, self.data
        self._model_args = (a.joint, a.geom, a.params, a.gravity, d.X, d.body, d.Ic, d.H, self.rows)

    def step(self, dt: float) -> None:
        """Advance by ``dt`` with the torques in ``tau_cmd`` held (zero-order hold)."""
        if self.integrator == "rk4":
            plant_step_rk4(*self._model_args, self.coulomb_velocity, dt, self.substeps, self._stage)
        else:
            plant_step(*self._model_args, self.coulomb_velocity, dt, self.substeps)
        self.time += dt
