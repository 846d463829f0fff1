"""A safety stage wired to a state, a command and device statuses, stepped tick by tick."""
import numpy as np

from rtctl.hal.joints import JointCommand, JointState
from rtctl.safety import SafetyStage

N = 3
Q_MIN, Q_MAX = np.array([-1.0, -2.0, -3.0]), np.array([1.0, 2.0, 3.0])
V_MAX, TAU_MAX = np.array([2.0, 2.0, 4.0]), np.array([10.0, 20.0, 5.0])


class Rig:
    """A stage with a state, a command and a tick counter: ``step()`` runs one check."""

    def __init__(self, n_devices=1, **options):
        devices = None if n_devices == 1 else [[0], [1, 2]]
        self.stage = SafetyStage(Q_MIN, Q_MAX, V_MAX, TAU_MAX, device_joints=devices, **options)
        self.state = JointState(N)
        self.command = JointCommand(N)
        self.statuses = np.zeros(n_devices, dtype=np.int64)
        self.tick = 0
        self.dt = 0.001

    def step(self, controller_ok=True, error=None, reference=None):
        v = self.stage.check(self.tick * self.dt, self.tick, self.state, self.statuses, self.command,
                             controller_ok, error, reference)
        self.tick += 1
        return v
