"""Computed torque (inverse dynamics) control:

    τ = H(q) (q̈_d − K_D ė − K_P e) + C(q, q̇) q̇ + G(q)  [+ armature q̈* + friction]
      = RNEA(q, q̇, q̈*),   q̈* = q̈_d − K_D (q̇ − q̇_d) − K_P (q − q_d)

With the exact model the closed loop is linear and decoupled: ë + K_D ė + K_P e = 0, so
K_P = ω², K_D = 2ζω give a chosen bandwidth per joint. ``motor_model = true`` adds the
robot file's armature and friction (what the drive train costs) to the feed-forward.
"""
from __future__ import annotations

import numpy as np

from rtctl.control.base import Controller
from rtctl.control.gains import per_joint
from rtctl.model.dynamics import Data, model_arrays, rnea_into


class ComputedTorque(Controller):
    def __init__(self, name, model, kp, kd, joints=None, divisor=1, motor_model=True, coulomb_velocity=0.01):
        super().__init__(name, model, joints, divisor)
        self.kp, self.kd = np.asarray(kp, float), np.asarray(kd, float)
        self.arrays, self.data = model_arrays(model), Data(model)
        n = model.nq
        m = model.motors if motor_model else None
        self.armature = m.armature.copy() if m is not None else np.zeros(n)
        self.viscous = m.viscous.copy() if m is not None else np.zeros(n)
        self.coulomb = m.coulomb.copy() if m is not None else np.zeros(n)
        self.coulomb_velocity = coulomb_velocity
        self.qdd_cmd = np.zeros(n)
        self.tau = np.zeros(n)
        self.e = np.zeros(n)
        self.internals = {"qdd_cmd": self.qdd_cmd}

    @classmethod
    def from_config(cls, cfg, model):
        t, n = cfg.options, model.nq
        c = cls(cfg.name, model, per_joint(t, "kp", n), per_joint(t, "kd", n), cfg.joints, cfg.divisor,
                motor_model=t.bool("motor_model", True))
        t.done()
        return c

    def update(self, t, state, ref, command):
        a, e, tau = self.qdd_cmd, self.e, self.tau
        np.subtract(state.position, ref.q, out=e)
        np.multiply(e, self.kp, out=a)
        np.subtract(state.velocity, ref.qd, out=e)
        e *= self.kd
        a += e
        np.subtract(ref.qdd, a, out=a)  # q̈* = q̈_d − K_D ė − K_P e
        rnea_into(self.arrays, self.data, state.position, state.velocity, a, tau)
        np.multiply(self.armature, a, out=e)
        tau += e
        np.multiply(self.viscous, state.velocity, out=e)
        tau += e
        np.divide(state.velocity, self.coulomb_velocity, out=e)
        np.tanh(e, out=e)
        e *= self.coulomb
        tau += e
        self.emit(command.tau_ff, tau)
