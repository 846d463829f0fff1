"""Tests for the logic (leg synthesis) mutants that survived a third sample (docs/mutation/logic.md),
each against an expectation worked out by hand or taken from the documentation:

* the compile report of a two-state, one-gate table: its flip-flop is named Q1 (flip-flops are
  numbered from 1) and every state is listed with its code, the initial state at code 0;
* the emulator starts at code 0, the power-on state the report documents;
* a circuit names the semantics it was compiled with ("exact" by default, or "guard");
* the error for a non-cyclic table whose last state never leaves points at ``cyclic = false``;
* ``rtctl leg compile`` exits 0 when the synthesis agrees with its own proof and 1 when the
  circuit disagrees with its automaton, even if the race proof holds;
* the PLA matrix of a hand-made personality: column names written vertically, bottom-aligned;
* the flip-flop limit at its boundary: exactly 2**MAX_BITS states are accepted, one more refused;
* the route steps of a hand-made assignment, counted by hand;
* the "random" synthetic shape: a tour of all n states, then random jumps, 3n rows;
* the single-bit-step distance between two codes around used codes, counted by hand;
* the exact cover's tie-break between covers of as many primes: fewest literals (care bits).
"""
from types import SimpleNamespace

import numpy as np
import pytest

from rtctl.logic import CircuitModel, compile_table, load_table
from rtctl.logic import cli
from rtctl.logic.cli import leg_command
from rtctl.logic.assign import MAX_BITS, Assignment, AssignmentError, _distance, candidate_assignments
from rtctl.logic.emulate import Emulator
from rtctl.logic.flow import FlowTable
from rtctl.logic.pla import Pla
from rtctl.logic.qm import exact_cover
from rtctl.logic.report import format_compile
from rtctl.logic.synthetic import state_sequence
from rtctl.logic.verify import agreement, race_proof
from rtctl.errors import ConfigError

# Two states, one gate: state 1 (actuator off) leaves to 2 when g rises, 2 back to 1 when it falls.
TWO_STATE_TABLE = """
name = "two states"
cyclic = true
gates = ["g"]
actuators = ["A"]
rows = [
    [1, "0", "0", 1],
    [2, "1", "1", 2],
]

[outputs]
1 = "0"
2 = "1"
"""


def _circuit(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(TWO_STATE_TABLE)
    return compile_table(load_table(path))


def test_report_names_the_flip_flop_q1_and_lists_every_state(tmp_path):
    circuit = _circuit(tmp_path)
    model = CircuitModel.from_pla(circuit.pla, 1, circuit.n_bits)
    lines = format_compile(circuit, agreement(circuit, model), race_proof(circuit, model)).splitlines()
    k = lines.index("State assignment (1 J-K flip-flops, Q1; code 0 at power-on):")
    assert lines[k + 1:k + 3] == ["  state 1 = 0", "  state 2 = 1"]


def test_emulator_starts_at_the_power_on_code_0(tmp_path):
    emu = Emulator(CircuitModel.from_pla(_circuit(tmp_path).pla, 1, 1))
    assert emu.code == 0


def test_circuit_semantics_names_the_one_it_was_compiled_with(tmp_path):
    """compile_table(table, semantics): the circuit reports "exact" (the default) or "guard",
    and so does the first line of its report."""
    path = tmp_path / "t.toml"
    path.write_text(TWO_STATE_TABLE)
    table = load_table(path)
    assert compile_table(table).semantics == "exact"
    assert compile_table(table, "guard").semantics == "guard"


def test_a_non_cyclic_table_whose_last_state_never_leaves_names_cyclic_false(tmp_path):
    """The last state of a non-cyclic table has no row leaving it: the error says so and points
    at ``cyclic = false``; a cyclic table's error would not."""
    path = tmp_path / "t.toml"
    path.write_text(TWO_STATE_TABLE.replace("cyclic = true", "cyclic = false"))
    with pytest.raises(ConfigError, match=r"an exit from state 2 \(no row leaves it; cyclic = false\)"):
        load_table(path)


def _compile_args(path):
    return SimpleNamespace(leg_command="compile", pla=None, table=str(path), semantics="exact")


def test_leg_compile_exits_0_when_the_synthesis_agrees_with_its_proof(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text(TWO_STATE_TABLE)
    assert leg_command(_compile_args(path)) == 0


def test_leg_compile_exits_1_on_a_mismatch_even_when_the_race_proof_holds(tmp_path, capsys, monkeypatch):
    """A circuit that disagrees with its automaton is a bug: exit 1, whatever the race proof says."""
    path = tmp_path / "t.toml"
    path.write_text(TWO_STATE_TABLE)

    def disagreeing(circuit, model):
        agree = agreement(circuit, model)
        agree["mismatches"] = [{"state": 1, "gates": "1", "kind": "exit", "expected": 2, "got": 1}]
        return agree

    monkeypatch.setattr(cli, "agreement", disagreeing)
    assert leg_command(_compile_args(path)) == 1
    assert "1 MISMATCHES" in capsys.readouterr().out


def test_pla_matrix_writes_column_names_vertically_bottom_aligned():
    """Inputs a, Q1; outputs J1, K1', A2 (J1 = a ¬Q1, K1' = Q1, A2 = 1): names read downwards,
    bottom-aligned over their columns; then one row per product term, AND plane | OR plane."""
    terms = ((0b11, 0b01), (0b10, 0b10), (0b00, 0b00))
    plane = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=bool)
    pla = Pla(("a", "Q1"), ("J1", "K1'", "A2"), terms, plane)
    assert pla.matrix().splitlines() == [
        "        |  K ",
        "      Q | J1A",
        "     a1 | 1'2",
        "     ---+----",
        "P1   10 | 1..",
        "P2   -1 | .1.",
        "P3   -- | ..1",
    ]


def _flow_without_transitions(n_states):
    """A flow table of states 1..n_states and no transitions (no routes to place): only the
    number of states matters to the flip-flop count."""
    table = SimpleNamespace(state_labels=tuple(range(1, n_states + 1)), n_gates=1)
    return FlowTable(table, 1, {s: frozenset() for s in table.state_labels},
                     {s: {} for s in table.state_labels}, ())


def test_exactly_two_to_the_max_bits_states_fit_in_max_bits_flip_flops():
    """MAX_BITS flip-flops hold 2**MAX_BITS codes: that many states are accepted (and use all
    MAX_BITS flip-flops); one more is refused as needing more than MAX_BITS flip-flops."""
    result = candidate_assignments(_flow_without_transitions(1 << MAX_BITS), budget=100)
    assert [bits for bits, _, _ in result.tried] == [MAX_BITS]
    assert result.candidates and all(a.n_bits == MAX_BITS for a in result.candidates)
    with pytest.raises(AssignmentError, match=f"{(1 << MAX_BITS) + 1} states need more than {MAX_BITS} flip-flops"):
        candidate_assignments(_flow_without_transitions((1 << MAX_BITS) + 1), budget=100)


def test_assignment_steps_count_one_per_flip_flop_change_on_every_route():
    """Two transitions: 1 → 2 one step (00 → 01), 2 → 3 through spare code 11 (01 → 11 → 10):
    1 + 2 = 3 steps; the longest route is 2 steps, so a settle needs 3 passes."""
    a = Assignment(2, {1: 0b00, 2: 0b01, 3: 0b10}, {(1, 0): (0b00, 0b01), (2, 1): (0b01, 0b11, 0b10)})
    assert a.steps == 3
    assert a.settle_passes == 3


@pytest.mark.parametrize("n_states", [2, 5, 9])
def test_a_random_synthetic_sequence_has_3n_rows_starting_with_a_tour(n_states):
    """The "random" shape: a tour of all n states, then random jumps, 3n rows in all."""
    rows = state_sequence("random", n_states, seed=3)
    assert len(rows) == 3 * n_states
    assert sorted(rows[:n_states]) == list(range(1, n_states + 1))


def test_distance_counts_single_bit_steps_around_used_codes():
    """Two flip-flops: 00 → 11 is 2 steps (through 10 when 01 is used); 000 → 111 with 001, 010
    used goes 000 → 100 → 101 → 111 or 110 → 111: 3 steps; with 100 used too, no way."""
    assert _distance(0b00, 0b11, 2, used=1 << 0b01) == 2
    assert _distance(0b000, 0b111, 3, used=1 << 0b001 | 1 << 0b010) == 3
    assert _distance(0b000, 0b111, 3, used=1 << 0b001 | 1 << 0b010 | 1 << 0b100) is None
    assert _distance(0b01, 0b01, 2, used=0) == 0


def test_exact_cover_breaks_a_tie_in_primes_by_fewest_literals():
    """Minterm 0b0011 is covered by either of two cubes (care, value): (0b1110, 0b0010), 3
    literals, one of them positive; (0b0011, 0b0011), 2 literals, both positive. One prime
    either way, so the cover is the one with fewer literals, whichever comes first."""
    three_literals, two_literals = (0b1110, 0b0010), (0b0011, 0b0011)
    assert exact_cover([0b0011], [three_literals, two_literals]) == ([two_literals], True)
    assert exact_cover([0b0011], [two_literals, three_literals]) == ([two_literals], True)
