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

from rtctl.config import JOINTS, Config
from rtctl.control import CONTROLLERS, controller_class
from rtctl.control.base import Reference
from rtctl.errors import ConfigError
from rtctl.hal import JointCommand, JointGroup, JointState, load_driver


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
    devices: list  # the joint devices (JointGroup)
    device_joints: list  # per joint device: indices of its joints in the robot
    controllers: list  # the active ones, in the configuration's order: what the tick runs
    state: JointState  # the whole robot, gathered from the devices every tick
    command: JointCommand  # the whole robot, scattered to the devices every tick
    ref: Reference
    context: DeviceContext
    io: dict = field(default_factory=dict)  # the other devices (framegrabber, I/O board …) by name
    io_users: list = field(default_factory=list)  # per io device (in order): the controllers using it
    configured: list = field(default_factory=list)  # every controller, active or not (`rtctl switch`)

    @property
    def all_devices(self) -> list:
        """Every device, joint devices first: the order of bring-up and of the tick's read/write."""
        return [*self.devices, *self.io.values()]

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
    devices, device_joints, io = [], [], {}
    for i, d in enumerate(cfg.devices):  # joint devices first: a simulated io device may need their plant
        if d.kind != JOINTS:
            continue
        dev = _driver(cfg, i, d).from_config(d, context)
        if not isinstance(dev, JointGroup):
            raise ConfigError(cfg.file, f"devices[{i}].driver", f"a driver of joints (kind {JOINTS!r}); "
                              f"{d.driver!r} is a {type(dev).__name__}")
        devices.append(dev)
        device_joints.append(np.asarray(d.joints, dtype=np.int64))
    for i, d in enumerate(cfg.devices):
        if d.kind != JOINTS:
            io[d.name] = _driver(cfg, i, d).from_config(d, context)
    controllers = []
    io_users = [[] for _ in io]
    for i, c in enumerate(cfg.controllers):
        if c.type not in CONTROLLERS:
            raise ConfigError(cfg.file, f"controllers[{i}].type", f"one of {', '.join(sorted(CONTROLLERS))}, got {c.type!r}")
        controller = controller_class(c.type).from_config(c, model)
        _bind(cfg, i, controller, c.devices, io, io_users, {d.name: d for d in devices})
        controllers.append(controller)
    n = model.nq
    if len(devices) == 1 and np.array_equal(device_joints[0], np.arange(n)):
        # one device serves every joint in order: its arrays are the robot's (no gather/scatter)
        state, command = devices[0].state, devices[0].command
    else:
        state, command = JointState(n), JointCommand(n)
    active = [c for c, conf in zip(controllers, cfg.controllers) if conf.active]
    return Runtime(cfg, devices, device_joints, active, state, command, Reference(n), context, io, io_users,
                   controllers)


def _driver(cfg: Config, i: int, d):
    try:
        return load_driver(d.driver)
    except Exception as e:
        if d.driver.startswith("sim_"):
            raise ConfigError(cfg.file, f"devices[{i}].kind", f"a kind the embedded simulator plays "
                              f"(no simulated {d.kind!r} device installed)") from None
        raise ConfigError(cfg.file, f"devices[{i}].driver", f"an installed driver ({e})") from None


def _bind(cfg: Config, i: int, controller, names, io: dict, io_users: list, joint_devices: dict) -> None:
    """Hand controller i the devices it names — non-joint ones, or a joint device with outputs
    of its own (a leg board's actuator codes); it checks they are what it needs."""
    named = {**joint_devices, **io}
    unknown = [x for x in names if x not in named]
    if unknown:
        raise ConfigError(cfg.file, f"controllers[{i}].devices", f"names of non-joint devices "
                          f"({', '.join(io) or 'none configured'}) or joint devices; unknown: {unknown[0]!r}")
    try:
        controller.bind({x: named[x] for x in names})
    except (TypeError, ValueError) as e:
        raise ConfigError(cfg.file, f"controllers[{i}].devices", str(e)) from None
    order = list(io)
    for x in names:
        if x in io:
            io_users[order.index(x)].append(controller)
