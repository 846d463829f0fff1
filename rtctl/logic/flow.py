"""Flow table and transition guards (synthesis steps 1 and 2).

The flow table of an event table: for each state, the gate vectors seen while it is stable
(*stay* inputs) and the vectors that move it on (*exits*). Every other vector — never seen in
that state — **holds** the state: the circuit is specified on all 2ⁿ gate vectors of every
state, so a sensor reading the table never lists cannot move the leg (safe by construction).

The *guards* are what the paper's state-transition matrix shows: for each exit, the smallest
product terms over the gates that contain its vector and exclude every other vector specified
in that state. They name the events that tell the exits apart; the circuit itself implements
the exact flow table above.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

from rtctl.logic.table import EventTable


@dataclass(frozen=True)
class Transition:
    state: int
    gates: int
    next: int
    row: int  # index of the row that shows it


@dataclass(frozen=True)
class FlowTable:
    table: EventTable
    initial: int
    stay: dict  # state → frozenset of gate vectors seen while stable
    exits: dict  # state → {gate vector: next state}
    transitions: tuple[Transition, ...]  # one per (state, exit vector), in row order

    @property
    def states(self) -> tuple[int, ...]:
        return self.table.state_labels

    @property
    def n_gates(self) -> int:
        return self.table.n_gates

    def next_state(self, state: int, gates: int) -> int:
        """δ(state, gates): an exit's target, else the state itself (stay, or never seen: hold)."""
        return self.exits[state].get(gates, state)

    def seen(self, state: int) -> frozenset:
        return self.stay[state] | frozenset(self.exits[state])


def flow_table(table: EventTable) -> FlowTable:
    stay = {s: set() for s in table.state_labels}
    exits = {s: {} for s in table.state_labels}
    transitions = []
    for k, (x, s) in enumerate(zip(table.inputs, table.states)):
        stay[s].add(x)
        p = table.predecessor(k)
        if p is not None and table.states[p] != s and x not in exits[table.states[p]]:
            exits[table.states[p]][x] = s
            transitions.append(Transition(table.states[p], x, s, k))
    return FlowTable(table, table.states[0], {s: frozenset(v) for s, v in stay.items()}, exits, tuple(transitions))


@dataclass(frozen=True)
class Guard:
    transition: Transition
    terms: tuple[tuple[int, int], ...]  # every minimal product term (care mask, value) over the gates


def guards(flow: FlowTable) -> list[Guard]:
    """For each exit, all product terms with the fewest literals that contain its gate vector
    and no other vector specified in the state (a minimum hitting set of the differences)."""
    n = flow.n_gates
    out = []
    for tr in flow.transitions:
        others = [y for y in flow.seen(tr.state) if y != tr.gates]
        diffs = [tr.gates ^ y for y in others]
        terms = []
        for size in range(n + 1):
            for lits in combinations(range(n), size):
                care = sum(1 << i for i in lits)
                if all(d & care for d in diffs):
                    terms.append((care, tr.gates & care))
            if terms:
                break
        out.append(Guard(tr, tuple(terms)))
    return out
