"""Assembling a run from its configuration, without touching any device.

:func:`build` turns a validated :class:`~rtctl.config.Config` into live objects: drivers
found by name through the ``rtctl.drivers`` entry points, controllers, the trajectory, the
safety stage. Plug-ins validate their own options in ``from_config`` and open nothing, so a
bad configuration still exits 2 before any device is touched (the daemon configures
devices only afterwards).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rtctl.config import Config
from rtctl.control import CONTROLLERS, controller_class
from rtctl.control.base import Reference
from rtctl.errors import ConfigError
from rtctl.hal import JointCommand, JointState, load_driver


@dataclass
class DeviceContext:
    """What a driver's ``from_config`` may use: the robot, the loop period, the ``[sim]``
    options, the config's directory, and a dict shared by the devices of one run."""

    model: object
    period: float
    sim: object
    base_dir: Path
    shared: dict = field(default_factory=dict)


@dataclass
class Runtime:
    cfg: Config
    devices: list
    device_joints: list  # per device: indices of its joints in the robot
    controllers: list
    state: JointState  # the whole robot, gathered from the devices every tick
    command: JointCommand  # the whole robot, scattered to the devices every tick
    ref: Reference
    context: DeviceContext

    @property
    def model(self):
        return self.cfg.model

    @property
    def direct(self) -> bool:
        """True when the robot's state and command are the (single) device's own arrays."""
        return len(self.devices) == 1 and self.state is self.devices[0].state

    def bus_budget(self) -> list[str]:
        """One line per bus: its load at the loop rate (devices that are on a bus say so)."""
        lines = []
        for dev in self.devices:
            budget = getattr(dev, "bus_budget", None)
            if budget is not None:
                lines.extend(budget(self.cfg.loop.rate_hz))
        return lines or ["bus load: no CAN buses in this configuration"]


def build(cfg: Config) -> Runtime:
    model = cfg.model
    context = DeviceContext(model, cfg.loop.period, cfg.sim, cfg.file.parent)
    devices, device_joints = [], []
    for i, d in enumerate(cfg.devices):
        try:
            cls = load_driver(d.driver)
        except Exception as e:
            raise ConfigError(cfg.file, f"devices[{i}].driver", f"an installed driver ({e})") from None
        devices.append(cls.from_config(d, context))
        device_joints.append(np.asarray(d.joints, dtype=np.int64))
    controllers = []
    for i, c in enumerate(cfg.controllers):
        if c.type not in CONTROLLERS:
            raise ConfigError(cfg.file, f"controllers[{i}].type", f"one of {', '.join(sorted(CONTROLLERS))}, got {c.type!r}")
        controllers.append(controller_class(c.type).from_config(c, model))
    n = model.nq
    if len(devices) == 1 and np.array_equal(device_joints[0], np.arange(n)):
        # one device serves every joint in order: its arrays are the robot's (no gather/scatter)
        state, command = devices[0].state, devices[0].command
    else:
        state, command = JointState(n), JointCommand(n)
    return Runtime(cfg, devices, device_joints, controllers, state, command, Reference(n), context)
