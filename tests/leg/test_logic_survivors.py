"""Tests for the logic (leg synthesis) mutants that survived the suite (issue 27, part 3;
docs/mutation/logic.md): the assignment search keeps one assignment per renaming of the flip-flops
(checked by trying every renaming) and tries every route choice before adding a flip-flop (the
paper's three for its table), the replay keeps at most ``keep`` failures, a synthetic table never
has more rows than its gates have distinct vectors, and the exact cover's budget counts every
node (counted from outside by profiling)."""
import sys
from itertools import permutations

import numpy as np
import pytest

from leg_helpers import TABLE3
from rtctl.logic import CircuitModel, compile_table, load_table
from rtctl.logic.assign import candidate_assignments
from rtctl.logic.flow import flow_table
from rtctl.logic.qm import exact_cover, primes_through
from rtctl.logic.synthetic import synthetic_table
from rtctl.logic.verify import replay


def _renamed(code: int, perm) -> int:
    """``code`` with flip-flop k renamed perm[k]."""
    return sum(1 << perm[k] for k in range(len(perm)) if code >> k & 1)


def _table(tmp_path, text):
    path = tmp_path / "t.toml"
    path.write_text(text)
    return load_table(path)


@pytest.mark.parametrize("which", ["table3", "random6", "complete4"])
def test_assignment_candidates_are_one_per_renaming_of_the_flip_flops(tmp_path, which):
    """Each candidate is the smallest, in code order (the states but the initial one, in
    order), of all its renamings; hence no two candidates are renamings of each other."""
    table = load_table(TABLE3) if which == "table3" else _table(tmp_path, {
        "random6": synthetic_table("random", 6, 5), "complete4": synthetic_table("complete", 4, 4)}[which])
    flow = flow_table(table)
    others = [s for s in flow.states if s != flow.initial]
    found = candidate_assignments(flow).candidates
    assert len(found) >= 2
    seen = set()
    for a in found:
        codes = [a.codes[s] for s in others]
        orbit = {tuple(_renamed(c, p) for c in codes) for p in permutations(range(a.n_bits))}
        assert min(orbit) == tuple(codes), (codes, min(orbit))
        assert not orbit & seen
        seen |= orbit


def test_replay_keeps_at_most_keep_failures(tmp_path):
    """As in test_synthesis.py: row 5 made to leave state 2 on 1010 0110, so one of row 4's two
    orders fails. keep = 0 counts it and keeps none; keep = 1 keeps it."""
    table = _table(tmp_path, TABLE3.read_text().replace('[ 5, "1110 0010"', '[ 5, "1010 0110"'))
    circuit = compile_table(table)
    model = CircuitModel.from_pla(circuit.pla, 8, circuit.n_bits)
    for keep in (0, 1):
        row4 = replay(circuit, model, keep=keep)[3]
        assert (row4.orders, row4.ok) == (2, 1)
        assert len(row4.failures) == keep


@pytest.mark.parametrize("kind", ["chain", "star", "random", "complete"])
def test_a_synthetic_table_has_distinct_gate_vectors_or_is_refused(tmp_path, kind):
    """n gates have 2ⁿ vectors: a table with more rows cannot give each row its own."""
    for gates in range(2, 6):
        for states in range(2, 9):
            try:
                text = synthetic_table(kind, states, gates)
            except ValueError:
                rows = {"chain": states, "star": 2 * (states - 1), "random": 3 * states,
                        "complete": states * (states - 1)}[kind]
                assert rows > 1 << gates  # refused only when it must be
                continue
            table = _table(tmp_path, text)
            assert len(table.inputs) <= 1 << gates
            assert len(set(table.inputs)) == len(table.inputs), (kind, states, gates)


@pytest.mark.parametrize("semantics", ["exact", "guard"])
def test_table3_needs_the_papers_three_flip_flops_in_both_semantics(table3, semantics):
    """Six states: ⌈log₂ 6⌉ = 3 flip-flops, as the paper's circuit has; the search tries every
    conflict-free choice of routes before it adds a fourth (one route choice per placement is
    not enough under the guard semantics)."""
    circuit = compile_table(table3, semantics)
    assert circuit.n_bits == 3
    assert circuit.search.tried[0][0] == 3 and len(circuit.search.tried) == 1


def _count_calls(fn, name, *args, **kw):
    """fn(*args, **kw) and how many times a function called ``name`` in rtctl/logic/qm.py ran."""
    calls = [0]

    def profile(frame, event, arg):
        if event == "call" and frame.f_code.co_name == name and frame.f_code.co_filename.endswith("qm.py"):
            calls[0] += 1

    sys.setprofile(profile)
    try:
        result = fn(*args, **kw)
    finally:
        sys.setprofile(None)
    return result, calls[0]


def test_the_cover_budget_counts_every_branch_and_bound_node():
    """A cyclic chart (no essential primes: x̄ȳ, ȳz, xz, xy, yz̄, x̄z̄ around the 3-cube's ring of
    six minterms) needs branching. With a budget of exactly the nodes the search visits
    (counted from outside, by profiling its recursive ``search``) the cover is proved minimum;
    with one node less it is not."""
    on = [0, 1, 5, 7, 6, 2]  # the ring 000-001-101-111-110-010 (bit 0 = x)
    primes = sorted({p for m in on for p in primes_through(3, m, np.array([3, 4]))})
    assert len(primes) == 6
    (cover, proved), nodes = _count_calls(exact_cover, "search", on, primes, budget=10_000)
    assert proved and len(cover) == 3 and nodes > 1
    assert exact_cover(on, primes, budget=nodes) == (cover, True)
    assert exact_cover(on, primes, budget=nodes - 1)[1] is False
