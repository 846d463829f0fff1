"""Two-level minimisation after Quine and McCluskey: prime implicants, then an exact cover.

A function of ``n`` variables is given by its ON-set and don't-care set (minterms as ints,
bit i = variable i); everything else is its OFF-set. A product term is a *cube*
``(care, value)``: the minterms m with ``m & care == value``.

1. Prime implicants. A cube containing ON minterm m is an implicant iff it contains no OFF
   minterm o, i.e. iff its free variables include none of the difference sets ``m ^ o``;
   the primes through m are the maximal free sets including none. This yields exactly the primes Quine–McCluskey's merging
   table would that cover at least one ON minterm (the others never enter a cover), without
   building the table's many don't-care-only implicants.
2. The prime implicant chart is covered exactly (essential primes first, then branch and
   bound in Petrick's spirit): fewest terms, then fewest literals.

Sizes: ≤ 16 variables; up to a few hundred ON minterms per function (the cover has a budget).
"""
from __future__ import annotations

import numpy as np

Cube = tuple[int, int]

MAX_VARIABLES = 16
COVER_BUDGET = 5_000  # branch-and-bound nodes of one exact cover (see exact_cover; times in docs/leg_automaton.md)


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


# the bytes of a little-endian uint64 word whose element index has bit b clear (b = 0, 1, 2)
_LOW_BYTES = [np.uint64(0x00FF00FF00FF00FF), np.uint64(0x0000FFFF0000FFFF), np.uint64(0x00000000FFFFFFFF)]


def primes_through(n: int, m: int, off: np.ndarray) -> list[Cube]:
    """Every prime implicant containing minterm ``m`` (which must not be in ``off``).

    A free-variable set f gives an implicant iff it includes no difference ``m ^ o``: marking
    the differences and closing the marks upwards over the subset lattice, one pass per
    variable (O(n 2ⁿ), whatever the OFF-set's size), leaves unmarked exactly the implicants;
    the primes are the maximal ones. One byte per set, eight to a uint64 word: the passes
    over the three low variables are shifts within a word, the others whole-word slices."""
    if off.size == 0:
        return [(0, 0)]
    blocked = np.zeros(max(1 << n, 8), dtype=np.uint8)
    blocked[off ^ m] = 1
    bw = blocked.view("<u8")  # (little-endian whatever the machine: the byte masks assume it)
    for b in range(n):  # a set with variable b free includes the one without it
        if b < 3:
            bw |= (bw & _LOW_BYTES[b]) << np.uint64(8 << b)
        else:
            v = bw.reshape(-1, 2, 1 << (b - 3))  # (higher variables, variable b, lower words)
            v[:, 1, :] |= v[:, 0, :]
    maximal = blocked ^ 1
    mw = maximal.view("<u8")
    for b in range(n):  # maximal: freeing any further variable would include a difference
        if b < 3:
            mw &= (bw >> np.uint64(8 << b)) | ~_LOW_BYTES[b]
        else:
            v, w = mw.reshape(-1, 2, 1 << (b - 3)), bw.reshape(-1, 2, 1 << (b - 3))
            v[:, 0, :] &= w[:, 1, :]
    full = (1 << n) - 1
    return [(full & ~f, m & full & ~f) for f in np.flatnonzero(maximal[:1 << n]).tolist()]


def exact_cover(on: list[int], primes: list[Cube], budget: int = COVER_BUDGET) -> tuple[list[Cube], bool]:
    """(fewest primes covering every ON minterm, ties broken by fewest literals, then order;
    True when proved so). Branch and bound on the most constrained minterm (fewest primes); a
    subtree is cut when a lower bound — one more prime for each of a set of minterms no prime
    covers two of, with its fewest literals — cannot beat the best cover. After ``budget``
    nodes the best cover found is returned (False).

    Minterms are numbered most constrained first (stable), and sets of them are int bit masks:
    the first uncovered minterm is the lowest set bit, and a node costs a few integer operations."""
    on_arr = np.asarray(on, dtype=np.int64)
    cares = np.array([p[0] for p in primes], dtype=np.int64)
    values = np.array([p[1] for p in primes], dtype=np.int64)
    chart = (on_arr[:, None] & cares[None, :]) == values[None, :]  # [minterm, prime]
    n_rows = chart.sum(axis=1)
    if not n_rows.all():
        raise ValueError("an ON minterm is covered by no prime")
    chart = chart[np.argsort(n_rows, kind="stable")]
    literals = [p[0].bit_count() for p in primes]
    rows = [np.flatnonzero(r).tolist() for r in chart]  # minterm j → the primes covering it
    covered = [_mask(col) for col in chart.T]  # prime i → the minterms it covers
    clash = [_or(covered[i] for i in r) for r in rows]  # minterm j → minterms sharing a prime with it
    fewest = [min(literals[i] for i in r) for r in rows]
    chosen = {r[0] for r in rows if len(r) == 1}  # essential primes: the only prime covering some minterm
    left = (1 << len(rows)) - 1 & ~_or(covered[i] for i in chosen)
    best: list = [None, (len(primes) + 1, 0)]
    nodes = [0]

    def lower_bound(uncovered: int) -> tuple[int, int]:
        count = lits = 0
        while uncovered:  # greedily, most constrained first: minterms no prime covers two of
            j = (uncovered & -uncovered).bit_length() - 1
            count, lits = count + 1, lits + fewest[j]
            uncovered &= ~clash[j]
        return count, lits

    def search(uncovered: int, picked: tuple[int, ...], n_lits: int):
        nodes[0] += 1
        cost = (len(picked), n_lits)
        if not uncovered:
            if cost < best[1]:
                best[0], best[1] = picked, cost
            return
        more, lits = lower_bound(uncovered)
        if (cost[0] + more, cost[1] + lits) >= best[1] or (best[0] is not None and nodes[0] > budget):
            return
        j = (uncovered & -uncovered).bit_length() - 1
        for i in sorted(rows[j], key=lambda i: (-(covered[i] & uncovered).bit_count(), literals[i], i)):
            search(uncovered & ~covered[i], picked + (i,), n_lits + literals[i])

    search(left, (), 0)
    return [primes[i] for i in sorted(chosen | set(best[0]))], nodes[0] <= budget


def _mask(flags: np.ndarray) -> int:
    """A bool vector as an int bit mask (bit j = flags[j])."""
    return int.from_bytes(np.packbits(flags, bitorder="little").tobytes(), "little")


def _or(masks) -> int:
    out = 0
    for m in masks:
        out |= m
    return out


def evaluate(cubes: list[Cube], n: int) -> np.ndarray:
    """The truth table of a sum of products over all 2ⁿ minterms (bool array)."""
    m = np.arange(1 << n, dtype=np.int64)
    out = np.zeros(m.size, dtype=bool)
    for care, value in cubes:
        out |= (m & care) == value
    return out
