"""Closing the loop in-process: a controller's update() against hil_sim's Plant, one plant
period per tick (the embedded simulator's lock-step, without the daemon around it)."""
from __future__ import annotations

import numpy as np

from hil_sim.plant import Plant
from rtctl.control.base import Reference
from rtctl.hal.joints import JointCommand, JointState
from rtctl.model import dynamics as dyn


def cosine_reference(q0, amplitude, omega):
    """q_d = q0 + A (1 − cos ωt) per joint: starts at rest at q0 (the Slotine–Li example's form)."""
    def sample(t, ref):
        c, s = np.cos(omega * t), np.sin(omega * t)
        ref.q[:] = q0 + amplitude * (1 - c)
        ref.qd[:] = amplitude * omega * s
        ref.qdd[:] = amplitude * omega ** 2 * c
    return sample


def run(controller, plant: Plant, reference, seconds: float, dt: float = 1e-3, lyapunov_model=None):
    """Returns (errors (N, n), torques (N, n), V (N,) or None). V = ½ sᵀ H s + ½ π̃ᵀ P⁻¹ π̃ with
    the true H and π of ``lyapunov_model`` (parameters with zero gain never move: left out)."""
    n = plant.model.nq
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    steps = int(round(seconds / dt))
    errors, torques, V = np.zeros((steps, n)), np.zeros((steps, n)), np.zeros(steps)
    active = controller.gamma > 0
    for k in range(steps):
        t = k * dt
        state.position[:], state.velocity[:] = plant.q, plant.qd
        reference(t, ref)
        controller.update(t, state, ref, cmd)
        errors[k], torques[k] = plant.q - ref.q, cmd.tau_ff
        if lyapunov_model is not None:
            s = controller.s
            tilde = (controller.params_hat - lyapunov_model.params)[active]
            V[k] = 0.5 * s @ dyn.mass_matrix(lyapunov_model, plant.q) @ s + 0.5 * np.sum(tilde ** 2 / controller.gamma[active])
        plant.tau_cmd[:] = cmd.tau_ff
        plant.step(dt)
    return errors, torques, (V if lyapunov_model is not None else None)


def per_window_max(errors, dt, window):
    """max |e| per window of ``window`` seconds, per joint, in degrees."""
    per = int(round(window / dt))
    return np.degrees(np.abs(errors).reshape(-1, per, errors.shape[1]).max(axis=1))
