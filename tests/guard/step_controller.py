"""A controller that misbehaves on purpose, for the guard's closed-loop tests: PD + gravity to a
fixed ``target`` (rad) from ``at`` seconds on, whatever the trajectory says (before then it
follows the trajectory's reference)."""
import numpy as np

from rtctl.control.base import Reference
from rtctl.control.gains import per_joint
from rtctl.control.pd_gravity import PDGravity


class StepInto(PDGravity):
    def __init__(self, name, model, kp, kd, target, at, joints=None, divisor=1):
        super().__init__(name, model, kp, kd, joints, divisor)
        self.target, self.at = np.asarray(target, float), float(at)
        self._ref = Reference(model.nq)

    @classmethod
    def from_config(cls, cfg, model):
        t, n = cfg.options, model.nq
        c = cls(cfg.name, model, per_joint(t, "kp", n), per_joint(t, "kd", n), t.vector("target", n),
                t.float("at", 0.2, min=0.0), cfg.joints, cfg.divisor)
        t.done()
        return c

    def update(self, t, state, ref, command):
        np.copyto(self._ref.q, self.target if t >= self.at else ref.q)
        super().update(t, state, self._ref, command)
