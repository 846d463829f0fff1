"""JointGroup: a set of joints read and commanded together every tick.

States and commands are preallocated arrays owned by the device; the loop reads
``state`` after :meth:`JointGroup.read` and fills ``command`` before :meth:`JointGroup.write`,
so nothing is allocated per tick.
"""
from __future__ import annotations

import enum

import numpy as np

from rtctl.hal.lifecycle import Hardware, Status


class CommandMode(enum.IntEnum):
    TORQUE = 0  # τ = tau_ff
    IMPEDANCE = 1  # τ = kp (q_des − q) + kd (qd_des − q̇) + tau_ff, closed at the drive (MIT style)


class JointState:
    """Measured state of n joints; ``fresh[i]`` is False when joint i's data is stale."""

    def __init__(self, n: int):
        self.position = np.zeros(n)
        self.velocity = np.zeros(n)
        self.effort = np.zeros(n)
        self.fresh = np.ones(n, dtype=bool)
        self.fault = np.zeros(n, dtype=np.int64)  # device error code per joint, 0 = none
        self.stamp = 0.0  # capture time of the state (loop time base)


class JointCommand:
    """Command to n joints; ``mode`` applies to the whole group."""

    def __init__(self, n: int):
        self.mode = CommandMode.TORQUE
        self.q_des = np.zeros(n)
        self.qd_des = np.zeros(n)
        self.kp = np.zeros(n)
        self.kd = np.zeros(n)
        self.tau_ff = np.zeros(n)

    def zero(self) -> None:
        for a in (self.q_des, self.qd_des, self.kp, self.kd, self.tau_ff):
            a.fill(0.0)


class JointGroup(Hardware):
    """Base for joint devices: implement ``_read`` and ``_write`` (and the lifecycle hooks)."""

    def __init__(self, name: str, joint_names):
        super().__init__(name)
        self.joint_names = tuple(joint_names)
        n = len(self.joint_names)
        self.state = JointState(n)
        self.command = JointCommand(n)

    @property
    def n(self) -> int:
        return len(self.joint_names)

    def stale_cause(self) -> str | None:
        """Why joints are not fresh, as the driver sees it (None: it cannot tell). Called only
        when a stale-data fault is recorded (it may allocate)."""
        return None

    def _write(self, t: float) -> Status:
        raise NotImplementedError
