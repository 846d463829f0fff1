"""Joint PD with gravity compensation: τ = G(q) − K_P (q − q_d) − K_D (q̇ − q̇_d).

The baseline every robot controller offers (Takegaki & Arimoto 1981): globally
asymptotically stable for a constant target with the exact G; it lags a moving reference,
which computed torque and the adaptive laws then improve on.
"""
from __future__ import annotations

import numpy as np

from rtctl.control.base import Controller
from rtctl.control.gains import per_joint
from rtctl.model.dynamics import Data, gravity_into, model_arrays


class PDGravity(Controller):
    def __init__(self, name, model, kp, kd, joints=None, divisor=1):
        super().__init__(name, model, joints, divisor)
        self.kp, self.kd = np.asarray(kp, float), np.asarray(kd, float)
        self.arrays, self.data = model_arrays(model), Data(model)
        self.g = np.zeros(model.nq)
        self.e = np.zeros(model.nq)
        self.tau = np.zeros(model.nq)
        self.internals = {"gravity": self.g}

    @classmethod
    def from_config(cls, cfg, model):
        t, n = cfg.options, model.nq
        c = cls(cfg.name, model, per_joint(t, "kp", n), per_joint(t, "kd", n), cfg.joints, cfg.divisor)
        t.done()
        return c

    def update(self, t, state, ref, command):
        gravity_into(self.arrays, self.data, state.position, self.g)
        tau, e = self.tau, self.e
        np.subtract(ref.q, state.position, out=e)
        np.multiply(e, self.kp, out=tau)
        tau += self.g
        np.subtract(ref.qd, state.velocity, out=e)
        e *= self.kd
        tau += e
        self.emit(command.tau_ff, tau)
