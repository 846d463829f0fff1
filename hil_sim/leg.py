"""The leg board in the embedded simulator: a :class:`~rtctl.hal.leg_board.LegBoard` on the
in-process :class:`~hil_sim.leg_plant.LegPlant`, stepped inside the tick (lock-step).

Chosen by ``[sim.leg]`` (the plant's options, :class:`~hil_sim.leg_plant.LegParams`) for the
run's joint device; ``[sim] engine = "mujoco"`` puts the board on the leg on contact physics
(:class:`~hil_sim.leg_mujoco.MujocoLegPlant`, its options :class:`~hil_sim.leg_mujoco.MujocoLegParams`). ``read`` takes the plant's noisy sensor channels, ``write`` hands the
actions to the plant and advances it one period — the causality of a real board that applies
each command and answers with fresh measurements. The joint torque command is ignored (the
knee and ankle take actions, not torques). ``deactivate`` locks both joints.
"""
from __future__ import annotations

from hil_sim.embedded import ENGINES
from hil_sim.leg_plant import LegParams, LegPlant
from rtctl.hal import Status
from rtctl.hal.leg_board import LegBoard


class EmbeddedLegBoard(LegBoard):
    def __init__(self, name, joint_names, plant: LegPlant, period: float):
        super().__init__(name, joint_names, period)
        self.plant = plant
        self.steps = 0

    @classmethod
    def from_config(cls, device, context) -> "EmbeddedLegBoard":
        if len(device.joints) != 3:
            raise device.options.error("joints", "the leg's three joints (hip, knee, ankle) on the board")
        plant = leg_plant(context.sim, context.sim.table("leg"), context.period)
        context.sim.done()
        device.options.done()
        names = [context.model.joint_names[j] for j in device.joints]
        return cls(device.name, names, plant, context.period)

    def _read(self, t: float) -> Status:
        self.channels[:] = self.plant.channels
        self.publish(self.plant.time, True)
        return Status.OK

    def _write(self, t: float) -> Status:
        self.plant.actions[:] = self.actions
        self.plant.step(self.period)
        self.steps += 1
        return Status.OK

    def _on_deactivate(self) -> None:
        self.safe_state()
        self.plant.actions[:] = self.actions

    def diagnostics(self) -> dict:
        return {**super().diagnostics(), "plant_steps": self.steps, "plant_time": self.plant.time}


def leg_plant(sim, leg, period: float):
    """The leg plant ``[sim] engine`` names ("rigid", the default: the scripted gait generator;
    "mujoco": the leg on contact physics) with the ``[sim.leg]`` options ``leg``."""
    if sim.str("engine", "rigid", choices=ENGINES) != "mujoco":
        return LegPlant(LegParams.from_table(leg))
    from hil_sim.leg_mujoco import MujocoLegParams, MujocoLegPlant

    params = MujocoLegParams.from_table(leg)
    try:
        return MujocoLegPlant(params, period)
    except ImportError as e:
        raise sim.error("engine", f"an installed engine ({e})") from None
