"""The simulated robot on MuJoCo: the same interface as :class:`hil_sim.plant.Plant` (``q``, ``qd``,
``tau_cmd``, ``tau_applied``, ``armature``, ``time``, ``step``), an independent engine underneath
(``[sim] engine = "mujoco"``; docs/mujoco.md).

The model comes from the robot description (:func:`hil_sim.mujoco_model.to_mjcf`) with the drive
train's armature, viscous and Coulomb friction and the joint limits, plus what the controller's
model lacks when the configuration says so (a payload). The commanded torque, clamped to the
drives' limits, is applied as a generalised force held over the period; MuJoCo integrates
``substeps`` steps of period/substeps with its own integrator (``euler``: MuJoCo's semi-implicit
Euler, ``rk4``: its RK4). ``q`` and ``qd`` are views of MuJoCo's state: no copy per step.
"""
from __future__ import annotations

import numpy as np

from hil_sim.mujoco_model import to_mjcf
from hil_sim.payload import Payload

INSTALL = "pip install -e '.[mujoco]'"
INTEGRATORS = {"euler": "Euler", "rk4": "RK4"}


def import_mujoco():
    """The mujoco module, or ImportError saying how to install it."""
    try:
        import mujoco
    except ImportError:
        raise ImportError(f"the MuJoCo engine needs the `mujoco` package: {INSTALL}") from None
    return mujoco


class MujocoPlant:
    def __init__(self, model, *, period: float, substeps: int = 4, friction_scale: float = 1.0,
                 armature: bool = True, q0=None, integrator: str = "euler", payload: Payload | None = None):
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {tuple(INTEGRATORS)}, got {integrator!r}")
        mujoco = import_mujoco()
        self._mujoco = mujoco
        self.model = model
        n = model.nq
        motors = model.motors
        self.armature = np.zeros(n)
        viscous, coulomb = np.zeros(n), np.zeros(n)
        if motors is not None:
            if armature:
                self.armature[:] = motors.armature
            viscous[:] = motors.viscous * friction_scale
            coulomb[:] = np.abs(motors.coulomb) * friction_scale
        self.substeps = int(substeps)
        self.mjcf = to_mjcf(model, timestep=period / self.substeps, integrator=INTEGRATORS[integrator],
                            armature=self.armature, damping=viscous, frictionloss=coulomb, payload=payload)
        self.mj_model = mujoco.MjModel.from_xml_string(self.mjcf)
        self.mj_data = mujoco.MjData(self.mj_model)
        self.q, self.qd = self.mj_data.qpos, self.mj_data.qvel  # views: MuJoCo's own state
        self.tau_cmd, self.tau_applied = np.zeros(n), self.mj_data.qfrc_applied
        self.tau_max = np.where(np.isfinite(model.tau_max), model.tau_max, 1e300)
        if q0 is not None:
            self.q[:] = q0
        self._mujoco.mj_forward(self.mj_model, self.mj_data)
        self.time = 0.0

    def step(self, dt: float) -> None:
        """Advance by ``dt`` (a whole number of MuJoCo steps) with the torques in ``tau_cmd`` held."""
        np.clip(self.tau_cmd, -self.tau_max, self.tau_max, out=self.tau_applied)
        steps = round(dt / self.mj_model.opt.timestep)
        if steps:
            self._mujoco.mj_step(self.mj_model, self.mj_data, steps)
        self.time += dt
