"""State assignment for an asynchronous circuit (synthesis step 3), found by search.

In fundamental mode a transition that flips two state bits at once is a race: the flip-flops
never switch at exactly the same instant, and an intermediate code may be stable or lead
elsewhere (critical). A race-free assignment gives every transition a path of single-bit
steps from the old code to the new one; where the two codes are not adjacent the path runs
through *unstable intermediate states* — spare codes that, under the transition's gate
vector, lead one bit further (never through another state's code: that state would have to
leave on a vector it holds on).

The search uses the fewest flip-flops, ⌈log₂ states⌉ (one more only if that fails), puts the
initial state at code 0 (flip-flops cleared at power-on), takes one assignment per
permutation of the flip-flops (renaming them changes nothing), and keeps the assignments
whose routes have the fewest steps in total, each with every conflict-free choice of routes.
:mod:`rtctl.logic.synth` then picks the one with the smallest PLA, and
:mod:`rtctl.logic.verify` proves it race-free on the synthesised circuit, exhaustively.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations, product

from rtctl.logic.flow import FlowTable

MAX_BITS = 5


@dataclass(frozen=True)
class Assignment:
    n_bits: int
    codes: dict  # state → code (bit k = flip-flop Q(k+1))
    routes: dict  # (state, gate vector) → codes from the state's code to the next state's, inclusive

    @property
    def spare(self) -> tuple[int, ...]:
        used = set(self.codes.values())
        return tuple(c for c in range(1 << self.n_bits) if c not in used)

    @property
    def steps(self) -> int:
        return sum(len(r) - 1 for r in self.routes.values())

    @property
    def intermediates(self) -> dict:
        """(spare code, gate vector) → next code, for every routed transition."""
        out = {}
        for (_, x), path in self.routes.items():
            for a, b in zip(path[1:-1], path[2:]):
                out[(a, x)] = b
        return out

    def state_of(self, code: int):
        for s, c in self.codes.items():
            if c == code:
                return s
        return None

    def code_str(self, code: int) -> str:
        """Q1 Q2 … as a bit string."""
        return "".join(str(code >> k & 1) for k in range(self.n_bits))


def candidate_assignments(flow: FlowTable) -> list[Assignment]:
    """Every race-free assignment with the fewest route steps (see the module doc)."""
    n_states = len(flow.states)
    bits = max(1, (n_states - 1).bit_length())
    while bits <= MAX_BITS:
        found = _search(flow, bits)
        if found:
            return found
        bits += 1
    raise ValueError(f"no race-free assignment with at most {MAX_BITS} flip-flops")


def _search(flow: FlowTable, bits: int) -> list[Assignment]:
    others = [s for s in flow.states if s != flow.initial]
    size = 1 << bits
    bit_perms = list(permutations(range(bits)))
    best_steps, best = None, []
    for codes in permutations(range(1, size), len(others)):
        if not _canonical(codes, bit_perms):
            continue
        code = {flow.initial: 0, **dict(zip(others, codes))}
        options = _route_options(flow, code, bits)
        if options is None:
            continue
        steps = sum(len(p[0]) - 1 for p in options.values())
        if best_steps is not None and steps > best_steps:
            continue
        found = [Assignment(bits, code, dict(zip(options, choice)))
                 for choice in product(*options.values()) if _consistent(options, choice)]
        if not found:
            continue
        if best_steps is None or steps < best_steps:
            best_steps, best = steps, []
        best.extend(found)
    return best


def _permute(code: int, perm) -> int:
    return sum(1 << perm[k] for k in range(len(perm)) if code >> k & 1)


def _canonical(codes, bit_perms) -> bool:
    """True for the smallest of the assignments that differ by a renaming of the flip-flops."""
    return all(tuple(_permute(c, p) for c in codes) >= codes for p in bit_perms)


def _route_options(flow: FlowTable, code: dict, bits: int):
    """(state, gates) → every shortest single-step path through spare codes, or None."""
    used = set(code.values())
    options = {}
    for tr in flow.transitions:
        paths = _shortest_paths(code[tr.state], code[tr.next], bits, used)
        if not paths:
            return None
        options[(tr.state, tr.gates)] = paths
    return options


def _shortest_paths(a: int, b: int, bits: int, used: set) -> list[tuple[int, ...]]:
    """Breadth-first over single-bit steps; intermediate codes must be spare."""
    frontier = [(a,)]
    while frontier:
        done = [p for p in frontier if p[-1] == b]
        if done:
            return done
        nxt = []
        for p in frontier:
            for k in range(bits):
                c = p[-1] ^ (1 << k)
                if c == b or (c not in used and c not in p):
                    nxt.append(p + (c,))
        frontier = nxt
    return []


def _consistent(options, choice) -> bool:
    """No spare code is told to go two ways under the same gate vector."""
    step = {}
    for (_, x), path in zip(options, choice):
        for a, b in zip(path[1:-1], path[2:]):
            if step.setdefault((a, x), b) != b:
                return False
    return True
