"""The embedded simulator through the CAN codec: ``[sim] transport = "can"``.

Each simulated device is the real :class:`~drivers.can_joints.MitCanJointGroup` on its own
python-can ``virtual`` bus (a channel name unique to the run), with emulated MIT drive
firmware (:mod:`hil_sim.mit_drive`) on the other end, mounted on the shared plant — so every
tick goes through the driver, the codec (quantisation included) and the drives' impedance
law. Lock-step inside the tick, as the direct simulator: right after the driver sends, the
drives are pumped (each answers at once with its measurement); when every active device has
written, the plant advances one period (:class:`~hil_sim.embedded.SimPlantHub`). Time is the
loop's time, for the drives' watchdogs too, so ``realtime_factor = 0`` is bit-for-bit
reproducible.

What differs from the direct simulator is what differs on real hardware: the state read at
tick k+1 is the drives' reply to tick k's commands (measured before the plant advanced: one
period older), quantised by the codec. Drives: ids 1…n per device, Katz firmware with ranges
from the robot's limits (:func:`hil_sim.can_rig.sim_layout`). ``[sim]`` ``encoder_counts`` and
``velocity_noise`` apply to the direct simulator only (here the codec quantises). The direct
simulator stays the default: this path costs ~0.4 ms per PUMA tick (python-can's virtual bus
deep-copies every frame) against ~0.08 ms.
"""
from __future__ import annotations

import uuid

import can
import numpy as np

from hil_sim.can_rig import emulated_drives, sim_layout
from hil_sim.embedded import SimPlantHub
from hil_sim.mit_drive import MitDriveBus, pump
from rtctl.hal import load_driver
from rtctl.tomltable import Table

# The real driver, found by name like the daemon finds it (hil_sim does not import drivers).
MitCanJointGroup = load_driver("mit_can")


class SimCanJointGroup(MitCanJointGroup):
    def __init__(self, name, joints, indices, hub: SimPlantHub):
        channel = f"rtctl-sim-{name}-{uuid.uuid4().hex}"
        bus = MitCanJointGroup.read_bus_options(
            Table({"bus": {"interface": "virtual", "channel": channel}}, "<embedded simulator>", name))
        # everything is answered inside send: no wait for replies
        super().__init__(name, joints, bus, period=hub.period, reply_deadline=0.0, exchange_timeout=0.0)
        self.hub, self.idx = hub, np.asarray(indices, dtype=np.int64)
        self.drive_bus = MitDriveBus(emulated_drives(joints, indices, hub.plant), name=channel)
        self._peer = None
        self._now = 0.0
        hub.devices.append(self)

    @classmethod
    def from_config(cls, device, context) -> "SimCanJointGroup":
        hub = context.shared.get("sim_hub")
        if hub is None:
            hub = SimPlantHub.from_options(context.sim, context.model, context.period, context.base_dir)
            context.shared["sim_hub"] = hub
        device.options.done()
        return cls(device.name, sim_layout(context.model, device.joints), device.joints, hub)

    def bus_budget(self, rate_hz: float) -> list[str]:
        return []  # an in-process virtual bus has no bitrate

    def warm_up(self) -> None:
        self.hub.plant.step(0.0)

    def _on_configure(self) -> None:
        # the drives' end first: a virtual bus delivers only to buses open at send time
        self._peer = can.Bus(interface="virtual", channel=self.bus_options.kwargs["channel"])
        super()._on_configure()

    def _on_deactivate(self) -> None:
        try:
            super()._on_deactivate()
        finally:
            np.put(self.hub.plant.tau_cmd, self.idx, 0.0)

    def _on_close(self) -> None:
        super()._on_close()
        if self._peer is not None:
            self._peer.shutdown()
            self._peer = None

    def _read(self, t: float) -> object:
        self._now = t
        return super()._read(t)

    def _write(self, t: float) -> object:
        self._now = t
        try:
            return super()._write(t)
        finally:
            self.hub.written()  # the plant advances once every active device wrote

    def _after_send(self) -> None:
        pump(self.drive_bus, self._peer, now=self._now)

    def _clock(self) -> float:
        return self._now
