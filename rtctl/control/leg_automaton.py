"""The prosthetic-leg controller: threshold gates → the synthesised J-K/PLA circuit → actions.

Every tick (one compiled call, :func:`automaton_tick`): each gate compares a sensor channel
of the leg board with its threshold, with hysteresis (a Schmitt trigger: it turns on above
threshold + h/2 and off below threshold − h/2; h = 0 is the paper's plain comparator, on
when S_c − S_r > 0, Table 2); the gate word is applied to the emulated circuit, which
settles in fundamental mode (:func:`rtctl.logic.emulate.settle`); its actuator bits K1 K2
and A1 A2 become the knee's and the ankle's action codes on the board (00 hold, 01 decrease,
10 increase, 11 release). A circuit that does not settle within ``max_passes`` raises: the
safety stage takes over and the board locks both joints in the same tick.

The circuit is synthesised from the event table at configuration (:mod:`rtctl.logic`).
Options (``[[controllers]]``, type ``leg_automaton``)::

    table = "leg/table3.toml"     # the event table, relative to the configuration
    semantics = "guard"           # each exit on its single gate event (the shipped jobs); "exact"
                                  # (default): only on the table's gate vector, every other holds
    devices = ["board"]           # the leg board (a LegBoard) whose channels and actions it uses
    hysteresis = true             # false: every gate a plain comparator (to see why it is there)
    max_passes = 8                # settle limit (default: what the circuit needs + 1; less than it needs: exit 2)
    gates.t_d = { channel = "toe", threshold = 0.15, hysteresis = 0.1 }   # one per table gate
    gates.h_d2 = { channel = "hip", threshold = -11, hysteresis = 2, below = true }

Angles (channels hip, knee, ankle) in degrees, loads (toe, heel) in body weights; ``below``:
the gate is 1 when the channel is under the threshold; a gate's ``hysteresis`` is 0 (the plain
comparator) when left out. After a reset every gate is off. Telemetry: ``leg_state`` (the
automaton's state), ``leg_gates``, ``leg_actions`` (knee, ankle), ``leg_settle`` (passes
that changed the state this tick), ``leg_channels``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rtctl.control.base import Controller
from rtctl.errors import RtctlError
from rtctl.hal.leg_board import CHANNELS, LegBoard
from rtctl.logic import CircuitModel, compile_table, load_table
from rtctl.logic.emulate import settle
from rtctl.logic.synth import SEMANTICS

ANGLES = ("hip", "knee", "ankle")
# data layout (int64): state code, output word, gate word, passes, state label, gate bits …
CODE, OUT, WORD, PASSES, LABEL, GATE0 = range(6)
# gate model rows (float64, one column per gate)
CHANNEL, THRESHOLD, HALF_HYSTERESIS, SENSE = range(4)


@njit(cache=True)
def automaton_tick(channels, gates, pla, labels, data, actions, n_bits, max_passes):
    """One tick: gates with hysteresis, settle the circuit, decode the actions. Returns the
    passes that changed the state, or NOT_SETTLED."""
    n_gates = gates.shape[1]
    word = data[2]
    for g in range(n_gates):
        e = gates[3, g] * (channels[int(gates[0, g])] - gates[1, g])
        h = gates[2, g]
        if h > 0.0:
            if e > h:
                word |= 1 << g
            elif e < -h:
                word &= ~(1 << g)
        elif e > 0.0:
            word |= 1 << g
        else:
            word &= ~(1 << g)
        data[5 + g] = (word >> g) & 1
    data[2] = word
    passes = settle(pla[0], pla[1], pla[2], n_gates, n_bits, word, data, max_passes)
    data[3] = passes
    data[4] = labels[data[0]]
    z = data[1] >> (2 * n_bits)
    actions[0] = (z & 1) << 1 | (z >> 1) & 1  # K1 K2
    actions[1] = (z >> 2 & 1) << 1 | (z >> 3) & 1  # A1 A2
    return passes


class LegAutomaton(Controller):
    follows_reference = False  # the gait, not a trajectory, sets the joints' motion
    def __init__(self, name, model, table, gate_rows, joints=None, divisor=1, max_passes=None, semantics="exact"):
        """``table``: an :class:`~rtctl.logic.table.EventTable`; ``gate_rows``: [4, gates] —
        channel index, threshold, half hysteresis, sense (+1 above, −1 below), SI units;
        ``max_passes``: the settle limit, at least what the synthesised circuit needs
        (default: that, plus one spare); ``semantics``: "guard" or "exact" (module doc)."""
        super().__init__(name, model, joints, divisor)
        self.table = table
        if self.table.n_actuators != 4:
            raise ValueError("the leg's event table needs 4 actuator bits (K1 K2 A1 A2)")
        self.circuit = compile_table(self.table, semantics)
        needed = self.circuit.settle_passes
        if max_passes is None:
            max_passes = needed + 1
        if max_passes < needed:
            raise ValueError(f"max_passes: at least {needed} (the circuit's longest path is {needed - 1} flip-flop "
                             f"changes, and one pass confirms the state), got {max_passes}")
        self.cm = CircuitModel.from_pla(self.circuit.pla, self.table.n_gates, self.circuit.n_bits, max_passes)
        self.gates = np.ascontiguousarray(gate_rows, dtype=float)
        if self.gates.shape != (4, self.table.n_gates):
            raise ValueError(f"one gate per table column ({self.table.n_gates}), got {self.gates.shape}")
        self.pla = np.stack([self.cm.care, self.cm.value, self.cm.ormask])
        a = self.circuit.assignment
        self.labels = np.full(1 << a.n_bits, -1, dtype=np.int64)
        for s, c in a.codes.items():
            self.labels[c] = s
        self.initial_code = a.codes[self.circuit.flow.initial]
        self.data = np.zeros(GATE0 + self.table.n_gates, dtype=np.int64)
        self.board: LegBoard | None = None
        self.telemetry_meta = {"leg_gates_labels": list(table.gates), "leg_actions_labels": ["knee", "ankle"]}
        self.internals = {"leg_state": self.data[LABEL:LABEL + 1], "leg_settle": self.data[PASSES:PASSES + 1],
                          "leg_gates": self.data[GATE0:]}
        self.reset(None)

    @classmethod
    def from_config(cls, cfg, model):
        t = cfg.options
        base = t.file.parent
        table_path = base / t.str("table", "leg/table3.toml")
        try:
            table = load_table(table_path)
        except RtctlError as e:
            raise t.error("table", f"a valid event table ({e})") from None
        use_hysteresis = t.bool("hysteresis", True)
        gates_t = t.table("gates")
        rows = np.zeros((4, table.n_gates))
        for g, name in enumerate(table.gates):
            spec = gates_t.table(name)
            channel = spec.str("channel", choices=CHANNELS)
            scale = math.pi / 180.0 if channel in ANGLES else 1.0
            rows[CHANNEL, g] = CHANNELS.index(channel)
            rows[THRESHOLD, g] = spec.float("threshold") * scale
            h = spec.float("hysteresis", 0.0, min=0.0) * scale
            rows[HALF_HYSTERESIS, g] = h / 2 if use_hysteresis else 0.0
            rows[SENSE, g] = -1.0 if spec.bool("below", False) else 1.0
            spec.done()
        gates_t.done()
        max_passes = t.int("max_passes", 0, min=1, max=64) if t.has("max_passes") else None
        semantics = t.str("semantics", "exact", choices=SEMANTICS)
        try:
            c = cls(cfg.name, model, table, rows, cfg.joints, cfg.divisor, max_passes, semantics)
        except ValueError as e:
            if str(e).startswith("max_passes"):
                raise t.error("max_passes", str(e).split(": ", 1)[1]) from None
            raise
        t.done()
        return c

    def bind(self, devices: dict) -> None:
        boards = [d for d in devices.values() if isinstance(d, LegBoard)]
        if len(devices) != 1 or len(boards) != 1:
            raise TypeError(f"{self.name} needs exactly one leg board in devices, got {', '.join(devices) or 'none'}")
        self.board = boards[0]
        self.internals = {**self.internals, "leg_actions": self.board.actions, "leg_channels": self.board.channels}

    def reset(self, state) -> None:
        self.data[:] = 0
        self.data[CODE] = self.initial_code
        self.data[LABEL] = self.labels[self.initial_code]

    def update(self, t, state, ref, command):
        board = self.board
        if board is None:
            raise RtctlError(f"{self.name}: no leg board bound")
        passes = automaton_tick(board.channels, self.gates, self.pla, self.labels, self.data, board.actions,
                                self.cm.n_bits, self.cm.max_passes)
        if passes < 0:
            raise RtctlError(f"{self.name}: the circuit did not settle within {self.cm.max_passes} passes "
                             f"(gates {self.table.gate_bits(int(self.data[WORD]))})")
