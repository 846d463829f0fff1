"""Counting the arithmetic of one controller tick from the implementation itself.

:func:`mirror` turns a numba kernel back into plain Python — the same source (each
dispatcher's ``py_func``), with every compiled callee it names replaced by its own mirror —
and :func:`count_slotine_li_tick` runs the mirror of
:func:`rtctl.control.slotine_li_kernels.slotine_li_kernel` on arrays of :class:`Counted`
scalars, which tally every multiplication (and division), addition (and subtraction) and
sin/cos they take part in. The mirror's outputs are returned as well, so a test checks them
against the compiled kernel: the count is of the code that runs. Negations and comparisons
are not counted; every operation of the generic code is (multiplications by the 0/1 entries of
a joint axis included: the kernels treat any axis). The expected counts, derived term by term
from the equations, are in docs/cstar_slotine_li.md (tests/control/test_opcount.py checks them).
"""
from __future__ import annotations

import types
from dataclasses import dataclass

import numpy as np
from numba.core.registry import CPUDispatcher

from rtctl.control.slotine_li import LAWS
from rtctl.control.slotine_li_kernels import PHI_VECTORS, slotine_li_kernel
from rtctl.model.data import BODY_SLOTS
from rtctl.model.dynamics import model_arrays


@dataclass
class Tally:
    mul: int = 0
    add: int = 0
    trig: int = 0


class Counted:
    """A float that counts the arithmetic it takes part in (into ``Counted.tally``)."""

    __slots__ = ("x",)
    tally = Tally()

    def __init__(self, x):
        self.x = float(x)

    @staticmethod
    def _value(y):
        return y.x if isinstance(y, Counted) else y

    def _mul(self, y):
        Counted.tally.mul += 1
        return Counted(self.x * self._value(y))

    def _add(self, y):
        Counted.tally.add += 1
        return Counted(self.x + self._value(y))

    __mul__ = __rmul__ = _mul
    __add__ = __radd__ = _add

    def __sub__(self, y):
        Counted.tally.add += 1
        return Counted(self.x - self._value(y))

    def __rsub__(self, y):
        Counted.tally.add += 1
        return Counted(self._value(y) - self.x)

    def __truediv__(self, y):
        Counted.tally.mul += 1
        return Counted(self.x / self._value(y))

    def __neg__(self):
        return Counted(-self.x)

    def __lt__(self, y):
        return self.x < self._value(y)

    def __gt__(self, y):
        return self.x > self._value(y)

    def __float__(self):
        return self.x

    def cos(self):  # np.cos on an object array calls this
        Counted.tally.trig += 1
        return Counted(np.cos(self.x))

    def sin(self):
        Counted.tally.trig += 1
        return Counted(np.sin(self.x))


def mirror(kernel, _done=None):
    """The plain-Python twin of a numba kernel: its source function, calling the twins of the
    compiled functions it names."""
    done = {} if _done is None else _done
    if kernel in done:
        return done[kernel]
    f = kernel.py_func
    names = dict(f.__globals__)
    twin = types.FunctionType(f.__code__, names, f.__name__, f.__defaults__, f.__closure__)
    done[kernel] = twin
    for name in f.__code__.co_names:
        value = names.get(name)
        if isinstance(value, CPUDispatcher):
            names[name] = mirror(value, done)
    return twin


def counted(a) -> np.ndarray:
    """An object array of Counted with the values of ``a``."""
    a = np.asarray(a, dtype=float)
    out = np.empty(a.shape, dtype=object)
    for idx in np.ndindex(a.shape):
        out[idx] = Counted(a[idx])
    return out


def _floats(a) -> np.ndarray:
    return np.vectorize(float, otypes=[float])(a)


def count_slotine_li_tick(model, law: str, state, params, gamma, lam, kd, adapt: bool = True):
    """Run the mirrored tick once; returns (Tally, τ, dπ̂/dt). ``state`` = (q, q̇, q_d, q̇_d,
    q̈_d); ``adapt=False`` counts the control law alone (the dead zone switches adaptation off)."""
    n = model.nq
    arrays = model_arrays(model)
    zeros = (lambda *shape: counted(np.zeros(shape)))
    q, qd, q_d, qd_d, qdd_d = (counted(x) for x in state)
    tau, qdr, qddr, s = zeros(n), zeros(n), zeros(n), zeros(n)
    params_dot = zeros(n, 10)
    dead_zone = Counted(0.0 if adapt else np.inf)
    Counted.tally = Tally()
    mirror(slotine_li_kernel)(LAWS[law], arrays.joint, counted(arrays.geom), counted(params), counted(arrays.gravity),
                              zeros(n, 4, 3), zeros(n, BODY_SLOTS, 6), zeros(PHI_VECTORS, 10),
                              q, qd, q_d, qd_d, qdd_d, counted(lam), counted(kd), counted(gamma), dead_zone, qdr, qddr,
                              s, tau, params_dot)
    return Counted.tally, _floats(tau), _floats(params_dot)
