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
from rtctl.control.base import Controller, emit_owned
from rtctl.control.gains import per_joint
from rtctl.control.motor import motor_feedforward_add
from rtctl.control.tunable import Tunable
from rtctl.model.dynamics import Data, model_arrays
from rtctl.model.rnea import rnea_kernel
from rtctl.model.robot import COULOMB_VELOCITY


KP, KD, ARMATURE, VISCOUS, COULOMB = range(5)  # gains (5, n)
QDD_CMD, TAU = range(2)  # signals (2, n)


@kernel
def computed_torque_kernel(joint, geom, params, gravity, X, body, q, qd, ref, gains, coulomb_velocity, signals, mask,
                           tau_out):
    """The tick in one call: q̈* from ``ref`` (rows q_d, q̇_d, q̈_d), τ = RNEA(q, q̇, q̈*) plus the drive
    train, and the owned joints' τ into ``tau_out`` (arrays packed: each one handed over costs ~60 ns)."""
    a, tau = signals[QDD_CMD], signals[TAU]
    kp, kd = gains[KP], gains[KD]
    for i in range(q.shape[0]):
        a[i] = ref[2, i] - kd[i] * (qd[i] - ref[1, i]) - kp[i] * (q[i] - ref[0, i])
    rnea_kernel(joint, geom, params, gravity, X, body, q, qd, a, tau)
    motor_feedforward_add(qd, a, gains[ARMATURE], gains[VISCOUS], gains[COULOMB], coulomb_velocity, tau)
    emit_owned(mask, tau, tau_out)


class ComputedTorque(Controller):
    """τ = RNEA(q, q̇, q̈_d − K_d (q̇ − q̇_d) − K_p (q − q_d)), plus the drive train. Options:
    ``kp``, ``kd`` (one number or one per joint, ≥ 0); ``motor_model`` (default true: the robot
    file's armature and friction as feed-forward)."""

    def __init__(self, name, model, kp, kd, joints=None, divisor=1, motor_model=True,
                 coulomb_velocity=COULOMB_VELOCITY):
        super().__init__(name, model, joints, divisor)
        n = model.nq
        self.gains = np.zeros((5, n))
        self.gains[KP], self.gains[KD] = kp, kd
        self.kp, self.kd = self.gains[KP], self.gains[KD]
        self.arrays, self.data = model_arrays(model), Data(model)
        m = model.motors if motor_model else None
        if m is not None:
            self.gains[ARMATURE], self.gains[VISCOUS], self.gains[COULOMB] = m.armature, m.viscous, m.coulomb
        self.coulomb_velocity = float(coulomb_velocity)
        self.signals = np.zeros((2, n))
        self.qdd_cmd, self.tau = self.signals
        self.internals = {"qdd_cmd": self.qdd_cmd}

    @classmethod
    def from_config(cls, cfg, model):
        t, n = cfg.options, model.nq
        c = cls(cfg.name, model, per_joint(t, "kp", n), per_joint(t, "kd", n), cfg.joints, cfg.divisor,
                motor_model=t.bool("motor_model", True))
        t.done()
        return c

    def tunables(self) -> dict:
        n = self.model.nq
        return {"kp": Tunable(self.kp, lambda t, k: per_joint(t, k, n)),
                "kd": Tunable(self.kd, lambda t, k: per_joint(t, k, n))}

    def update(self, t, state, ref, command):
        a, d = self.arrays, self.data
        computed_torque_kernel(a.joint, a.geom, a.params, a.gravity, d.X, d.body, state.position, state.velocity,
                               ref.packed, self.gains, self.coulomb_velocity, self.signals, self.mask, command.tau_ff)
