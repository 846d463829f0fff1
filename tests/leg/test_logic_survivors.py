"""Tests for the logic (leg synthesis) mutants that survived the suite (issue 27, part 3;
docs/testing.md): the assignment search keeps one assignment per renaming of the flip-flops
(checked by trying every renaming), the replay keeps at most ``keep`` failures, and a synthetic
table never has more rows than its gates have distinct vectors."""
from itertools import permutations

import pytest

from leg_helpers import TABLE3
from rtctl.logic import CircuitModel, compile_table, load_table
from rtctl.logic.assign import candidate_assignments
from rtctl.logic.flow import flow_table
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
