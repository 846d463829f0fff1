"""The event table (the leg paper's Table 3) as data: loaded from TOML and validated.

A table lists, for one walking cycle, the threshold-gate bits, the actuator bits and the
internal state at each step. Read as a flow table it says: the gates of row k, applied in the
state of row k−1, lead to the state of row k, which is stable under them (fundamental mode).
Every error names the file and the row (``rows[k]``; exit code 2 from the CLI):

* a row of the wrong width (number of columns, gate bits or actuator bits);
* more rows, states or gates than the compiler is bounded for (256, 16, 12: ``rows``, ``gates``);
* two rows that conflict (same state and gates, different next state);
* a state with no exit;
* an output that is not a function of the state (a row's actuator bits differ from the
  state's declared Moore output).

Bit vectors are packed into ints with bit i = column i (``gates[0]`` is bit 0).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rtctl.errors import ConfigError
from rtctl.tomltable import Table, load_toml

MAX_GATES = 12  # with up to 4 flip-flops: the minimiser handles 16 variables
MAX_STATES = 16  # the state-assignment search is bounded for these (docs/leg_automaton.md)
MAX_ROWS = 256  # 16 states left for each of the 15 others is 240; more rows only repeat transitions
# under other gate vectors, and the minimiser's time grows with them (docs/leg_automaton.md)

NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_")


@dataclass(frozen=True)
class EventTable:
    file: Path
    name: str
    gates: tuple[str, ...]
    actuators: tuple[str, ...]
    outputs: dict  # state → actuator bits (packed)
    steps: tuple[int, ...]
    inputs: tuple[int, ...]  # per row: gate bits (packed)
    states: tuple[int, ...]  # per row
    cyclic: bool

    @property
    def n_gates(self) -> int:
        return len(self.gates)

    @property
    def n_actuators(self) -> int:
        return len(self.actuators)

    @property
    def state_labels(self) -> tuple[int, ...]:
        return tuple(sorted(self.outputs))

    def gate_bits(self, x: int) -> str:
        return bits_to_str(x, self.n_gates)

    def actuator_bits(self, z: int) -> str:
        return bits_to_str(z, self.n_actuators)

    def predecessor(self, k: int) -> int | None:
        """Index of the row before row ``k`` (the last row before the first if cyclic)."""
        if k > 0:
            return k - 1
        return len(self.states) - 1 if self.cyclic else None

    def row_key(self, k: int) -> str:
        return f"rows[{k}]"


def bits_to_str(x: int, n: int) -> str:
    return "".join("1" if x >> i & 1 else "0" for i in range(n))


def parse_bits(t: Table, key: str, value, n: int, what: str) -> int:
    """``"0010 0100"`` (first character = bit 0) → int; ConfigError naming ``key``."""
    if not isinstance(value, str):
        raise t.error(key, f"{n} {what} as a string of 0 and 1, got {value!r}")
    bits = value.replace(" ", "").replace("_", "")
    if len(bits) != n or set(bits) - {"0", "1"}:
        raise t.error(key, f"{n} {what} (0 or 1), got {value!r} ({len(bits)} characters)")
    return sum(1 << i for i, c in enumerate(bits) if c == "1")


def _names(t: Table, key: str) -> tuple[str, ...]:
    names = t.raw(key)
    if (not isinstance(names, list) or not names
            or not all(isinstance(x, str) and x and set(x) <= NAME_CHARS for x in names)):
        raise t.error(key, f"a non-empty array of names (letters, digits, _), got {names!r}")
    if len(set(names)) != len(names):
        raise t.error(key, "distinct names")
    return tuple(names)


def load_table(path) -> EventTable:
    """Load and validate an event table (see the module doc)."""
    t = load_toml(path)
    name = t.str("name", Path(path).stem)
    cyclic = t.bool("cyclic", True)
    gates = _names(t, "gates")
    actuators = _names(t, "actuators")
    shared = sorted(set(gates) & set(actuators))
    if shared:
        raise t.error("actuators", f"names different from the gates' (both: {', '.join(map(repr, shared))})")
    if len(gates) > MAX_GATES:
        raise t.error("gates", f"at most {MAX_GATES} gates (the circuit's PLA has gates + flip-flops ≤ 16 inputs)")
    outputs = _outputs(t.table("outputs"), len(actuators))
    steps, inputs, states = _rows(t, len(gates), len(actuators), outputs)
    t.done()
    if len(set(states)) > MAX_STATES:
        raise t.error("rows", f"at most {MAX_STATES} states, got {len(set(states))}")
    table = EventTable(Path(path), name, gates, actuators, outputs, steps, inputs, states, cyclic)
    check_flow(table)
    return table


def _outputs(t: Table, n_act: int) -> dict:
    out = {}
    for key in list(t.data):
        try:
            state = int(key)
        except ValueError:
            raise t.error(key, "a state number (1, 2, …) as the key") from None
        if state < 0 or str(state) != key.strip():
            raise t.error(key, "a non-negative state number as the key")
        out[state] = parse_bits(t, key, t.raw(key), n_act, "actuator bits")
    if len(out) < 2:
        raise t.error("", "the outputs of at least two states")
    t.done()
    return out


def _rows(t: Table, n_gates: int, n_act: int, outputs: dict):
    rows = t.raw("rows")
    if not isinstance(rows, list) or len(rows) < 2:
        raise t.error("rows", "an array of at least two rows [step, gate bits, actuator bits, state]")
    if len(rows) > MAX_ROWS:
        raise t.error("rows", f"at most {MAX_ROWS} rows, got {len(rows)}")
    steps, inputs, states = [], [], []
    for k, row in enumerate(rows):
        key = f"rows[{k}]"
        if not isinstance(row, list) or len(row) != 4:
            width = len(row) if isinstance(row, list) else "not an array"
            raise t.error(key, f"4 columns [step, gate bits, actuator bits, state], got {width}: {row!r}")
        step, g, a, s = row
        if isinstance(step, bool) or not isinstance(step, int):
            raise t.error(f"{key}[0]", f"the step number, got {step!r}")
        x = parse_bits(t, f"{key}[1]", g, n_gates, "gate bits")
        z = parse_bits(t, f"{key}[2]", a, n_act, "actuator bits")
        if isinstance(s, bool) or not isinstance(s, int) or s not in outputs:
            raise t.error(f"{key}[3]", f"a state with an output in [outputs] ({', '.join(map(str, sorted(outputs)))}), got {s!r}")
        if z != outputs[s]:
            raise t.error(f"{key}[2]", f"the output of state {s} ({bits_to_str(outputs[s], n_act)} in outputs.{s}), "
                                       f"got {a!r}: an output must be a function of the state")
        steps.append(step)
        inputs.append(x)
        states.append(s)
    unused = sorted(set(outputs) - set(states))
    if unused:
        raise t.error(f"outputs.{unused[0]}", "a state that some row is in")
    return tuple(steps), tuple(inputs), tuple(states)


def check_flow(table: EventTable) -> None:
    """Conflicting rows and states without an exit (see the module doc)."""
    seen: dict[tuple[int, int], tuple[int, int]] = {}  # (state, gates) → (next state, row)

    def define(state, x, nxt, k):
        old = seen.setdefault((state, x), (nxt, k))
        if old[0] != nxt:
            j = old[1]
            raise ConfigError(table.file, table.row_key(k),
                              f"no conflict with rows[{j}] (step {table.steps[j]}): in state {state} the gates "
                              f"{table.gate_bits(x)} lead to state {old[0]} there and to state {nxt} here")

    for k, (x, s) in enumerate(zip(table.inputs, table.states)):
        p = table.predecessor(k)
        if p is not None:
            define(table.states[p], x, s, k)
        define(s, x, s, k)  # fundamental mode: the new state is stable under the same gates
    exits = {s for (s, _), (nxt, _) in seen.items() if nxt != s}
    for s in table.state_labels:
        if s not in exits:
            k = max(i for i, st in enumerate(table.states) if st == s)
            raise ConfigError(table.file, table.row_key(k),
                              f"an exit from state {s} (no row leaves it{'' if table.cyclic else '; cyclic = false'})")
