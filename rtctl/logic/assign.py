"""State assignment for an asynchronous circuit (synthesis step 3), found by search.

In fundamental mode a transition that flips two state bits at once is a race: the flip-flops
never switch at exactly the same instant, and an intermediate code may be stable or lead
elsewhere (critical). A race-free assignment gives every transition a path of single-bit
steps from the old code to the new one; where the two codes are not adjacent the path runs
through *unstable intermediate states* — spare codes that, under the transition's gate
vector, lead one bit further (never through another state's code: that state would have to
leave on a vector it holds on).

The search uses the fewest flip-flops, ⌈log₂ states⌉ (more, up to :data:`MAX_BITS`, only if
that fails), puts the initial state at code 0 (flip-flops cleared at power-on), takes one
assignment per permutation of the flip-flops (renaming them changes nothing), and keeps the
assignments whose routes have the fewest steps in total, each with every conflict-free choice
of routes. It is a branch and bound over the states in order: codes next to the state's
neighbours in the transition graph are tried first, and a partial assignment is dropped when
a renaming of the flip-flops makes it smaller, when a transition between two placed states has
no path through the codes still free, or when those paths' lengths already exceed the best
total. Each flip-flop count gets :data:`SEARCH_BUDGET` search nodes; a search that ends within
it is complete (the fewest steps, or no assignment at all), one that spends it keeps the best
it found. :mod:`rtctl.logic.synth` then picks the smallest PLA among at most
:data:`MAX_CANDIDATES` of them, and :mod:`rtctl.logic.verify` proves it race-free on the
synthesised circuit, exhaustively.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations, product

from rtctl.errors import RtctlError
from rtctl.logic.flow import FlowTable

MAX_BITS = 5
SEARCH_BUDGET = 40_000  # search nodes per flip-flop count (see docs/leg_automaton.md for the times)
MAX_CANDIDATES = 4  # assignments (in code order) synthesised to find the smallest PLA
MAX_PATHS = 8  # shortest routes kept per transition (there can be factorially many)


class AssignmentError(RtctlError):
    """No race-free state assignment was found; the message says what was tried."""


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
    def settle_passes(self) -> int:
        """Passes a settle needs: one per flip-flop change on the longest route (one flip-flop
        changes per step), and one that finds nothing more to change."""
        return max((len(r) - 1 for r in self.routes.values()), default=0) + 1

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


@dataclass(frozen=True)
class SearchResult:
    """The candidates (fewest route steps found, in code order) and, per flip-flop count tried,
    ``(bits, nodes, complete)``: complete means the search ended within its budget."""

    candidates: list
    tried: tuple


def candidate_assignments(flow: FlowTable, budget: int = SEARCH_BUDGET, firing=None) -> SearchResult:
    """Race-free assignments with the fewest route steps found (see the module doc);
    :class:`AssignmentError` saying what was tried when there is none. ``firing``: (state,
    gate vector) of each transition → the gate vectors it fires on, as an int bit mask (the
    guard semantics, :mod:`rtctl.logic.guard`); by default each fires on its own vector."""
    n_states = len(flow.states)
    if n_states > 1 << MAX_BITS:
        raise AssignmentError(f"{n_states} states need more than {MAX_BITS} flip-flops")
    tried = []
    for bits in range(max(1, (n_states - 1).bit_length()), MAX_BITS + 1):
        search = _Search(flow, bits, budget, firing)
        search.run()
        tried.append((bits, search.nodes, search.complete))
        if search.best:
            found = sorted(search.best, key=lambda a: [a.codes[s] for s in search.others])
            return SearchResult(found[:MAX_CANDIDATES], tuple(tried))
    raise AssignmentError("no race-free state assignment: " + "; ".join(
        f"with {b} flip-flops " + ("none exists" if complete else f"none found within the search budget ({n} nodes)")
        for b, n, complete in tried))


class _Search:
    """Branch and bound over the codes of the states in order (see the module doc)."""

    def __init__(self, flow: FlowTable, bits: int, budget: int, firing=None):
        self.flow, self.bits, self.budget = flow, bits, budget
        self.firing = firing or {(tr.state, tr.gates): 1 << tr.gates for tr in flow.transitions}
        self.size = 1 << bits
        self.others = [s for s in flow.states if s != flow.initial]
        self.index = {flow.initial: -1, **{s: i for i, s in enumerate(self.others)}}
        pairs: dict = {}  # (earlier-placed state, later) → how many transitions join them
        for tr in flow.transitions:
            pair = tuple(sorted((tr.state, tr.next), key=self.index.get))
            pairs[pair] = pairs.get(pair, 0) + 1
        self.back = {s: [(a, n) for (a, b), n in pairs.items() if b == s] for s in self.others}
        self.bit_perms = [p for p in permutations(range(bits))][1:]  # (the identity never makes it smaller)
        self.code = {flow.initial: 0}
        self.used = 1  # bit c set: code c is a state's
        self.best_steps, self.best = None, []
        self.nodes, self.complete = 0, True

    def run(self) -> None:
        if len(self.flow.states) <= self.size:
            self._place(0, self.bit_perms, 0)

    def _place(self, i: int, tied, lower: int) -> None:
        """Place ``others[i]`` on every free code in turn; ``lower``: the bound so far."""
        if i == len(self.others):
            self._leaf()
            return
        s = self.others[i]
        near = [self.code[t] for t, _ in self.back[s]]
        free = [c for c in range(1, self.size) if not self.used >> c & 1]
        free.sort(key=lambda c: (sum((c ^ n).bit_count() for n in near), c))
        for c in free:
            if self.nodes >= self.budget:
                self.complete = False
                return
            self.nodes += 1
            still = []
            for p in tied:  # renamings that leave the prefix as it is; one that makes it smaller: not canonical
                pc = _permute(c, p)
                if pc < c:
                    break
                if pc == c:
                    still.append(p)
            else:
                self.code[s], self.used = c, self.used | 1 << c
                more = self._added_steps(s)
                if more is not None and (self.best_steps is None or lower + more <= self.best_steps):
                    self._place(i + 1, still, lower + more)
                del self.code[s]
                self.used &= ~(1 << c)

    def _added_steps(self, s):
        """The fewest steps the transitions between ``s`` and the states placed before it can
        take: each a path through codes no placed state holds (through none at all when there
        will be no spare code); None when one has no path. Placing more states only lengthens
        these paths, so the sum over the placements bounds the total from below."""
        blocked = self.used if len(self.flow.states) < self.size else (1 << self.size) - 1
        total = 0
        for t, count in self.back[s]:
            d = _distance(self.code[t], self.code[s], self.bits, blocked)
            if d is None:
                return None
            total += count * d
        return total

    def _leaf(self) -> None:
        options = _route_options(self.flow, self.code, self.bits)
        if options is None:
            return
        self.nodes += len(options)  # (the routes' cost: a leaf is not free)
        steps = sum(len(p[0]) - 1 for p in options.values())
        if self.best_steps is not None and steps > self.best_steps:
            return
        found = []
        for choice in product(*options.values()):
            self.nodes += 1
            if _consistent(options, choice, self.firing):
                found.append(Assignment(self.bits, dict(self.code), dict(zip(options, choice))))
            if len(found) >= MAX_CANDIDATES or self.nodes >= self.budget:
                break
        if not found:
            return
        if self.best_steps is None or steps < self.best_steps:
            self.best_steps, self.best = steps, []
        self.best.extend(found)
        if len(self.best) > MAX_CANDIDATES:  # keep the first in code order, as an exhaustive search lists them
            self.best.sort(key=lambda a: [a.codes[s] for s in self.others])
            del self.best[MAX_CANDIDATES:]


def _distance(a: int, b: int, bits: int, used: int):
    """Single-bit steps from code a to code b through codes not in ``used`` (a bit set), or None."""
    seen, frontier, d = 1 << a, [a], 0
    while frontier:
        if b in frontier:
            return d
        nxt = []
        for c in frontier:
            for k in range(bits):
                n = c ^ (1 << k)
                if not seen >> n & 1 and (n == b or not used >> n & 1):
                    seen |= 1 << n
                    nxt.append(n)
        frontier, d = nxt, d + 1
    return None


def _permute(code: int, perm) -> int:
    return sum(1 << perm[k] for k in range(len(perm)) if code >> k & 1)


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
    """Shortest single-bit-step paths from a to b whose intermediate codes are spare, at most
    :data:`MAX_PATHS` of them (in code order): a breadth-first distance from b, then the paths
    that step down it."""
    dist, frontier = {b: 0}, [b]
    while frontier and a not in dist:
        nxt = []
        for c in frontier:
            for k in range(bits):
                n = c ^ (1 << k)
                if n not in dist and (n == a or n not in used):
                    dist[n] = dist[c] + 1
                    nxt.append(n)
        frontier = nxt
    if a not in dist:
        return []
    paths = [(a,)]
    for _ in range(dist[a]):
        paths = [p + (n,) for p in paths for n in sorted(p[-1] ^ (1 << k) for k in range(bits))
                 if dist.get(n) == dist[p[-1]] - 1][:MAX_PATHS]
    return paths


def _consistent(options, choice, firing) -> bool:
    """No spare code is told to go two ways under the same gate vector: routes through one
    spare code that step to different codes fire on disjoint sets of gate vectors."""
    steps: dict = {}  # spare code → [(next code, gate vectors as a bit mask)]
    for key, path in zip(options, choice):
        for a, b in zip(path[1:-1], path[2:]):
            for other, mask in steps.setdefault(a, []):
                if other != b and mask & firing[key]:
                    return False
            steps[a].append((b, firing[key]))
    return True
