"""The Controller protocol (docs/architecture.md).

A controller owns the commands of some joints (one owner per joint, checked at start; an
observer owns none) and runs every ``divisor``-th tick. It may use non-joint devices (a
framegrabber, an I/O board), which it receives by name through :meth:`Controller.bind`. ``update`` writes into the preallocated command arrays it is
given and allocates nothing; what it wants recorded it exposes through ``internals``
(name → preallocated array), which telemetry copies every tick.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import leaf
from rtctl.hal.joints import JointCommand, JointState


@leaf
def emit_owned(mask, tau, out):
    """:meth:`Controller.emit` inside a kernel: out[j] = tau[j] for the joints owned (``mask``)."""
    for j in range(tau.shape[0]):
        if mask[j]:
            out[j] = tau[j]


class Reference:
    """Desired joint motion for this tick: position, velocity, acceleration (preallocated)."""

    def __init__(self, n: int):
        self.packed = np.zeros((3, n))  # q, q̇, q̈ as rows: one argument for a compiled caller
        self.q, self.qd, self.qdd = self.packed


class Controller:
    """Base class; subclasses implement :meth:`update` and usually :meth:`reset`.

    ``follows_reference``: whether the controller steers its joints along the run's reference
    (the trajectory or a ``move``); one that does not (the leg's automaton drives them from
    its gait) makes "tracking error" meaningless, and the daemon reports none."""

    follows_reference = True

    def __init__(self, name: str, model, joints=None, divisor: int = 1):
        self.name = name
        self.model = model
        self.joints = np.arange(model.nq) if joints is None else np.asarray(joints, dtype=np.int64)
        self.divisor = divisor
        self.mask = np.zeros(model.nq, dtype=bool)  # the joint commands this controller owns
        self.mask[self.joints] = True
        self.internals: dict[str, np.ndarray] = {}

    def emit(self, tau_out: np.ndarray, tau: np.ndarray) -> None:
        """Copy the owned joints' torques into the command, without allocating (a compiled
        controller does it in its kernel: :func:`emit_owned`)."""
        np.copyto(tau_out, tau, where=self.mask)

    def bind(self, devices: dict) -> None:
        """Receive the non-joint devices the configuration's ``devices`` names (name → device),
        before anything is opened. Raise TypeError or ValueError if one is not what this
        controller needs; the default needs none."""
        if devices:
            raise ValueError(f"{type(self).__name__} uses no devices; got {', '.join(devices)}")

    def tunables(self) -> dict:
        """The parameters ``rtctl set`` may change while it runs: name →
        :class:`~rtctl.control.tunable.Tunable` (none by default)."""
        return {}

    def reset(self, state: JointState) -> None:
        """Forget history (integrators, estimates) before (re)starting from ``state``."""

    def resume(self, state: JointState) -> None:
        """Start again after a time inactive, keeping what was learnt (an adaptive controller's
        estimates); without estimates, the same as :meth:`reset`."""
        self.reset(state)

    def update(self, t: float, state: JointState, ref: Reference, command: JointCommand) -> None:
        raise NotImplementedError
