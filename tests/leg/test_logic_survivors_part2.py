"""Tests for the logic (leg synthesis) mutants that survived a second sample (docs/mutation/logic.md),
each against an expectation worked out by hand or taken from the documentation:

* the state assignment's default firing under the exact semantics ("each transition fires on
  its own vector"): on a small hand-made table with two exits on the same gate vector, every
  candidate keeps routes that share a spare code and step to different codes on different
  vectors, and the default equals that firing passed explicitly;
* the assignment search's pruning, counted by hand on a four-state table that two flip-flops
  cannot hold (no spare code): a placement whose transition to the initial state is not a
  single step is dropped at once, so the two-flip-flop search is complete in 5 nodes;
* a flow table's transitions are values: immutable and hashable;
* the PLA equations of a two-input, hand-made personality in the text style (``¬x``) and the
  LaTeX style (``\\bar{x}``, subscripts, ``\\,``);
* the compile report of Table 3: the transition guards as docs/leg_automaton.md §2 lists them
  (negated gates printed with ``¬``), and the two routed transitions of §3 with their codes.
"""
import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from rtctl.logic import load_table
from rtctl.logic.assign import candidate_assignments
from rtctl.logic.flow import flow_table
from rtctl.logic.pla import Pla
from rtctl.logic.report import format_compile
from rtctl.logic.verify import agreement, race_proof

# Five states, three gates. State 2 leaves to 1 and state 3 leaves to 1 on the same vector
# (g1 alone), state 4 to 5 on it too; state 1 leaves to 4 and state 5 to 3 both on g0 alone.
# Rows: [step, g0 g1 g2, actuators, state]; each state's actuator bits are its label in binary.
SAME_VECTOR_TABLE = """
name = "two exits on one gate vector"
cyclic = true
gates = ["g0", "g1", "g2"]
actuators = ["K1", "K2", "A1", "A2"]
rows = [
    [ 1, "010", "0001", 1],
    [ 2, "100", "0100", 4],
    [ 3, "010", "0101", 5],
    [ 4, "101", "0001", 1],
    [ 5, "111", "0101", 5],
    [ 6, "100", "0011", 3],
    [ 7, "010", "0001", 1],
    [ 8, "000", "0010", 2],
    [ 9, "110", "0101", 5],
    [10, "011", "0010", 2],
]

[outputs]
1 = "0001"
2 = "0010"
3 = "0011"
4 = "0100"
5 = "0101"
"""


def _flow(tmp_path, text):
    path = Path(tmp_path) / "t.toml"
    path.write_text(text)
    return flow_table(load_table(path))


def _spare_steps_conflict(assignment, flow):
    """The first (spare code, vector, two next codes) where two routes step differently from one
    spare code under the same gate vector — each exit firing on its own vector — or None."""
    vector = {(tr.state, tr.gates): tr.gates for tr in flow.transitions}
    seen = {}  # (spare code, vector) → next code
    for key, path in assignment.routes.items():
        for a, b in zip(path[1:-1], path[2:]):
            other = seen.setdefault((a, vector[key]), b)
            if other != b:
                return a, vector[key], other, b
    return None


def test_by_default_each_exit_fires_on_its_own_vector(tmp_path):
    """Exact semantics (``firing`` not given): the table's exits 1 → 4 and 5 → 3 both fire on
    g0 alone. Codes are written Q1 Q2 Q3. With 1 = 000, 2 = 100, 3 = 010, 5 = 101 and 4 = 111
    (as good as the best in route steps) 1 → 4 could run 000 → 001 → 011 → 111 and 5 → 3
    101 → 001 → 011 → 010: under g0 the spare 011 would be told to go to 111 and to 010 — a critical race the assignment must not contain. Every
    candidate is free of such a clash, and the default is the documented one: the same
    candidates as with each transition's own vector passed as its firing mask."""
    flow = _flow(tmp_path, SAME_VECTOR_TABLE)
    vectors = [tr.gates for tr in flow.transitions]
    assert len(set(vectors)) < len(vectors)  # (the point of the table: shared exit vectors)
    found = candidate_assignments(flow)
    assert found.candidates
    for a in found.candidates:
        assert _spare_steps_conflict(a, flow) is None, (a.codes, a.routes)
    own = {(tr.state, tr.gates): 1 << tr.gates for tr in flow.transitions}
    explicit = candidate_assignments(flow, firing=own)
    assert found.candidates == explicit.candidates


# Four states, two gates: 1 → 3 → 2 → 1 → 4 → 1. State 1 has three neighbours (2, 3, 4) but a
# 2-bit code only two, and with four states in four codes there is no spare code to route
# through: two flip-flops cannot do, three can.
FOUR_STATES_TABLE = """
name = "four states, no spare code in two flip-flops"
cyclic = true
gates = ["g0", "g1"]
actuators = ["K1", "K2", "A1", "A2"]
rows = [
    [1, "00", "0001", 1],
    [2, "10", "0011", 3],
    [3, "11", "0010", 2],
    [4, "01", "0001", 1],
    [5, "11", "0100", 4],
]

[outputs]
1 = "0001"
2 = "0010"
3 = "0011"
4 = "0100"
"""


def test_the_two_flip_flop_search_drops_a_placement_at_once_when_no_step_joins_it(tmp_path):
    """The module doc of rtctl.logic.assign: state 1 at code 0, the other states 2, 3, 4 in
    order, one assignment per renaming of the flip-flops; a partial assignment is dropped when
    a transition between two placed states has no path (with no spare code: when it is not a
    single step). By hand, with 2 bits (codes Q1 Q2), the nodes (placements tried) are:
    2 on 10 (a step from 00: kept) → 3 on 01 (3 → 2 is no step: dropped), 3 on 11 (1 → 3 is
    none: dropped); 2 on 01 (the renaming of 10: not canonical); 2 on 11 (2 → 1 is no step:
    dropped). Five nodes, complete (none exists). Placing 3 or 4 after 2 on 11 — the initial
    state's transitions with the first other state left out of the bound — would take more.
    With a budget of exactly 5 the two-flip-flop search is still complete."""
    flow = _flow(tmp_path, FOUR_STATES_TABLE)
    found = candidate_assignments(flow)
    assert found.tried[0] == (2, 5, True)
    assert found.tried[1][0] == 3 and found.tried[1][2] and found.candidates
    assert candidate_assignments(flow, budget=5).tried[0] == (2, 5, True)


def test_a_flow_tables_transitions_are_immutable_values(tmp_path):
    """A transition is shared by the flow table, its guards and the assignment's routes: it
    cannot be changed in place, and equal transitions hash alike (usable as keys)."""
    flow = _flow(tmp_path, SAME_VECTOR_TABLE)
    tr = flow.transitions[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        tr.next = tr.state
    assert {tr: 1}[dataclasses.replace(tr)] == 1
    assert len(set(flow.transitions)) == len(flow.transitions) == 10


def _tiny_pla():
    """Inputs a, Q1 (bit 0 = a); outputs J1, K1', A2:
    J1 = a ¬Q1 (care 11, value 01), K1' = Q1 + a ¬Q1, A2 = 1 (no literal)."""
    terms = ((0b11, 0b01), (0b10, 0b10), (0b00, 0b00))
    plane = np.array([[1, 1, 0], [0, 1, 0], [0, 0, 1]], dtype=bool)
    return Pla(("a", "Q1"), ("J1", "K1'", "A2"), terms, plane)


def test_text_equations_write_negated_literals_with_a_not_sign():
    """The default style is "text": plain names, ¬ before a negated one, terms joined by " + "."""
    pla = _tiny_pla()
    assert pla.equations() == ["J1 = a ¬Q1", "K1' = a ¬Q1 + Q1", "A2 = 1"]
    assert pla.equations("text") == pla.equations()


def test_latex_equations_bar_negated_literals_and_subscript_names():
    """The "latex" style: Q1 → Q_{1}, ¬Q1 → \\bar{Q}_{1}, K1' → K_{1}', literals joined by \\,;
    no ¬ anywhere (the plain style's sign does not belong in LaTeX)."""
    eqs = _tiny_pla().equations("latex")
    assert eqs == [r"J_{1} = a\,\bar{Q}_{1}", r"K_{1}' = a\,\bar{Q}_{1} + Q_{1}", r"A_{2} = 1"]
    assert not any("¬" in e for e in eqs)


@pytest.fixture(scope="module")
def report(circuit, model):
    return format_compile(circuit, agreement(circuit, model), race_proof(circuit, model))


def test_compile_report_lists_the_guards_of_the_papers_fig_8(report):
    """docs/leg_automaton.md §2: the guards of Table 3's eight exits, alternatives joined by
    " | ", a negated gate printed ¬g (K̄_d2 → ¬K_d2)."""
    got = {}
    for line in report.splitlines():
        m = re.fullmatch(r"  (\d) → (\d) \(step \d+\):  (.+)", line)
        if m:
            got[(int(m[1]), int(m[2]))] = set(m[3].split(" | "))
    assert got == {
        (6, 1): {"¬K_d2"}, (4, 1): {"a_d"},
        (1, 2): {"h_d1"}, (1, 5): {"h_d2"},
        (2, 3): {"h_d"}, (5, 1): {"¬h_d", "K_d1", "K_d2", "K_d3", "¬h_d2"},
        (3, 4): {"¬K_d1"}, (1, 6): {"¬t_d K_d2", "¬t_d K_d3"},
    }


def test_compile_report_names_the_routed_transitions_and_their_codes(report):
    """docs/leg_automaton.md §3: 1 = 000, 2 = 110, 4 = 101 (Q1 Q2 Q3); 1 → 2 is routed
    000 → 100 → 110 and 4 → 1 is routed 101 → 100 → 000 through the spare 100, which is an
    unstable intermediate state; 011 is unused. Every other transition changes one bit."""
    lines = report.splitlines()
    routed = [line for line in lines if " routed " in line]
    assert sorted(routed) == ["  1 → 2 routed 000 → 100 → 110 (no adjacent code is free)",
                              "  4 → 1 routed 101 → 100 → 000 (no adjacent code is free)"]
    assert "  100 spare, unstable intermediate state" in lines
    assert "  011 spare, unused (don't care)" in lines
