"""Synthetic event tables, for the compiler's limits (tests) and its timing (``rtctl bench leg``).

Every row's gate vector is the next code of a Gray sequence, so consecutive rows differ in one
gate (as a sensor sweep would) and no vector repeats: no two rows conflict. The actuator bits
of state s are s's low four bits (a Moore output). Three shapes of cycle:

* ``chain``: 1 → 2 → … → n → 1, each state left one way (the sparsest cyclic table);
* ``star``: 1 → 2 → 1 → 3 → 1 → … → n → 1, the leg table's shape (state 1 is left n − 1
  ways): the hub needs more neighbours than a code has, so transitions need routes;
* ``random``: a tour of all states in random order, then random jumps (``seed``, 0 unless
  given: the bench's tables are the same in every run), 3n rows;
* ``complete``: every state left for every other, once each (an Eulerian circuit of the
  complete graph, n(n − 1) rows): the most transitions n states can have, no assignment
  without routes, and the largest functions for the minimiser.
"""
from __future__ import annotations

import random

KINDS = ("chain", "star", "random", "complete")


def state_sequence(kind: str, n_states: int, seed: int = 0) -> list[int]:
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    if n_states < 2:
        raise ValueError(f"at least 2 states, got {n_states}")
    if kind == "chain":
        return list(range(1, n_states + 1))
    if kind == "star":
        return [s for k in range(2, n_states + 1) for s in (1, k)]
    if kind == "complete":
        return _euler_circuit(n_states)
    rng = random.Random(seed)
    tour = [1] + rng.sample(range(2, n_states + 1), n_states - 1)
    while len(tour) < 3 * n_states:
        tour.append(rng.choice([s for s in range(1, n_states + 1) if s != tour[-1]]))
    if tour[-1] == 1:  # the cycle closes on state 1: the last row needs a state other than both neighbours'
        tour[-1] = min(s for s in range(2, n_states + 1) if s != tour[-2])
    return tour


def synthetic_table(kind: str, n_states: int, n_gates: int, seed: int = 0) -> str:
    """The TOML text of a cyclic event table (see the module doc)."""
    states = state_sequence(kind, n_states, seed)
    if len(states) > 1 << n_gates:
        raise ValueError(f"{len(states)} rows need more than {n_gates} gates for distinct gate vectors")
    rows = []
    for k, s in enumerate(states):
        gray = k ^ (k >> 1)
        rows.append(f'    [{k + 1}, "{_bits(gray, n_gates)}", "{_bits(s, 4)}", {s}],')
    outputs = "\n".join(f'{s} = "{_bits(s, 4)}"' for s in range(1, n_states + 1))
    gates = ", ".join(f'"g{i}"' for i in range(n_gates))
    return (f'name = "synthetic {kind}: {n_states} states, {n_gates} gates"\ncyclic = true\n'
            f'gates = [{gates}]\nactuators = ["K1", "K2", "A1", "A2"]\nrows = [\n' + "\n".join(rows)
            + f"\n]\n\n[outputs]\n{outputs}\n")


def _euler_circuit(n: int) -> list[int]:
    """States 1…n in an order that takes every ordered pair once and closes on the first:
    Hierholzer's circuit from state 1, taking the smallest state not yet gone to first (every
    state has n − 1 ways in and out)."""
    left = {s: [t for t in range(n, 0, -1) if t != s] for s in range(1, n + 1)}
    stack, circuit = [1], []
    while stack:
        if left[stack[-1]]:
            stack.append(left[stack[-1]].pop())
        else:
            circuit.append(stack.pop())
    return circuit[::-1][:-1]


def _bits(x: int, n: int) -> str:
    return "".join("1" if x >> i & 1 else "0" for i in range(n))
