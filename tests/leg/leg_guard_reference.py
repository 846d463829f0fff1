"""An independent reference for the guard semantics (docs/leg_automaton.md, "Two semantics"),
written from the event table's rows and not from rtctl.logic: the guards by brute force over
all 3ⁿ product terms, δ by following them one state at a time."""
from itertools import product


def seen_and_exits(table):
    """Per state the gate vectors seen in it (stays and exits); {(state, vector): next}."""
    seen = {s: set() for s in table.state_labels}
    exits = {}
    n = len(table.states)
    for k in range(n):
        x, s = table.inputs[k], table.states[k]
        seen[s].add(x)
        p = table.states[(k - 1) % n]
        if p != s:
            exits.setdefault((p, x), s)
            seen[p].add(x)
    return seen, exits


def _meet(a, b) -> bool:
    """Two cubes (care, value) share a vector."""
    return all(not (a[0] >> i & 1 and b[0] >> i & 1 and (a[1] ^ b[1]) >> i & 1) for i in range(16))


def brute_guards(table):
    """{(state, next): [cubes]}: every cube of fewest literals holding on the exit's vector and
    on no other vector seen in the state — less those a guard of the way back can hold with,
    unless that is all of them."""
    n = table.n_gates
    seen, exits = seen_and_exits(table)
    cubes = []
    for lits in product((None, 0, 1), repeat=n):
        care = sum(1 << i for i, v in enumerate(lits) if v is not None)
        value = sum(1 << i for i, v in enumerate(lits) if v == 1)
        cubes.append((care, value))
    minimal = {}
    for (s, x), t in exits.items():
        fits = [c for c in cubes if x & c[0] == c[1] and all(y & c[0] != c[1] for y in seen[s] if y != x)]
        fewest = min(bin(c[0]).count("1") for c in fits)
        minimal.setdefault((s, t), [])
        minimal[(s, t)] += [c for c in fits if bin(c[0]).count("1") == fewest and c not in minimal[(s, t)]]
    out = {}
    for (s, t), terms in minimal.items():
        back = minimal.get((t, s), [])
        keep = [c for c in terms if not any(_meet(c, b) for b in back)]
        out[(s, t)] = keep or terms
    return out


class GuardReference:
    """δ(s, x) of the guard semantics: one guard step at a time; two guards at once hold;
    a state whose steps come back to it holds; otherwise the chain stops where it is stable
    (or at the first state of a cycle it runs into)."""

    def __init__(self, table):
        self.table = table
        self.guards = brute_guards(table)

    def one_step(self, s, x):
        hits = [t for (a, t), terms in self.guards.items() if a == s and any(x & c == v for c, v in terms)]
        return hits[0] if len(hits) == 1 else s

    def next_state(self, s, x):
        path = [s]
        while True:
            t = self.one_step(path[-1], x)
            if t == path[-1]:
                return t
            if t in path:
                return t  # runs into a cycle (s itself when s is on it): that state holds
            path.append(t)
