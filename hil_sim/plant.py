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
from numba import njit

from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.forward_dynamics import forward_dynamics_kernel


@njit(cache=True)
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


@njit(cache=True)
def _acceleration(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau_applied, armature, viscous, coulomb,
                  coulomb_velocity, tau, qdd):
    for i in range(q.shape[0]):
        tau[i] = tau_applied[i] - viscous[i] * qd[i] - coulomb[i] * math.tanh(qd[i] / coulomb_velocity)
    forward_dynamics_kernel(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, armature, qdd)


@njit(cache=True)
def plant_step_rk4(joint, geom, params, gravity, X, body, Ic, H, q, qd, qdd, tau_cmd, tau_max, tau_applied,
                   armature, viscous, coulomb, coulomb_velocity, tau, dt, substeps, stage):
    """As :func:`plant_step` with classical RK4 steps; ``stage``: scratch (4, n) for the stage
    position, velocity and the accumulated increments."""
    n = q.shape[0]
    for i in range(n):
        tau_applied[i] = min(max(tau_cmd[i], -tau_max[i]), tau_max[i])
    h = dt / substeps
    qs, vs, dq, dv = stage[0], stage[1], stage[2], stage[3]
    weights = (1.0, 2.0, 2.0, 1.0)
    offsets = (0.5, 0.5, 1.0)
    for _ in range(substeps):
        for i in range(n):
            qs[i], vs[i], dq[i], dv[i] = q[i], qd[i], 0.0, 0.0
        for s in range(4):
            _acceleration(joint, geom, params, gravity, X, body, Ic, H, qs, vs, tau_applied, armature, viscous,
                          coulomb, coulomb_velocity, tau, qdd)
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
                 coulomb_velocity: float = 0.01, q0=None, integrator: str = "euler"):
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
        self.model = model
        n = model.nq
        self.integrator = integrator
        self._stage = np.zeros((4, n))
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
        if self.integrator == "rk4":
            plant_step_rk4(a.joint, a.geom, a.params, a.gravity, d.X, d.body, d.Ic, d.H, self.q, self.qd, self.qdd,
                           self.tau_cmd, self.tau_max, self.tau_applied, self.armature, self.viscous, self.coulomb,
                           self.coulomb_velocity, self._tau, dt, self.substeps, self._stage)
        else:
            plant_step(a.joint, a.geom, a.params, a.gravity, d.X, d.body, d.Ic, d.H, self.q, self.qd, self.qdd,
                       self.tau_cmd, self.tau_max, self.tau_applied, self.armature, self.viscous, self.coulomb,
                       self.coulomb_velocity, self._tau, dt, self.substeps)
        self.time += dt
