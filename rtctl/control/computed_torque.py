"""Computed torque (inverse dynamics) control:

    q̈* = q̈_d − K_D (q̇ − q̇_d) − K_P (q − q_d)
    τ  = H(q) q̈* + C(q, q̇) q̇ + G(q) = RNEA(q, q̇, q̈*)   [+ armature q̈* + friction(q̇)]

With the exact model the closed loop is linear and decoupled, ë + K_D ė + K_P e = 0, so
K_P = ω², K_D = 2ζω set a bandwidth per joint. ``motor_model = true`` (default) adds the
robot file's armature and friction — what the drive train costs — to the feed-forward.
One compiled call per tick (:func:`computed_torque_kernel`), no allocation.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel
from rtctl.control.base import Controller
from rtctl.control.gains import per_joint
from rtctl.control.motor import motor_feedforward_add
from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.rnea import rnea_kernel


@kernel
def computed_torque_kernel(joint, geom, params, gravity, X, body, q, qd, q_d, qd_d, qdd_d, kp, kd,
                           armature, viscous, coulomb, coulomb_velocity, a, tau):
    n = q.shape[0]
    for i in range(n):
        a[i] = qdd_d[i] - kd[i] * (qd[i] - qd_d[i]) - kp[i] * (q[i] - q_d[i])
    rnea_kernel(joint, geom, params, gravity, X, body, q, qd, a, tau)
    motor_feedforward_add(qd, a, armature, viscous, coulomb, coulomb_velocity, tau)


class ComputedTorque(Controller):
    def __init__(self, name, model, kp, kd, joints=None, divisor=1, motor_model=True, coulomb_velocity=0.01):
        super().__init__(name, model, joints, divisor)
        n = model.nq
        self.kp = np.broadcast_to(np.asarray(kp, float), (n,)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, float), (n,)).copy()
        self.arrays, self.data = model_arrays(model), Data(model)
        m = model.motors if motor_model else None
        self.armature = m.armature.copy() if m is not None else np.zeros(n)
        self.viscous = m.viscous.copy() if m is not None else np.zeros(n)
        self.coulomb = m.coulomb.copy() if m is not None else np.zeros(n)
        self.coulomb_velocity = float(coulomb_velocity)
        self.qdd_cmd = np.zeros(n)
        self.tau = np.zeros(n)
        self.internals = {"qdd_cmd": self.qdd_cmd}

    @classmethod
    def from_config(cls, cfg, model):
        t, n = cfg.options, model.nq
        c = cls(cfg.name, model, per_joint(t, "kp", n), per_joint(t, "kd", n), cfg.joints, cfg.divisor,
                motor_model=t.bool("motor_model", True))
        t.done()
        return c

    def update(self, t, state, ref, command):
        a, d = self.arrays, self.data
        computed_torque_kernel(a.joint, a.geom, a.params, a.gravity, d.X, d.body, state.position, state.velocity,
                               ref.q, ref.qd, ref.qdd, self.kp, self.kd, self.armature, self.viscous,
                               self.coulomb, self.coulomb_velocity, self.qdd_cmd, self.tau)
        self.emit(command.tau_ff, self.tau)
