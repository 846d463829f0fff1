"""Tests for logic-compiler mutants that survived the full run's second pass (part 11;
docs/mutation/logic.md), each against the documented contract:

* the minimiser takes 0 to 16 variables, whatever the function — a negative count is refused
  by name even when the ON-set is empty (where nothing else would notice);
* a synthetic state sequence has at least 2 states, for every kind;
* the assignment search tries ⌈log₂ states⌉ flip-flops first and at most 5 (docs/leg_automaton.md):
  a search with no budget at all reports exactly those flip-flop counts as tried;
* a state number is any non-negative integer: a table may name a state 0;
* an assignment and a guard automaton are immutable values, like the flow table and circuit;
* an event table row's state is an integer state of ``[outputs]``: a TOML boolean or float
  that equals one (``true`` == 1, ``1.0`` == 1 in Python) is refused, not read as that state;
* a random synthetic table is seed 0 unless told (the bench's tables are the same every run).
"""
import dataclasses
import re

import pytest

from leg_helpers import TABLE3, table_refusal
from rtctl.logic import CircuitModel, compile_table, load_table
from rtctl.logic.assign import AssignmentError, candidate_assignments
from rtctl.logic.flow import flow_table
from rtctl.logic.qm import minimise
from rtctl.logic.synthetic import KINDS, state_sequence
from rtctl.logic.verify import agreement


@pytest.mark.parametrize("on", [[], [0]])
def test_a_negative_variable_count_is_refused_by_name(on):
    with pytest.raises(ValueError, match=r"n must be in \[0, 16\], got -1"):
        minimise(-1, on)


@pytest.mark.parametrize("kind", KINDS)
def test_a_synthetic_sequence_has_at_least_two_states(kind):
    assert len(set(state_sequence(kind, 2))) == 2
    with pytest.raises(ValueError, match="at least 2 states, got 1"):
        state_sequence(kind, 1)


@pytest.mark.parametrize("state", ["true", "1.0"])
def test_a_rows_state_is_an_integer_not_a_value_equal_to_one(tmp_path, state):
    text = TABLE3.read_text()
    edited = text.replace('[ 1, "0010 0100", "1111", 1]', f'[ 1, "0010 0100", "1111", {state}]', 1)
    assert edited != text
    e = table_refusal(tmp_path, edited)
    assert e.key_path == "rows[0][3]" and "a state with an output in [outputs]" in e.expected


def test_a_search_without_budget_tries_from_the_fewest_flip_flops_up_to_five():
    flow = flow_table(load_table(TABLE3))  # 6 states: 3 flip-flops at least
    with pytest.raises(AssignmentError) as e:
        candidate_assignments(flow, budget=0)
    tried = [part.split(" flip-flops")[0] for part in str(e.value).split("with ")[1:]]
    assert tried == ["3", "4", "5"], str(e.value)


def test_a_table_may_name_a_state_0(tmp_path):
    """Table 3 with its state 6 renamed 0, in ``[outputs]`` and in the rows."""
    text = TABLE3.read_text()
    edited = re.sub(r", 6\]", ", 0]", text.replace('6 = "0111"', '0 = "0111"'))
    assert edited.count(", 0]") == 2
    path = tmp_path / "t.toml"
    path.write_text(edited)
    table = load_table(path)
    assert sorted(set(table.states)) == [0, 1, 2, 3, 4, 5]
    circuit = compile_table(table)
    model = CircuitModel.from_pla(circuit.pla, table.n_gates, circuit.n_bits)
    assert agreement(circuit, model)["mismatches"] == []


def test_an_assignment_and_a_guard_automaton_are_immutable(circuit):
    with pytest.raises(dataclasses.FrozenInstanceError):
        circuit.assignment.n_bits = 4
    guard = compile_table(load_table(TABLE3), semantics="guard").guard
    with pytest.raises(dataclasses.FrozenInstanceError):
        guard.flow = None


def test_a_random_synthetic_table_is_seed_zero_unless_told():
    """The bench's random tables are the same in every run: seed 0 (rtctl/logic/synthetic.py)."""
    from rtctl.logic.synthetic import state_sequence, synthetic_table

    assert state_sequence("random", 9) == state_sequence("random", 9, seed=0) != state_sequence("random", 9, seed=1)
    assert synthetic_table("random", 9, 6) == synthetic_table("random", 9, 6, seed=0)
    assert synthetic_table("random", 9, 6) != synthetic_table("random", 9, 6, seed=-1)
