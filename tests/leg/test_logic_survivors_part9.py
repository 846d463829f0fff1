"""Tests for logic-compiler mutants that survived the suite (part 9; docs/testing.md). Each
expectation comes from the documentation, checked by an independent construction:

* synthetic tables step their gate vectors along a Gray sequence: consecutive rows differ in
  exactly one gate, and no vector repeats (the module doc of rtctl.logic.synthetic);
* at most 8 shortest routes are kept per transition (docs/leg_automaton.md), the first 8 in
  code order — checked against every shortest route enumerated as an order of bit flips;
* the search uses 3 to 5 flip-flops: 33 states need more than 5 and are refused before any
  search, 32 are searched with 5.
"""
import itertools
import tomllib
from types import SimpleNamespace

import pytest

from rtctl.logic.assign import AssignmentError, _shortest_paths, candidate_assignments
from rtctl.logic.flow import FlowTable
from rtctl.logic.synthetic import KINDS, synthetic_table


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n_states", [3, 5, 8])
def test_consecutive_synthetic_rows_differ_in_one_gate(kind, n_states):
    rows = tomllib.loads(synthetic_table(kind, n_states, 7, seed=3))["rows"]
    vectors = [row[1] for row in rows]
    assert len(set(vectors)) == len(vectors)
    for a, b in itertools.pairwise(vectors):
        assert sum(x != y for x, y in zip(a, b)) == 1, (a, b)


def _all_shortest(a: int, b: int, bits: int) -> list[tuple[int, ...]]:
    """Every shortest single-bit-step path a → b (all codes spare): one per order of the bits
    in which a and b differ, sorted in code order."""
    differ = [k for k in range(bits) if (a ^ b) >> k & 1]
    paths = []
    for order in itertools.permutations(differ):
        path, c = [a], a
        for k in order:
            c ^= 1 << k
            path.append(c)
        paths.append(tuple(path))
    return sorted(paths)


@pytest.mark.parametrize(("a", "b", "bits"), [(0, 31, 5), (0, 15, 4), (5, 26, 5), (0, 7, 3), (1, 2, 2)])
def test_the_first_eight_shortest_routes_are_kept_in_code_order(a, b, bits):
    expected = _all_shortest(a, b, bits)
    assert _shortest_paths(a, b, bits, {a, b}) == expected[:8]


def _states_only(n_states: int) -> FlowTable:
    """A flow table of n states and no transitions: only the state count matters."""
    table = SimpleNamespace(state_labels=tuple(range(1, n_states + 1)), n_gates=6)
    return FlowTable(table, 1, {}, {}, ())


def test_thirty_three_states_need_more_than_five_flip_flops():
    with pytest.raises(AssignmentError, match="^33 states need more than 5 flip-flops$"):
        candidate_assignments(_states_only(33), budget=50)
    found = candidate_assignments(_states_only(32), budget=50)
    assert [bits for bits, _, _ in found.tried] == [5]
