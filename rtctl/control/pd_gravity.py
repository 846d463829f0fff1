"""Joint PD with gravity compensation: τ = G(q) − K_P (q − q_d) − K_D (q̇ − q̇_d).

The baseline every robot controller offers (Takegaki & Arimoto 1981): globally
asymptotically stable for a constant target with the exact G; it lags a moving reference,
which computed torque and the adaptive laws then improve on. One compiled call per tick
(:func:`pd_gravity_kernel`), no allocation.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel
from rtctl.control.base import Controller, emit_owned
from rtctl.control.gains import per_joint
from rtctl.control.tunable import Tunable
from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.rnea import rnea_kernel


@kernel
def pd_gravity_kernel(joint, geom, params, gravity, X, body, zero, q, qd, ref, kp, kd, g, tau, mask, tau_out):
    """G(q) into ``g`` (RNEA at q̇ = q̈ = 0), then τ = G − K_P (q − q_d) − K_D (q̇ − q̇_d) with
    q_d, q̇_d the rows 0, 1 of ``ref``, and the owned joints' τ into ``tau_out``."""
    rnea_kernel(joint, geom, params, gravity, X, body, q, zero, zero, g)
    for i in range(q.shape[0]):
        tau[i] = g[i] + kp[i] * (ref[0, i] - q[i]) + kd[i] * (ref[1, i] - qd[i])
    emit_owned(mask, tau, tau_out)


class PDGravity(Controller):
    def __init__(self, name, model, kp, kd, joints=None, divisor=1):
        super().__init__(name, model, joints, divisor)
        n = model.nq
        self.kp = np.broadcast_to(np.asarray(kp, float), (n,)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, float), (n,)).copy()
        self.arrays, self.data = model_arrays(model), Data(model)
        self.g = np.zeros(n)
        self.tau = np.zeros(n)
        self.internals = {"gravity": self.g}

    @classmethod
    def from_config(cls, cfg, model):
        t, n = cfg.options, model.nq
        c = cls(cfg.name, model, per_joint(t, "kp", n), per_joint(t, "kd", n), cfg.joints, cfg.divisor)
        t.done()
        return c

    def tunables(self) -> dict:
        n = self.model.nq
        return {"kp": Tunable(self.kp, lambda t, k: per_joint(t, k, n)),
                "kd": Tunable(self.kd, lambda t, k: per_joint(t, k, n))}

    def update(self, t, state, ref, command):
        a, d = self.arrays, self.data
        pd_gravity_kernel(a.joint, a.geom, a.params, a.gravity, d.X, d.body, d.zero, state.position,
                          state.velocity, ref.packed, self.kp, self.kd, self.g, self.tau, self.mask, command.tau_ff)
