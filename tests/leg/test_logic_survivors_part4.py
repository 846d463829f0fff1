"""Tests for the logic (leg synthesis) mutants left after the widened sample (docs/mutation/logic.md):
the two branch and bounds' pruning and budgets, each against a count made by hand or the rule
as the module documentation states it:

* the exact cover on the cyclic function Σm(0, 1, 2, 5, 6, 7): six two-literal primes around a
  cycle, no essential one; the search, followed by hand, takes 7 nodes, so it is proved with a
  budget of 7 and not with 6;
* the state assignment drops a partial assignment whose routes between placed states already
  take more steps than the best total found (rtctl.logic.assign's module doc): every placement
  the search extends is checked against a bound computed here, by a breadth-first search of
  its own, and the best total read from the routes found;
* a flip-flop count's search stops at its budget (on a synthetic star table that needs routes):
  a leaf's routes are paid for at once, so a search may end at most one leaf's transitions
  (plus the choice being tried) past it.
"""
from pathlib import Path

import pytest

from rtctl.logic import load_table
from rtctl.logic import assign
from rtctl.logic.assign import candidate_assignments
from rtctl.logic.flow import flow_table
from rtctl.logic.qm import exact_cover
from rtctl.logic.synthetic import synthetic_table

TABLE3 = Path(__file__).resolve().parents[2] / "configs" / "leg" / "table3.toml"

# Three variables (bit 0, 1, 2), minterms 0 1 5 7 6 2 around a cycle; each prime joins two
# neighbours, as (care, value): one free variable, two literals.
CYCLE = [0, 1, 2, 5, 6, 7]
P0, P1, P2 = (0b110, 0b000), (0b011, 0b001), (0b101, 0b101)  # {0,1}, {1,5}, {5,7}
P3, P4, P5 = (0b110, 0b110), (0b011, 0b010), (0b101, 0b000)  # {6,7}, {2,6}, {0,2}


def test_the_exact_cover_of_the_cyclic_function_takes_seven_nodes_by_hand():
    """Every minterm has two primes, so the minterms keep their order j0..j5 = 0 1 2 5 6 7, and
    the lower bound takes minterms no prime covers two of (2 literals each). By hand:
    1. root, bound 3 primes/6 literals; branch on minterm 0: P0 (covers two) before P5.
    2. P0: bound (1+2, 2+4) = (3, 6); branch on minterm 2: P4 (covers 2 and 6) before P5.
    3. P0 P4: bound (3, 6); branch on minterm 5: P2 (5 and 7) before P1.
    4. P0 P4 P2 covers all: the best, (3 primes, 6 literals).
    5. P0 P4 P1: bound (4, 8) ≥ (3, 6): cut.
    6. P0 P5: bound (4, 8): cut.
    7. P5: bound (1+2, 2+4) = (3, 6), not better than the best: cut.
    Seven nodes: proved within a budget of 7, not within 6. The literal part of the bound adds
    the literals already picked (2), not the primes (1): with the count, node 7 would read
    (3, 5) and be searched further."""
    primes = [P0, P1, P2, P3, P4, P5]
    assert exact_cover(CYCLE, primes, budget=7) == ([P0, P2, P4], True)
    assert exact_cover(CYCLE, primes, budget=6) == ([P0, P2, P4], False)


def _paper_flow():
    return flow_table(load_table(TABLE3))


def _steps(a: int, b: int, bits: int, held: set) -> int:
    """Single-bit steps from code a to code b through codes not in ``held``, by breadth-first search."""
    dist, frontier = {a: 0}, [a]
    while frontier and b not in dist:
        nxt = []
        for c in frontier:
            for k in range(bits):
                n = c ^ 1 << k
                if n not in dist and (n == b or n not in held):
                    dist[n] = dist[c] + 1
                    nxt.append(n)
        frontier = nxt
    assert b in dist  # (a placement the search extends has a path for every transition)
    return dist[b]


def _bound(flow, placed: list, code: dict, bits: int) -> int:
    """The module doc's bound, computed independently: each placed state in turn adds the
    fewest steps of its transitions with the states placed before it, through codes no state
    placed so far holds (none at all when the states will fill every code)."""
    size, total = 1 << bits, 0
    for k, s in enumerate(placed):
        before = set(placed[:k])
        held = {code[t] for t in placed[:k + 1]} if len(flow.states) < size else set(range(size))
        for tr in flow.transitions:
            if {tr.state, tr.next} <= before | {s} and s in (tr.state, tr.next) and tr.state != tr.next:
                other = tr.next if tr.state == s else tr.state
                total += _steps(code[other], code[s], bits, held)
    return total


def test_the_assignment_search_extends_no_placement_whose_routes_exceed_the_best(monkeypatch):
    """For the paper's Table 3: each time the search goes one state deeper, the states placed so
    far (the initial state, then the others in order) must have a bound, computed here, no
    larger than the best total found so far: the steps of the best candidates' routes, counted
    here as flip-flop changes."""
    flow = _paper_flow()
    seen = {"checked": 0}
    place = assign._Search._place

    def checked(self, i, tied, lower):
        if self.best:
            best = min(sum(len(r) - 1 for r in a.routes.values()) for a in self.best)
            bound = _bound(self.flow, [self.flow.initial, *self.others[:i]], self.code, self.bits)
            assert bound <= best, (i, dict(self.code), bound, best)
            seen["checked"] += 1
        return place(self, i, tied, lower)

    monkeypatch.setattr(assign._Search, "_place", checked)
    found = candidate_assignments(flow)
    assert found.candidates and seen["checked"] > 100  # (the rule was checked, many times)


def _star_flow(tmp_path):
    """The synthetic "star" table of six states: state 1 and each other state in turn (1 2 1 3 …
    1 6), so state 1 has five neighbours and three flip-flops need routes through spare codes."""
    path = tmp_path / "star.toml"
    path.write_text(synthetic_table("star", 6, 6))
    return flow_table(load_table(path))


@pytest.mark.parametrize("budget", [10, 20, 30, 60, 100, 200])
def test_each_flip_flop_counts_search_stops_at_its_budget(tmp_path, budget):
    """The module doc: each flip-flop count gets ``budget`` search nodes. A placement is a node,
    checked before it is made; a leaf adds its transitions' routes at once, then one node per
    choice of routes it tries, and the search stops as soon as the budget is spent. So no
    search ends more than the table's transitions plus one past its budget, and one that is not
    complete has spent it."""
    flow = _star_flow(tmp_path)
    result = candidate_assignments(flow, budget=budget)
    for bits, nodes, complete in result.tried:
        assert nodes <= budget + len(flow.transitions) + 1, (bits, nodes, budget)
        if not complete:
            assert nodes >= budget, (bits, nodes, budget)
