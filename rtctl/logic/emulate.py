"""The PLA + J-K flip-flops, emulated: asynchronous fundamental-mode semantics, compiled.

Not a lookup table: every pass evaluates the AND plane (a term is active when the inputs
agree with it on its care bits), ORs the active terms' output words (the OR plane), and
clocks every flip-flop with its characteristic equation Q⁺ = J Q̄ + K̄ Q — all flip-flops in
one word operation, the outputs of all terms in one OR. After an input change the circuit
is re-evaluated until the state no longer changes; one that has not settled within
``max_passes`` passes is a fault (``NOT_SETTLED``). Passes change the flip-flops together;
:func:`rtctl.logic.verify.race_proof` shows, exhaustively, that every other order ends in
the same state, so this is the circuit's behaviour, not one lucky interleaving.

Word layouts: input word = gates (bit i = gate i) | state << n_gates; output word = J1…Jb
(bits 0…b−1), K1…Kb (bits b…2b−1), then the actuator bits.

:class:`CircuitModel` holds the compiled personality (model, in Pinocchio's sense);
:func:`settle` is the kernel; it allocates nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from rtctl.logic.pla import Pla

NOT_SETTLED = -1
DEFAULT_MAX_PASSES = 4  # the shipped table's longest route is 2 steps: 2 changing passes + 1 that confirms, + 1 spare


@njit(cache=True)
def pla_eval(care, value, ormask, word):
    """The OR-plane word for one input word."""
    out = 0
    for t in range(care.shape[0]):
        if word & care[t] == value[t]:
            out |= ormask[t]
    return out


@njit(cache=True)
def settle(care, value, ormask, n_gates, n_bits, gates, io, max_passes):
    """Apply gate word ``gates`` to the state ``io[0]`` and re-evaluate until stable.

    On return ``io[0]`` is the stable state and ``io[1]`` the output word; the result is
    the number of passes that changed the state, or NOT_SETTLED (``io`` then holds the last
    pass)."""
    mask = (1 << n_bits) - 1
    q = io[0]
    for p in range(max_passes):
        out = pla_eval(care, value, ormask, gates | (q << n_gates))
        j = out & mask
        k = (out >> n_bits) & mask
        q_next = ((j & ~q) | (~k & q)) & mask
        io[1] = out
        if q_next == q:
            io[0] = q
            return p
        q = q_next
    io[0] = q
    return NOT_SETTLED


@dataclass(frozen=True)
class CircuitModel:
    """A PLA personality compiled to word form for :func:`settle`."""

    n_gates: int
    n_bits: int
    n_actuators: int
    care: np.ndarray  # int64 [terms]
    value: np.ndarray
    ormask: np.ndarray  # int64 [terms]: internal output word of each term
    max_passes: int = DEFAULT_MAX_PASSES

    @classmethod
    def from_pla(cls, pla: Pla, n_gates: int, n_bits: int, max_passes: int = DEFAULT_MAX_PASSES) -> "CircuitModel":
        """Inputs: n_gates gates then Q1…Qb; outputs J1 K1 … Jb Kb (any order, by name) and the
        actuator bits (the other outputs, in order): at most 62 outputs in all, bits 0–61 of
        one int64 word."""
        if len(pla.inputs) != n_gates + n_bits:
            raise ValueError(f"a PLA with {n_gates} gate and {n_bits} state inputs, got {len(pla.inputs)} inputs")
        if max_passes < 1:
            raise ValueError("max_passes must be ≥ 1")
        bit_of = {}
        for k in range(n_bits):
            for prefix, base in (("J", 0), ("K", n_bits)):
                name = f"{prefix}{k + 1}"
                if name not in pla.outputs:
                    raise ValueError(f"the PLA has no output {name}")
                bit_of[pla.outputs.index(name)] = base + k
        actuators = [o for o in range(len(pla.outputs)) if o not in bit_of]
        for a, o in enumerate(actuators):
            bit_of[o] = 2 * n_bits + a
        if 2 * n_bits + len(actuators) > 62:
            raise ValueError("too many outputs for one word")
        ormask = np.array([sum(1 << bit_of[o] for o in np.flatnonzero(row)) for row in pla.plane], dtype=np.int64)
        care = np.array([c for c, _ in pla.terms], dtype=np.int64)
        value = np.array([v for _, v in pla.terms], dtype=np.int64)
        return cls(n_gates, n_bits, len(actuators), care, value, ormask.reshape(len(pla.terms)), max_passes)

    def actuators(self, out_word: int) -> int:
        return (out_word >> (2 * self.n_bits)) & ((1 << self.n_actuators) - 1)

    def excited(self, q: int, gates: int) -> int:
        """The flip-flops whose next value differs from their present one (bit k = Q(k+1))."""
        out = pla_eval(self.care, self.value, self.ormask, gates | (q << self.n_gates))
        mask = (1 << self.n_bits) - 1
        j, k = out & mask, (out >> self.n_bits) & mask
        return (((j & ~q) | (~k & q)) & mask) ^ q


class Emulator:
    """The circuit with its flip-flops: ``apply(gates)`` settles and returns the passes."""

    def __init__(self, model: CircuitModel, state_code: int = 0):
        self.model = model
        self.io = np.zeros(2, dtype=np.int64)
        self.io[0] = state_code

    @property
    def code(self) -> int:
        return int(self.io[0])

    @code.setter
    def code(self, value: int) -> None:
        self.io[0] = value

    @property
    def actuators(self) -> int:
        return self.model.actuators(int(self.io[1]))

    def apply(self, gates: int) -> int:
        m = self.model
        if not 0 <= gates < 1 << m.n_gates:
            raise ValueError(f"gates must be a {m.n_gates}-bit word, got {gates}")
        return settle(m.care, m.value, m.ormask, m.n_gates, m.n_bits, gates, self.io, m.max_passes)
