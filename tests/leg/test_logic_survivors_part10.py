"""Tests for logic-compiler mutants that survived the suite (part 10; docs/mutation/logic.md), each
against the documentation or a count worked out by hand:

* a flow table is an immutable value, like the circuit built from it;
* a ``.pla`` product term has only 0, 1 or - in its inputs and 0, 1, - or ~ in its outputs —
  a bad input with good outputs is an error, and a bad output with good inputs;
* a PLA without product terms has all-false truth tables;
* the minimiser takes 0 to 16 variables (docs/leg_automaton.md: 16 inputs): a function of no
  variable is a constant;
* an event table has at least two rows;
* the replay of a table that is not cyclic starts at its second row (the first has no
  predecessor), and goes on to the last;
* the agreement check visits every state under every gate vector: Table 3's 6 states × 2⁸
  vectors = 1536 pairs, each counted once as an exit, a stay, a guard or a hold.
"""
import dataclasses

import pytest

from leg_helpers import TABLE3, table_refusal
from rtctl.errors import RtctlError
from rtctl.logic import CircuitModel, Pla, compile_table, load_table
from rtctl.logic.qm import minimise
from rtctl.logic.synthetic import synthetic_table
from rtctl.logic.verify import agreement, replay


def test_a_flow_table_is_immutable(circuit):
    with pytest.raises(dataclasses.FrozenInstanceError):
        circuit.flow.initial = 2


@pytest.mark.parametrize("term", ["1x 1", "2- 0", "11 x", "-0 2"])
def test_a_product_term_with_a_character_outside_its_plane_is_refused(term):
    with pytest.raises(RtctlError, match="^line 3: expected 2 input and 1 output characters"):
        Pla.from_espresso(f".i 2\n.o 1\n{term}\n.e\n")


def test_a_pla_without_terms_is_false_everywhere():
    pla = Pla.from_espresso(".i 2\n.o 1\n.e\n")
    assert pla.n_terms == 0
    assert pla.truth_tables().shape == (4, 1) and not pla.truth_tables().any()


def test_the_minimiser_takes_0_to_16_variables():
    assert minimise(0, [0]) == [(0, 0)]  # the constant 1: one term without literals
    assert minimise(0, []) == []
    assert minimise(16, [0xFFFF]) == [(0xFFFF, 0xFFFF)]
    with pytest.raises(ValueError, match=r"n must be in \[0, 16\], got 17"):
        minimise(17, [0])


def test_an_event_table_has_at_least_two_rows(tmp_path):
    text = TABLE3.read_text()
    start, end = text.index("rows = ["), text.index("]\n\n", text.index("rows = ["))
    e = table_refusal(tmp_path, text[:start] + 'rows = [\n    [1, "0010 0100", "1111", 1],\n' + text[end:])
    assert e.key_path == "rows" and "at least two rows" in e.expected


def test_the_replay_of_a_table_that_is_not_cyclic_starts_at_its_second_row(tmp_path):
    """A chain 1 → 2 → 3 → 4 → 1 written out as five rows (Gray-coded gates), not cyclic: row 0
    has no predecessor; rows 1–4 are replayed."""
    text = synthetic_table("chain", 4, 4).replace("cyclic = true", "cyclic = false")
    text = text.replace('    [4, "0100", "0010", 4],\n', '    [4, "0100", "0010", 4],\n    [5, "0110", "1000", 1],\n')
    path = tmp_path / "open.toml"
    path.write_text(text)
    table = load_table(path)
    assert not table.cyclic and len(table.states) == 5
    circuit = compile_table(table)
    rows = replay(circuit, CircuitModel.from_pla(circuit.pla, table.n_gates, circuit.n_bits))
    assert [r.row for r in rows] == [1, 2, 3, 4]


def test_the_agreement_check_counts_every_state_under_every_gate_vector(circuit, model):
    counts = agreement(circuit, model)
    assert counts["pairs"] == 6 * 2**8 == 1536
    assert counts["exit"] + counts["stay"] + counts["guard"] + counts["hold"] == 1536
    assert counts["exit"] == len(circuit.flow.transitions)


def test_the_longest_settle_counts_both_changes_of_a_non_critical_race():
    """Two flip-flops set together (J1 = J2 = g0, never reset) from 00 under g0: either may
    switch first, and 00 → 01 → 11, 00 → 10 → 11 both take two changes — the one-step jump
    00 → 11, explored first, must not shorten the paths that reach 11 after it."""
    from rtctl.logic.verify import _explore

    pla = Pla.from_functions(["g0", "Q1", "Q2"], {"J1": [(0b001, 0b001)], "K1": [], "J2": [(0b001, 0b001)],
                                                  "K2": [], "A0": [(0b010, 0b010)]})
    model = CircuitModel.from_pla(pla, 1, 2)
    finals, cyclic, longest, choice = _explore(model, 0b00, 0b1)
    assert (finals, cyclic, longest, choice) == ({0b11}, False, 2, True)
    assert _explore(model, 0b00, 0b0) == ({0b00}, False, 0, False)  # (g0 off: nothing excited)


@pytest.mark.parametrize("names", [".ilb a\n.ob y\n", ".ilb a b\n.ob y z\n", ".ilb a b c\n"])
def test_pla_names_must_match_the_counts(names):
    with pytest.raises(RtctlError, match=r"^\.ilb/\.ob do not match \.i/\.o$"):
        Pla.from_espresso(".i 2\n.o 1\n" + names + "11 1\n.e\n")


@pytest.mark.parametrize(("row", "width"), [("5", "not an array"), ('"row"', "not an array"),
                                            ('[1, "0010 0100", "1111"]', "3")])
def test_a_row_of_the_wrong_shape_says_what_it_got(tmp_path, row, width):
    text = TABLE3.read_text()
    edited = text.replace('[ 1, "0010 0100", "1111", 1]', row, 1)
    assert edited != text
    e = table_refusal(tmp_path, edited)
    assert e.key_path == "rows[0]" and f"4 columns [step, gate bits, actuator bits, state], got {width}:" in e.expected


@pytest.mark.parametrize("semantics", ["exact", "guard"])
def test_the_agreement_line_counts_guard_exits_only_under_the_guard_semantics(table3, semantics):
    """The compile report's agreement line: exits, stays, guard exits on vectors the table
    does not show — a kind only the guard semantics has — and holds."""
    from rtctl.logic.report import format_compile
    from rtctl.logic.verify import race_proof

    circuit = compile_table(table3, semantics)
    model = CircuitModel.from_pla(circuit.pla, table3.n_gates, circuit.n_bits)
    counts = agreement(circuit, model)
    text = format_compile(circuit, counts, race_proof(circuit, model))
    line = next(line for line in text.splitlines() if "circuit = automaton on all 1536" in line)
    assert ("guard exits on vectors the table does not show" in line) == (semantics == "guard"), line
    if semantics == "exact":
        assert counts["guard"] == 0


def test_an_event_table_has_the_outputs_of_at_least_two_states(tmp_path):
    text = "\n".join(line for line in TABLE3.read_text().splitlines()
                     if not (line[:1].isdigit() and line.split(" = ")[0].strip() != "1")) + "\n"
    e = table_refusal(tmp_path, text)
    assert e.key_path == "outputs" and "the outputs of at least two states" in e.expected


def test_an_event_table_is_cyclic_unless_it_says_otherwise(tmp_path):
    """configs/leg/table3.toml: ``cyclic`` is true by default."""
    text = "\n".join(line for line in TABLE3.read_text().splitlines() if not line.startswith("cyclic")) + "\n"
    path = tmp_path / "t.toml"
    path.write_text(text)
    table = load_table(path)
    assert table.cyclic and table.predecessor(0) == len(table.states) - 1


def test_an_event_table_and_a_guard_are_immutable(table3):
    from rtctl.logic.flow import flow_table, guards

    with pytest.raises(dataclasses.FrozenInstanceError):
        table3.cyclic = False
    with pytest.raises(dataclasses.FrozenInstanceError):
        guards(flow_table(table3))[0].terms = ()
