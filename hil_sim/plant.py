"""The simulated robot: rigid-body dynamics plus the drive train, integrated in substeps.

    (H(q) + diag(armature)) q̈ = τ_motor − C(q, q̇) q̇ − G(q) − τ_friction
    τ_friction = b q̇ + τ_c · tanh(q̇ / v_c)        (viscous + smoothed Coulomb)

τ_motor is the commanded torque clamped to the drives' limits and held over the period.
Integration is semi-implicit (symplectic) Euler with ``substeps`` per period:
q̇ ← q̇ + h q̈(q, q̇); q ← q + h q̇ — cheap, stable at this stiffness and, with a fixed step,
bit-for-bit reproducible. The whole period is one compiled call (:func:`plant_step`) over
preallocated arrays; :meth:`Plant.step` allocates nothing.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.compiled import kernel
from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.forward_dynamics import forward_dynamics_kernel


@kernel
def plant_step(joint, geom, params, gravity, X, body, Ic, H, q, qd, qdd, tau_cmd, tau_max, tau_applied,
               armature, viscous, coulomb, coulomb_velocity, tau, dt, substeps):
    n = q.shape[0]
    for i in range(n):
        tau_applied[i] = min(max(tau_cmd[i], -tau_max[i]), tau_max[i])
    h = dt / substeps
    for _ in range(substeps):
        for i in range(n):
            tau[i] = (tau_applied[i] - viscous[i] * qd[i]
                      - coulomb[i] * math.tanh(qd[i] / coulomb_velocity))
        forward_dynamics_kernel(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, armature, qdd)
        for i in range(n):
            qd[i] += h * qdd[i]
            q[i] += h * qd[i]


class Plant:
    def __init__(self, model, *, substeps: int = 4, friction_scale: float = 1.0, armature: bool = True,
                 coulomb_velocity: float = 0.01, q0=None):
        self.model = model
        n = model.nq
        self.substeps = int(substeps)
        self.arrays = model_arrays(model)
        self.data = Data(model)
        motors = model.motors
        zeros = np.zeros(n)
        self.armature = motors.armature.copy() if motors is not None and armature else zeros.copy()
        self.viscous = motors.viscous * friction_scale if motors is not None else zeros.copy()
        self.coulomb = motors.coulomb * friction_scale if motors is not None else zeros.copy()
        self.coulomb_velocity = float(coulomb_velocity)
        self.tau_max = np.where(np.isfinite(model.tau_max), model.tau_max, 1e300)
        self.q = np.zeros(n) if q0 is None else np.array(q0, dtype=float)
        self.qd = np.zeros(n)
        self.qdd = np.zeros(n)
        self.tau_cmd = np.zeros(n)  # written by the devices every tick
        self.tau_applied = np.zeros(n)  # what the motors produced (after clamping)
        self._tau = np.zeros(n)
        self.time = 0.0

    def step(self, dt: float) -> None:
        """Advance by ``dt`` with the torques in ``tau_cmd`` held (zero-order hold)."""
        a, d = self.arrays, self.data
        plant_step(a.joint, a.geom, a.params, a.gravity, d.X, d.body, d.Ic, d.H, self.q, self.qd, self.qdd,
                   self.tau_cmd, self.tau_max, self.tau_applied, self.armature, self.viscous, self.coulomb,
                   self.coulomb_velocity, self._tau, dt, self.substeps)
        self.time += dt
