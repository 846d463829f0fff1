"""Controllers switched at run time (``rtctl switch``), bumplessly (docs/operations.md).

A switch is decided in the loop's thread between two ticks (the control socket's handler runs
there), so the new set of active controllers takes over at one tick boundary:

* :func:`plan_switch` checks the request against the configuration: every joint that had an
  active owner keeps exactly one, and nothing else changes hands;
* the controllers that start are reset from the current state (or keep their estimates, when
  the request says so); the reference is the run's, unchanged;
* :class:`Blend` makes the hand-over bumpless: on the joints that changed controller, the
  torque the old controller last commanded, τ_old, becomes the start of an offset that decays
  with time constant T::

      τ(t) = τ_new(t) + (τ_old − τ_new(t_s)) · exp(−(t − t_s) / T)

  so the command is continuous at the switch (its step there is zero, up to rounding) and after
  it differs from the new controller's own torque by at most |τ_old − τ_new(t_s)| · e^{−(t−t_s)/T}.
  The step from one tick to the next stays within the new controller's own change over a tick
  plus |τ_old − τ_new(t_s)| · (1 − e^{−Δt/T}).

Nothing here allocates per tick: the blend works on preallocated arrays with ``out=``.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.errors import RtctlError

BLEND_TIME_S = 0.05  # T: the offset has decayed to 1 % after 4.6 T = 0.23 s
BLEND_TIME_CONSTANTS = 8  # the blend ends after 8 T (offset below 0.04 % of the step)


def owners(controllers) -> dict[int, str]:
    """Joint index → name of the controller owning its command."""
    return {int(j): c.name for c in controllers for j in c.joints}


def plan_switch(configured: list, active: list, activate: list[str], deactivate: list[str]) -> list:
    """The active controllers after the switch, in the configuration's order, or
    :class:`RtctlError` saying why the switch is refused."""
    by_name = {c.name: c for c in configured}
    for name in (*activate, *deactivate):
        if name not in by_name:
            raise RtctlError(f"switch refused: no controller {name!r} (configured: {', '.join(by_name)})")
    both = set(activate) & set(deactivate)
    if both:
        raise RtctlError(f"switch refused: {sorted(both)[0]!r} is both activated and deactivated")
    names = ({c.name for c in active} - set(deactivate)) | set(activate)
    after = [c for c in configured if c.name in names]
    before_owner, after_owner = owners(active), {}
    for c in after:
        for j in map(int, c.joints):
            if j in after_owner:
                raise RtctlError(f"switch refused: joint {_joint(c, j)!r} would have two controllers, "
                                 f"{after_owner[j]!r} and {c.name!r}")
            after_owner[j] = c.name
    for j, name in before_owner.items():
        if j not in after_owner:
            raise RtctlError(f"switch refused: joint {_joint(by_name[name], j)!r} would have no controller "
                             f"({name!r} is deactivated and no activated controller takes it over)")
    return after


def _joint(controller, j: int) -> str:
    return controller.model.joint_names[j]


class Blend:
    """The decaying offset on the joints that changed controller (see the module docstring)."""

    def __init__(self, n: int, dt: float, time_constant: float = BLEND_TIME_S):
        self.decay = math.exp(-dt / time_constant)
        self.ticks = int(math.ceil(BLEND_TIME_CONSTANTS * time_constant / dt))
        self.mask = np.zeros(n, dtype=bool)  # the joints being blended
        self.start = np.zeros(n)  # τ_old, the last torque before the switch
        self.offset = np.zeros(n)  # (τ_old − τ_new(t_s)) on the blended joints, 0 elsewhere; decaying
        self.raw = np.zeros(n)  # the new controllers' own torque (held between their updates)
        self._out = np.zeros(n)  # scratch: a ufunc with where= allocates (~1.5 kB a call), out= alone does not
        self.due = []  # (controller, its joints) being blended
        self.left = 0  # ticks the blend still runs; 0: off
        self._first = False

    @property
    def active(self) -> bool:
        return self.left > 0

    def begin(self, tau_last: np.ndarray, started: list) -> None:
        """Arm the blend for the ``started`` controllers' joints, from the torque last commanded."""
        self.mask[:] = False
        for c in started:
            self.mask[c.joints] = True
        np.copyto(self.start, tau_last)
        self.due = [(c, c.mask) for c in started]
        self.left = self.ticks if self.mask.any() else 0
        self._first = True

    def apply(self, tau: np.ndarray, due) -> None:
        """After the controllers' updates: the blended command into ``tau`` (in place).
        ``due(divisor)``: whether a controller with that divisor ran this tick."""
        for c, mask in self.due:
            if self._first or due(c.divisor):  # its fresh torque; otherwise the one it holds between updates
                np.copyto(self.raw, tau, where=mask)
        if self._first:
            np.subtract(self.start, self.raw, out=self.offset)
            np.multiply(self.offset, self.mask, out=self.offset)
            self._first = False
        else:
            np.multiply(self.offset, self.decay, out=self.offset)
        self.left -= 1
        if self.left == 0:  # ended: the controllers' own torque
            np.copyto(tau, self.raw, where=self.mask)
            return
        np.add(self.raw, self.offset, out=self._out)
        np.copyto(tau, self._out, where=self.mask)

    def cancel(self) -> None:
        self.left = 0
