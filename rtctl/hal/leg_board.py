"""LegBoard: the prosthetic leg's I/O board — sensor channels in, actuator codes out.

The board serves the leg's three joints (hip, knee, ankle) as a :class:`JointGroup`: their
angles come from its sensor channels, so the safety stage checks them like any joint's
(limits, stale data, device errors). The knee and ankle are cybernetic actuators, commanded
not by torque but by a 2-bit action each (``actions``: 00 hold — locked, 01 decrease,
10 increase, 11 release); the controller that names the board writes them, and the board
ignores the joint torque command.

Safe state: both joints locked (:meth:`safe_state`, called by the loop in the same tick the
safety stage takes over, and on deactivation). ``channels``: hip, knee, ankle angle (rad),
toe and heel load (fractions of the body weight). Velocities are a low-pass filtered
difference of the angles (the board measures angles only).
"""
from __future__ import annotations

import numpy as np

from rtctl.hal.joints import JointGroup

CHANNELS = ("hip", "knee", "ankle", "toe", "heel")
ACTUATED = ("knee", "ankle")
HOLD = 0  # the actuators' lock code


class LegBoard(JointGroup):
    """Base of the leg board drivers: implement ``_read`` (fill ``channels``, then call
    :meth:`publish`) and ``_write`` (send ``actions``)."""

    def __init__(self, name: str, joint_names, period: float, velocity_time: float = 0.02):
        if len(joint_names) != 3:
            raise ValueError(f"a leg board serves 3 joints (hip, knee, ankle), got {list(joint_names)}")
        super().__init__(name, joint_names)
        self.channels = np.zeros(len(CHANNELS))
        self.actions = np.zeros(len(ACTUATED), dtype=np.int64)  # knee, ankle
        self.period = float(period)
        self._alpha = float(np.exp(-period / velocity_time)) if velocity_time > 0 else 0.0
        self._previous = np.zeros(3)
        self._delta = np.zeros(3)
        self._primed = False

    def safe_state(self) -> None:
        """Lock both joints (written with the next ``write``)."""
        self.actions.fill(HOLD)

    def publish(self, stamp: float, fresh: bool) -> None:
        """Joint state from ``channels`` (call after updating them)."""
        s = self.state
        s.position[:] = self.channels[:3]
        if self._primed:
            np.subtract(s.position, self._previous, out=self._delta)
            self._delta *= (1.0 - self._alpha) / self.period
            s.velocity *= self._alpha
            s.velocity += self._delta
        self._previous[:] = s.position
        self._primed = True
        s.fresh[:] = fresh
        s.stamp = stamp
