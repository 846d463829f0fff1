"""Two-level minimisation after Quine and McCluskey: prime implicants, then an exact cover.

A function of ``n`` variables is given by its ON-set and don't-care set (minterms as ints,
bit i = variable i); everything else is its OFF-set. A product term is a *cube*
``(care, value)``: the minterms m with ``m & care == value``.

1. Prime implicants. A cube containing ON minterm m is an implicant iff it contains no OFF
   minterm o, i.e. iff its free variables include none of the difference sets ``m ^ o`` —
   so only the inclusion-minimal differences matter, and the primes through m are the
   maximal free sets avoiding them. This yields exactly the primes Quine–McCluskey's merging
   table would that cover at least one ON minterm (the others never enter a cover), without
   building the table's many don't-care-only implicants.
2. The prime implicant chart is covered exactly (essential primes first, then branch and
   bound in Petrick's spirit): fewest terms, then fewest literals.

Sizes here are small (≤ 16 variables; a handful of ON minterms per function).
"""
from __future__ import annotations

import numpy as np

Cube = tuple[int, int]

MAX_VARIABLES = 16
COVER_BUDGET = 20_000  # branch-and-bound nodes of one exact cover (see exact_cover)


def minimise(n: int, on, dc=()) -> list[Cube]:
    """An exact minimum sum of products for ON-set ``on`` with don't-cares ``dc`` (within the
    cover's budget: see :func:`minimise_proved`)."""
    return minimise_proved(n, on, dc)[0]


def minimise_proved(n: int, on, dc=()) -> tuple[list[Cube], bool]:
    """(a minimum sum of products, True when the cover is proved minimum; False when
    :func:`exact_cover` spent its budget and returned the best cover it found)."""
    if not 0 <= n <= MAX_VARIABLES:
        raise ValueError(f"n must be in [0, {MAX_VARIABLES}], got {n}")
    on = _minterms(on, n)
    dc = _minterms(dc, n)
    if np.intersect1d(on, dc).size:
        raise ValueError("a minterm is both in the ON-set and a don't-care")
    if on.size == 0:
        return [], True
    space = np.arange(1 << n, dtype=np.int64)
    off = np.setdiff1d(space, np.union1d(on, dc))
    primes = sorted({p for m in on.tolist() for p in primes_through(n, m, off)})
    return exact_cover(on.tolist(), primes)


def _minterms(values, n: int) -> np.ndarray:
    arr = np.unique(np.asarray(list(values) if not isinstance(values, np.ndarray) else values, dtype=np.int64))
    if arr.size and (arr[0] < 0 or arr[-1] >= 1 << n):
        raise ValueError(f"minterms must be in [0, {1 << n})")
    return arr


def primes_through(n: int, m: int, off: np.ndarray) -> list[Cube]:
    """Every prime implicant containing minterm ``m`` (which must not be in ``off``)."""
    full = (1 << n) - 1
    if off.size == 0:
        return [(0, 0)]
    minimal = _minimal_sets((off ^ m).tolist())
    free = np.arange(1 << n, dtype=np.int64)
    ok = np.ones(free.size, dtype=bool)
    for d in minimal:
        ok &= (free & d) != d  # the cube's free variables must not include a whole difference
    maximal = ok.copy()
    for b in range(n):
        bit = 1 << b
        grows = ((free & bit) == 0) & ok[free | bit]
        maximal &= ~grows
    out = []
    for f in np.flatnonzero(maximal).tolist():
        care = full & ~f
        out.append((care, m & care))
    return out


def _minimal_sets(sets: list[int]) -> list[int]:
    """The inclusion-minimal elements of a family of bit sets."""
    keep: list[int] = []
    for s in sorted(set(sets), key=int.bit_count):
        if not any(k & s == k for k in keep):
            keep.append(s)
    return keep


def covers(cube: Cube, m: int) -> bool:
    care, value = cube
    return m & care == value


def exact_cover(on: list[int], primes: list[Cube], budget: int = COVER_BUDGET) -> tuple[list[Cube], bool]:
    """(fewest primes covering every ON minterm, ties broken by fewest literals, then order;
    True when proved so). Branch and bound; a subtree is cut when a lower bound — one more
    prime for each of a set of minterms no prime covers two of, with its fewest literals —
    cannot beat the best cover. After ``budget`` nodes the best cover found is returned (False)."""
    rows = {m: frozenset(i for i, p in enumerate(primes) if covers(p, m)) for m in on}
    if any(not r for r in rows.values()):
        raise ValueError("an ON minterm is covered by no prime")
    literals = [p[0].bit_count() for p in primes]
    fewest = {m: min(literals[i] for i in r) for m, r in rows.items()}
    chosen: set[int] = set()
    # essential primes: the only prime covering some minterm
    for m, r in rows.items():
        if len(r) == 1:
            chosen |= r
    left = [m for m in on if not rows[m] & chosen]
    best: list = [None, (len(primes) + 1, 0)]
    nodes = [0]

    def lower_bound(uncovered: list[int]) -> tuple[int, int]:
        taken: set[int] = set()
        count = lits = 0
        for u in sorted(uncovered, key=lambda u: len(rows[u])):
            if not rows[u] & taken:
                taken |= rows[u]
                count, lits = count + 1, lits + fewest[u]
        return count, lits

    def search(uncovered: list[int], picked: tuple[int, ...]):
        nodes[0] += 1
        cost = (len(picked), sum(literals[i] for i in picked))
        if not uncovered:
            if cost < best[1]:
                best[0], best[1] = picked, cost
            return
        more, lits = lower_bound(uncovered)
        if (cost[0] + more, cost[1] + lits) >= best[1] or (best[0] is not None and nodes[0] > budget):
            return
        m = min(uncovered, key=lambda u: len(rows[u]))  # most constrained minterm first
        for i in sorted(rows[m], key=lambda i: (-sum(1 for u in uncovered if i in rows[u]), literals[i], i)):
            search([u for u in uncovered if i not in rows[u]], picked + (i,))

    search(left, ())
    return [primes[i] for i in sorted(chosen | set(best[0]))], nodes[0] <= budget


def evaluate(cubes: list[Cube], n: int) -> np.ndarray:
    """The truth table of a sum of products over all 2ⁿ minterms (bool array)."""
    m = np.arange(1 << n, dtype=np.int64)
    out = np.zeros(m.size, dtype=bool)
    for care, value in cubes:
        out |= (m & care) == value
    return out
