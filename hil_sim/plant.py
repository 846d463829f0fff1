"""The simulated robot: rigid-body dynamics plus the drive train, integrated in substeps.

    (H(q) + diag(armature)) q̈ = τ_motor − C(q, q̇) q̇ − G(q) − τ_friction
    τ_friction = b q̇ + τ_c · tanh(q̇ / v_c)        (viscous + smoothed Coulomb)

τ_motor is the commanded torque clamped to the drives' limits. Integration is semi-implicit
(symplectic) Euler with ``substeps`` per period: q̇ ← q̇ + h q̈(q, q̇); q ← q + h q̇ — cheap,
stable for this stiffness and, with a fixed step, bit-for-bit reproducible. All buffers are
preallocated; :meth:`Plant.step` allocates nothing.
"""
from __future__ import annotations

import numpy as np

from rtctl.model.dynamics import Data, forward_dynamics_into, model_arrays


class Plant:
    def __init__(self, model, *, substeps: int = 4, friction_scale: float = 1.0, armature: bool = True,
                 coulomb_velocity: float = 0.01, q0=None):
        self.model = model
        n = model.nq
        self.substeps = substeps
        self.arrays = model_arrays(model)
        self.data = Data(model)
        motors = model.motors
        zeros = np.zeros(n)
        self.armature = (motors.armature.copy() if motors is not None and armature else zeros.copy())
        self.viscous = (motors.viscous * friction_scale if motors is not None else zeros.copy())
        self.coulomb = (motors.coulomb * friction_scale if motors is not None else zeros.copy())
        self.coulomb_velocity = coulomb_velocity
        self.tau_max = np.where(np.isfinite(model.tau_max), model.tau_max, 1e300)
        self.q = np.zeros(n) if q0 is None else np.array(q0, dtype=float)
        self.qd = np.zeros(n)
        self.qdd = np.zeros(n)
        self.tau_cmd = np.zeros(n)  # written by the devices every tick
        self.tau_applied = np.zeros(n)  # what the motors produced (after clamping)
        self._tau = np.zeros(n)
        self._tmp = np.zeros(n)
        self.time = 0.0

    def step(self, dt: float) -> None:
        """Advance by ``dt`` with the torques in ``tau_cmd`` held constant (zero-order hold)."""
        np.clip(self.tau_cmd, -self.tau_max, self.tau_max, out=self.tau_applied)
        h = dt / self.substeps
        for _ in range(self.substeps):
            # τ = τ_motor − b q̇ − τ_c tanh(q̇ / v_c)
            np.divide(self.qd, self.coulomb_velocity, out=self._tmp)
            np.tanh(self._tmp, out=self._tmp)
            np.multiply(self._tmp, self.coulomb, out=self._tmp)
            np.subtract(self.tau_applied, self._tmp, out=self._tau)
            np.multiply(self.qd, self.viscous, out=self._tmp)
            np.subtract(self._tau, self._tmp, out=self._tau)
            forward_dynamics_into(self.arrays, self.data, self.q, self.qd, self._tau, self.armature, self.qdd)
            np.multiply(self.qdd, h, out=self._tmp)
            self.qd += self._tmp
            np.multiply(self.qd, h, out=self._tmp)
            self.q += self._tmp
        self.time += dt
