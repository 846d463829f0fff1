"""The drive train a controller may compensate as known: reflected rotor inertia and friction."""
from __future__ import annotations

import math

from rtctl.compiled import leaf


@leaf
def motor_feedforward_add(qd, qddr, armature, viscous, coulomb, coulomb_velocity, tau):
    """τ += armature q̈_r + viscous q̇ + coulomb tanh(q̇ / v_c): the known drive train.
    Armature adds a constant diagonal to H (Ḣ unchanged, so Ḣ − 2C stays skew) and friction
    is cancelled, so the adaptive law's Lyapunov argument is unchanged."""
    for i in range(tau.shape[0]):
        tau[i] += armature[i] * qddr[i] + viscous[i] * qd[i] + coulomb[i] * math.tanh(qd[i] / coulomb_velocity)
