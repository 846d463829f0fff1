"""Guard semantics: every exit fires on its single gate event, as the paper's Fig. 8 draws it.

The exact semantics (:mod:`rtctl.logic.flow`) moves only on the gate vectors the event table
shows and holds on every other one. Under the guard semantics an exit fires on its *guard*:
the sum of the product terms with the fewest literals that contain its vector and no other
vector seen in its state (:func:`rtctl.logic.flow.guards`; for Table 3 one gate literal each,
like the terms of the paper's Eqs. (1)–(3)). On every vector the table shows, both semantics
agree (a guard excludes every other vector seen in its state); on the others:

* **one step** δ₁(s, x): the exit whose guard holds; hold when none does, and hold when the
  guards of two exits of s hold at once (the table cannot say which event came first);
* **chaining** (fundamental mode: the circuit settles before the gates change again): after a
  step, the new state's guards are evaluated on the same vector, and so on — two events that
  land in the same tick are both taken;
* **cycles hold**: where the steps under x would return to a state already visited, every
  state on that cycle holds under x (a cycle would be an oscillator, never a stable state);
  ``step`` is δ₁ with those holds.

δ(s, x) is where the chain stops. In a state's code every vector is specified (exit or hold);
the freedom the guard semantics leaves is in the spare codes: a spare code that no route
passes under a vector is a don't-care there (:func:`guard_spec`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rtctl.logic.flow import FlowTable, guards

DONT_CARE = -1


@dataclass(frozen=True)
class GuardAutomaton:
    flow: FlowTable
    exit_terms: dict  # (state, next state) → tuple of cubes (care, value) over the gates
    step: dict  # state → int array [2ⁿ]: δ₁ (one guard step; conflicts and cycles hold)
    final: dict  # state → int array [2ⁿ]: δ, where the chain of steps stops

    def next_state(self, state: int, gates: int) -> int:
        return int(self.final[state][gates])


def _term_mask(n: int, terms) -> np.ndarray:
    x = np.arange(1 << n, dtype=np.int64)
    hit = np.zeros(x.size, dtype=bool)
    for care, value in terms:
        hit |= (x & care) == value
    return hit


def _cubes_meet(a, b) -> bool:
    return not (a[0] & b[0] & (a[1] ^ b[1]))


def _not_back(terms, back):
    """The terms that no guard of the way back can hold with: a term that can would make the
    two states an oscillator on their common vectors, which hold (all of them when each can)."""
    keep = tuple(t for t in terms if not any(_cubes_meet(t, b) for b in back))
    return keep or terms


def guard_automaton(flow: FlowTable) -> GuardAutomaton:
    """The guard semantics of a flow table (module doc)."""
    n, states = flow.n_gates, flow.states
    exit_terms: dict = {}
    for g in guards(flow):
        key = (g.transition.state, g.transition.next)
        exit_terms[key] = tuple(dict.fromkeys(exit_terms.get(key, ()) + g.terms))
    exit_terms = {key: _not_back(terms, exit_terms.get(key[::-1], ())) for key, terms in exit_terms.items()}
    size = 1 << n
    step = {}
    for s in states:
        target = np.full(size, s, dtype=np.int64)
        fired = np.zeros(size, dtype=np.int64)
        for (a, t), terms in exit_terms.items():
            if a == s:
                hit = _term_mask(n, terms)
                target[hit] = t
                fired += hit
        target[fired > 1] = s  # two events at once: hold
        step[s] = target
    final = {s: np.empty(size, dtype=np.int64) for s in states}
    on_cycle = []
    for x in range(size):
        for s in states:
            path, t = [s], int(step[s][x])
            while t != path[-1] and t not in path:
                path.append(t)
                t = int(step[t][x])
            # t == path[-1]: stable there; otherwise t is the first state of a cycle, which holds
            # (s itself when s is on the cycle)
            final[s][x] = t
            if t == s != path[-1]:
                on_cycle.append((s, x))
    for s, x in on_cycle:
        step[s][x] = s
    return GuardAutomaton(flow, exit_terms, step, final)


def firing_masks(auto: GuardAutomaton) -> dict:
    """(state, gate vector) of each table transition → the gate vectors its one step fires on
    (an int bit mask; bit x = vector x). A second table transition between the same two states
    fires on none: the first one's route serves both."""
    out, taken = {}, set()
    for tr in auto.flow.transitions:
        pair = (tr.state, tr.next)
        hits = np.flatnonzero(auto.step[tr.state] == tr.next) if pair not in taken else []
        out[(tr.state, tr.gates)] = sum(1 << int(x) for x in hits)
        taken.add(pair)
    return out


def guard_spec(auto: GuardAutomaton, a) -> np.ndarray:
    """[code, gates] → the next code: from a state's code the first step of the route to its
    one-step target (its own code when it holds); on a spare code the next step of the route
    passing it under that vector; DONT_CARE on spare codes no route passes under that vector —
    the freedom the guard semantics leaves. Chains of exits are the circuit's own doing: the
    target's code, under the same vector, steps on by its own guard."""
    route = {(s, a.state_of(path[-1])): path for (s, _), path in a.routes.items()}
    spec = np.full((1 << a.n_bits, 1 << auto.flow.n_gates), DONT_CARE, dtype=np.int64)
    for s, c in a.codes.items():
        for x, t in enumerate(auto.step[s].tolist()):
            path = route[(s, t)] if t != s else (c, c)
            spec[c, x] = path[1]
            for p, q in zip(path[1:-1], path[2:]):
                spec[p, x] = q
    return spec
