"""Exhaustive checks of a synthesised circuit against its flow table.

* :func:`agreement` — on every (state, gate vector) pair, the emulated circuit settles where
  the automaton of its semantics goes: the exits and stays the table shows, and on every
  vector the table never shows in that state **hold** (exact semantics) or the chain of
  guards (guard semantics, :mod:`rtctl.logic.guard`: an unseen vector may move the state).
* :func:`race_proof` — for every state and every gate vector, every order in which the
  excited flip-flops can switch (any non-empty subset of them first, then again from there)
  ends in one and the same stable state, with no cycle, within the settle limit.
* :func:`replay` — the event table row by row, each change between consecutive rows applied
  one bit at a time in every order, the circuit settling after each bit (fundamental mode);
  every order must end in the row's state, and the report says where and why one does not
  (under the exact semantics also an intermediate vector that moves the state: the table's
  exits must not fire early; under the guard semantics firing on the first event is the point).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import permutations

from rtctl.logic.emulate import NOT_SETTLED, CircuitModel, Emulator
from rtctl.logic.synth import Circuit


def agreement(circuit: Circuit, model: CircuitModel) -> dict:
    """Emulated circuit vs automaton on all states × 2ⁿ gate vectors."""
    flow, a = circuit.flow, circuit.assignment
    em = Emulator(model)
    mismatches, counted = [], {"exit": 0, "stay": 0, "guard": 0, "hold": 0}
    for s in flow.states:
        for x in range(1 << flow.n_gates):
            em.code = a.codes[s]
            passes = em.apply(x)
            want = circuit.next_state(s, x)
            kind = "exit" if x in flow.exits[s] else "stay" if x in flow.stay[s] else "hold" if want == s else "guard"
            counted[kind] += 1
            got = a.state_of(em.code) if passes != NOT_SETTLED else None
            out_ok = em.actuators == flow.table.outputs[want]
            if got != want or not out_ok:
                mismatches.append({"state": s, "gates": flow.table.gate_bits(x), "kind": kind, "expected": want,
                                   "got": got, "passes": passes, "actuators": flow.table.actuator_bits(em.actuators)})
    return {"pairs": sum(counted.values()), **counted, "mismatches": mismatches}


@dataclass
class RaceReport:
    checked: int = 0  # (state, gate vector) pairs explored
    races: int = 0  # pairs where the flip-flops had a choice (more than one excited at once)
    longest: int = 0  # most flip-flop changes on any path to the stable state
    failures: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.failures


def race_proof(circuit: Circuit, model: CircuitModel) -> RaceReport:
    """Every switching order of the excited flip-flops, from every state's code under every
    gate vector (see the module doc). Limit: ``model.max_passes − 1`` changes on any path."""
    flow, a = circuit.flow, circuit.assignment
    report = RaceReport()
    for s in flow.states:
        for x in range(1 << flow.n_gates):
            report.checked += 1
            finals, cyclic, longest, choice = _explore(model, a.codes[s], x)
            report.longest = max(report.longest, longest)
            report.races += choice
            want = a.codes[circuit.next_state(s, x)]
            if cyclic or finals != {want} or longest > model.max_passes - 1:
                report.failures.append({"state": s, "gates": flow.table.gate_bits(x), "finals": sorted(finals),
                                        "expected": want, "cycle": cyclic, "longest": longest})
    return report


def _explore(model: CircuitModel, start: int, x: int):
    """Depth-first over the asynchronous successors: (stable codes, cycle?, longest path, choice?)."""
    finals, on_path, memo = set(), set(), {}
    cyclic = choice = False

    def depth(q: int) -> int:
        nonlocal cyclic, choice
        if q in memo:
            return memo[q]
        if q in on_path:
            cyclic = True
            return 0
        excited = model.excited(q, x)
        if not excited:
            finals.add(q)
            memo[q] = 0
            return 0
        if excited & (excited - 1):
            choice = True
        on_path.add(q)
        best = 0
        sub = excited
        while sub:  # every non-empty subset of the excited flip-flops switches first
            best = max(best, 1 + depth(q ^ sub))
            sub = (sub - 1) & excited
        on_path.discard(q)
        memo[q] = best
        return best

    longest = depth(start)
    return finals, cyclic, longest, choice


@dataclass
class ReplayRow:
    row: int
    step: int
    changed: tuple[str, ...]  # the gates that change from the previous row
    orders: int
    ok: int
    failures: list  # {"order": [...], "state": reached, "why": ...}, at most a few kept


def replay(circuit: Circuit, model: CircuitModel, keep: int = 5) -> list[ReplayRow]:
    """Table rows in every one-at-a-time order of their changed gate bits (module doc); each
    row keeps its first ``keep`` failing orders and counts them all."""
    table, a = circuit.table, circuit.assignment
    em = Emulator(model)
    rows = []
    for k in range(len(table.states)):
        p = table.predecessor(k)
        if p is None:
            continue
        x0, x1 = table.inputs[p], table.inputs[k]
        bits = [i for i in range(table.n_gates) if (x0 ^ x1) >> i & 1]
        orders = list(permutations(bits)) if bits else [()]
        result = ReplayRow(k, table.steps[k], tuple(table.gates[i] for i in bits), len(orders), 0, [])
        for order in orders:
            em.code = a.codes[table.states[p]]
            em.apply(x0)
            x, why = x0, None
            for i in order:
                x ^= 1 << i
                before = a.state_of(em.code)
                if em.apply(x) == NOT_SETTLED:
                    why = f"did not settle after {table.gates[i]} changed (gates {table.gate_bits(x)})"
                    break
                after = a.state_of(em.code)
                if after != before and x != x1 and circuit.guard is None:
                    why = (f"the intermediate gates {table.gate_bits(x)} (after {table.gates[i]}) are an exit of "
                           f"state {before} to state {after}")
            reached = a.state_of(em.code)
            if why is None and reached == table.states[k]:
                result.ok += 1
            elif len(result.failures) < keep:
                result.failures.append({"order": [table.gates[i] for i in order], "state": reached,
                                        "why": why or f"ended in state {reached}, not {table.states[k]}"})
        rows.append(result)
    return rows
