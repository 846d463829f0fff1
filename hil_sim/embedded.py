"""The embedded simulator: a simulated JointGroup stepped inside the tick, in lock-step.

Registered as the driver ``sim`` in the entry-point group ``rtctl.drivers``. One
:class:`~hil_sim.plant.Plant` plays the whole robot; each simulated device serves some of its
joints. Within a tick the loop ``write()``s every device; when the last one has written, the
plant advances one period, so the next ``read()`` sees the state one period later — the
same causality as a real drive that answers each command with a fresh measurement.

Options (the run configuration's ``[sim]`` table)::

    substeps = 4                 # integrator steps per period
    integrator = "euler"         # or "rk4" (classical Runge–Kutta; hil_sim.plant)
    friction = 1.0               # scale of the robot file's viscous + Coulomb friction
    armature = true              # reflected rotor inertia from the robot file
    plant = "robots/x.toml"      # another description as the true plant (default: the robot)
    params_scale = 1.0           # scale the true plant's inertial parameters
    initial_q = [..]             # start position (rad/m; default: mid-range clipped to 0)
    encoder_counts = 0           # counts per revolution for position quantisation (0 = ideal)
    velocity_noise = 0.0         # std of white noise on measured velocity (rad/s)
    seed = 1
    transport = "direct"         # "can": through the MIT CAN driver and emulated drives (hil_sim.can_embedded)
    [sim.leg]                    # the robot is the prosthetic leg: its board on the leg plant (hil_sim.leg)
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel
from rtctl.hal import JointGroup, Status
from rtctl.hal.lifecycle import Lifecycle
from rtctl.model import load_robot
from rtctl.model.regressor import regressor_mass_matrix
from hil_sim.mujoco_plant import MujocoPlant
from hil_sim.payload import Payload, fold_payload
from hil_sim.plant import Plant


@kernel
def measure(q, qd, tau_applied, idx, quantum, position, velocity, effort):
    """The device's joints of the plant as its encoders see them: position floored to ``quantum``
    (when > 0), velocity and the torque the motors produce — one call for the whole read."""
    for k in range(idx.shape[0]):
        j = idx[k]
        p = q[j]
        if quantum:
            p = np.floor(p / quantum) * quantum
        position[k] = p
        velocity[k] = qd[j]
        effort[k] = tau_applied[j]


@kernel
def command_torque(impedance, q_des, qd_des, kp, kd, tau_ff, position, velocity, idx, tau_cmd):
    """The motor torque of the device's joints into the plant's ``tau_cmd``: ``tau_ff``, or the
    impedance law closed here as a drive would, kp (q_des − q) + τ_ff + kd (q̇_des − q̇)."""
    for k in range(idx.shape[0]):
        tau = tau_ff[k]
        if impedance:
            tau = (q_des[k] - position[k]) * kp[k] + tau_ff[k] + (qd_des[k] - velocity[k]) * kd[k]
        tau_cmd[idx[k]] = tau


ENGINES = ("rigid", "mujoco")  # rtctl's own rigid-body plant, or MuJoCo (an independent one: docs/mujoco.md)


class SimPlantHub:
    """The plant shared by the simulated devices of one run, and its lock-step counter."""

    def __init__(self, plant: Plant, period: float):
        self.plant = plant
        self.period = period
        self.devices: list["SimJointGroup"] = []
        self._written = 0

    def written(self) -> None:
        """Called by each active device's write; the last one steps the plant (a device alone is
        the last: an inactive device never writes)."""
        self._written += 1
        if len(self.devices) == 1 or self._written >= sum(d.lifecycle is Lifecycle.ACTIVE for d in self.devices):
            self._written = 0
            self.plant.step(self.period)

    @classmethod
    def from_options(cls, sim, model, period: float, base_dir) -> "SimPlantHub":
        plant_file = sim.str("plant", "")
        true_model = load_robot(base_dir / plant_file) if plant_file else model
        if true_model.nq != model.nq:
            raise sim.error("plant", f"a robot with {model.nq} joints like {model.name}")
        scale = sim.float("params_scale", 1.0, positive=True)
        if scale != 1.0:
            true_model = true_model.with_params(true_model.params * scale)
        q0 = sim.vector("initial_q", model.nq, None)
        if q0 is None:
            q0 = np.clip(np.zeros(model.nq), model.q_min, model.q_max)
        payload_t = sim.table("payload", None)
        payload = None if payload_t is None else Payload.from_table(payload_t)
        options = dict(substeps=sim.int("substeps", 4, min=1, max=1000), friction_scale=sim.float("friction", 1.0, min=0.0),
                       armature=sim.bool("armature", True), q0=q0,
                       integrator=sim.str("integrator", "euler", choices=("euler", "rk4")))
        if sim.str("engine", "rigid", choices=ENGINES) == "mujoco":
            try:
                plant = MujocoPlant(true_model, period=period, payload=payload, **options)
            except ImportError as e:
                raise sim.error("engine", f"an installed engine ({e})") from None
            except ValueError as e:  # (MuJoCo's own compiler refusing the generated model)
                raise sim.error("engine", f"a robot MuJoCo can simulate ({e})") from None
        else:
            plant = Plant(true_model if payload is None else fold_payload(true_model, payload), **options)
        try:  # a joint with no inertia and no armature cannot be simulated (its q̈ is undefined)
            np.linalg.cholesky(regressor_mass_matrix(true_model, plant.q) + np.diag(plant.armature))
        except np.linalg.LinAlgError:
            raise sim.error("armature", "a plant whose every joint has inertia or armature (H(q) + diag(armature) "
                                        "is not positive definite at the initial q)") from None
        hub = cls(plant, period)
        hub.encoder_counts = sim.int("encoder_counts", 0, min=0)
        hub.velocity_noise = sim.float("velocity_noise", 0.0, min=0.0)
        hub.rng = np.random.default_rng(sim.int("seed", 1))
        sim.done()
        return hub


class SimJointGroup(JointGroup):
    """Simulated joints: torque or MIT-style impedance commands in, measured state out."""

    def __init__(self, name: str, joint_names, joints, hub: SimPlantHub):
        super().__init__(name, joint_names)
        self.hub = hub
        self.idx = np.asarray(joints, dtype=np.int64)
        self._noise = np.zeros(len(self.idx))
        self.quantum = 2 * np.pi / hub.encoder_counts if hub.encoder_counts else 0.0
        hub.devices.append(self)

    @classmethod
    def from_config(cls, device, context) -> "SimJointGroup":
        """``device``: rtctl.config.DeviceConfig; ``context``: rtctl.daemon.DeviceContext.
        ``[sim] transport = "can"`` plays the device through the CAN driver and emulated drives
        (:mod:`hil_sim.can_embedded`) instead."""
        if context.sim.str("transport", "direct", choices=("direct", "can")) == "can":
            from hil_sim.can_embedded import SimCanJointGroup

            return SimCanJointGroup.from_config(device, context)
        if context.sim.has("leg"):  # the prosthetic leg: its board on the leg plant (hil_sim.leg)
            from hil_sim.leg import EmbeddedLegBoard

            return EmbeddedLegBoard.from_config(device, context)
        hub = context.shared.get("sim_hub")
        if hub is None:
            hub = SimPlantHub.from_options(context.sim, context.model, context.period, context.base_dir)
            context.shared["sim_hub"] = hub
        device.options.done()
        names = [context.model.joint_names[j] for j in device.joints]
        return cls(device.name, names, device.joints, hub)

    def warm_up(self) -> None:
        """Load the compiled plant step (a zero-length step changes nothing) and the device's own
        kernels (on scratch arrays: the plant's are untouched)."""
        self.hub.plant.step(0.0)
        n, c = len(self.idx), self.command
        scratch = np.zeros(len(self.hub.plant.q))
        measure(scratch, scratch, scratch, self.idx, 0.0, np.zeros(n), np.zeros(n), np.zeros(n))
        command_torque(True, c.q_des, c.qd_des, c.kp, c.kd, c.tau_ff, self.state.position, self.state.velocity,
                       self.idx, scratch)

    def _on_deactivate(self) -> None:
        np.put(self.hub.plant.tau_cmd, self.idx, 0.0)  # motors off

    def _read(self, t: float) -> Status:
        plant, s = self.hub.plant, self.state
        measure(plant.q, plant.qd, plant.tau_applied, self.idx, self.quantum, s.position, s.velocity, s.effort)
        if self.hub.velocity_noise:
            self.hub.rng.standard_normal(out=self._noise)
            self._noise *= self.hub.velocity_noise
            s.velocity += self._noise
        s.stamp = plant.time
        return Status.OK

    def _write(self, t: float) -> Status:
        c, s = self.command, self.state
        command_torque(bool(c.mode), c.q_des, c.qd_des, c.kp, c.kd, c.tau_ff, s.position, s.velocity, self.idx,
                       self.hub.plant.tau_cmd)
        self.hub.written()
        return Status.OK
