"""The minimiser's two steps against brute force on every cube: the primes through a minterm
(a superset closure over the subset lattice, packed eight sets to a word, so functions of 0 to
7 variables cross every kind of pass), and the exact cover (fewest terms, then literals)."""
import itertools

import numpy as np
from hypothesis import example, given, settings, strategies as st

from rtctl.logic.qm import exact_cover, minimise_proved, primes_through


def _function(data, n):
    values = data.draw(st.lists(st.sampled_from((0, 1, 2)), min_size=1 << n, max_size=1 << n))  # OFF, ON, don't care
    return values, [m for m, v in enumerate(values) if v == 1]


def _implicant(values, care, value):
    return all(values[m] for m in range(len(values)) if m & care == value)


def _brute_primes(n, values):
    """Every cube with no OFF minterm from which no literal can be dropped."""
    cubes = [(c, v) for c in range(1 << n) for v in range(1 << n) if v & ~c == 0 and _implicant(values, c, v)]
    return {(c, v) for c, v in cubes
            if not any(c >> b & 1 and _implicant(values, c & ~(1 << b), v & ~(1 << b)) for b in range(n))}


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 7), st.data())
def test_primes_through_a_minterm_are_every_prime_containing_it(n, data):
    values, on = _function(data, n)
    off = np.array([m for m, v in enumerate(values) if v == 0], dtype=np.int64)
    primes = _brute_primes(n, values)
    for m in on:
        assert set(primes_through(n, m, off)) == {(c, v) for c, v in primes if m & c == v}, (values, m)


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 4).flatmap(lambda n: st.lists(st.sampled_from((0, 1, 2)), min_size=1 << n, max_size=1 << n)))
@example([0, 1, 1, 1, 1, 1, 1, 0])  # a cyclic chart: no essential prime, and taking the first prime costs a term
def test_the_cover_is_the_cheapest_of_all_prime_covers(values):
    n = len(values).bit_length() - 1
    on = [m for m, v in enumerate(values) if v == 1]
    cubes, proved = minimise_proved(n, on, [m for m, v in enumerate(values) if v == 2])
    assert proved
    primes = sorted(_brute_primes(n, values))
    covered = [sum(1 << j for j, m in enumerate(on) if m & c == v) for c, v in primes]
    full = (1 << len(on)) - 1
    best = min(((k, sum(primes[i][0].bit_count() for i in combo)) for k in range(len(cubes) + 1)
                for combo in itertools.combinations(range(len(primes)), k)
                if _or(covered[i] for i in combo) == full), default=None)
    assert best == (len(cubes), sum(c.bit_count() for c, _ in cubes)), (values, cubes)


def test_a_spent_budget_returns_a_cover_and_says_it_is_not_proved():
    """A chart with few essential primes: one node cannot finish the search."""
    on = list(range(8))
    primes = [(0b111, m) for m in on] + [(0b110, m & 0b110) for m in on[::2]] + [(0b011, m & 0b011) for m in on[:4]]
    cubes, proved = exact_cover(on, primes, budget=1)
    assert not proved and all(any(m & c == v for c, v in cubes) for m in on)
    assert exact_cover(on, primes)[1]


def _or(masks):
    out = 0
    for m in masks:
        out |= m
    return out
