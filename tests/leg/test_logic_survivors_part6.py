"""Tests for logic (leg synthesis) mutants left by the full run (docs/mutation/logic.md): the event
table's checks, the PLA's input limit and the synthetic tables, each against the module
documentation, docs/leg_automaton.md or a property worked out by hand:

* a table may have 12 gates (rtctl.logic.table's module doc: at most 12), and one of 13 is
  refused when it is loaded, naming ``gates``;
* gate and actuator names are a non-empty array of distinct names of letters, digits and ``_``:
  a name using every one of those characters is accepted; an empty array, an empty name, a
  name with a space or a hyphen, and a name that is not a string are refused, naming the key;
* a name used for a gate and an actuator is refused, the message naming every such name;
* an ``[outputs]`` key that is not a number, or ``rows`` that are not an array, is a
  configuration error, not a crash;
* two conflicting rows: the message gives the next state each row says;
* the PLA's inputs are the gates then the flip-flops Q1…Qb (rtctl.logic.synth's module doc);
* gates + flip-flops at most the minimiser's inputs: exactly as many compiles, one more is
  refused naming ``gates`` with the number of gates the flip-flops leave room for;
* the "random" synthetic cycle never closes on state 1 twice (its last row is not in state 1,
  the first row's state), for many seeds, and every one of its rows changes state;
* the "complete" synthetic cycle takes every ordered pair of distinct states exactly once, the
  last row leading back to the first (n(n − 1) rows, starting in state 1).
"""
from collections import Counter
from pathlib import Path

import pytest

from rtctl.errors import ConfigError
from rtctl.logic import compile_table, load_table
from rtctl.logic.synthetic import state_sequence, synthetic_table

TABLE3 = Path(__file__).resolve().parents[2] / "configs" / "leg" / "table3.toml"

LETTERS = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"


def _table_text(gates, actuators=('"A"',), n_gates=None):
    """A valid two-state cycle (1 on all gates low, 2 on gate 0 high) with the given names;
    ``gates`` and ``actuators`` are written as TOML literals."""
    n = len(gates) if n_gates is None else n_gates
    low, high = "0" * n, "1" + "0" * (n - 1)
    return (f'name = "t"\ncyclic = true\ngates = [{", ".join(gates)}]\n'
            f'actuators = [{", ".join(actuators)}]\n'
            f'rows = [\n    [1, "{low}", "0", 1],\n    [2, "{high}", "1", 2],\n]\n\n[outputs]\n1 = "0"\n2 = "1"\n')


def _load(tmp_path, text):
    path = tmp_path / "t.toml"
    path.write_text(text)
    return load_table(path)


def test_twelve_gates_load_and_thirteen_are_refused_naming_gates(tmp_path):
    twelve = [f'"g{i}"' for i in range(12)]
    assert _load(tmp_path, _table_text(twelve)).n_gates == 12
    with pytest.raises(ConfigError) as e:
        _load(tmp_path, _table_text(twelve + ['"g12"']))
    assert e.value.key_path == "gates" and "at most 12 gates" in e.value.expected, e.value


def test_a_name_may_use_every_letter_digit_and_underscore(tmp_path):
    every = LETTERS + "0123456789_"
    table = _load(tmp_path, _table_text([f'"{every}"']))
    assert table.gates == (every,)


@pytest.mark.parametrize("key, names", [
    ("gates", []), ("gates", ['""']), ("gates", ['"t d"']), ("gates", ['"g-0"']), ("gates", ['"g0"', "3"]),
    ("actuators", ['"A-1"']), ("actuators", ["1"]),
])
def test_names_that_are_not_letters_digits_and_underscore_are_refused(tmp_path, key, names):
    gates, actuators = (names, ['"A"']) if key == "gates" else (['"g0"'], names)
    with pytest.raises(ConfigError) as e:
        _load(tmp_path, _table_text(gates, actuators, n_gates=1))
    assert e.value.key_path == key and "a non-empty array of names" in e.value.expected, e.value


def test_a_name_both_a_gate_and_an_actuator_is_refused_naming_it(tmp_path):
    """Gates a, b; actuators b, c (two actuator bits): b is the one name in both lists."""
    text = _table_text(['"a"', '"b"'], ['"b"', '"c"']).replace('"0", 1]', '"00", 1]').replace('"1", 2]', '"10", 2]')
    text = text.replace('1 = "0"', '1 = "00"').replace('2 = "1"', '2 = "10"')
    with pytest.raises(ConfigError) as e:
        _load(tmp_path, text)
    assert e.value.key_path == "actuators" and "names different from the gates' (both: 'b')" in e.value.expected, e.value


def test_every_name_both_a_gate_and_an_actuator_is_named(tmp_path):
    """Gates a, b, c; actuators c, b: both b and c are named, so that one edit fixes them all."""
    text = _table_text(['"a"', '"b"', '"c"'], ['"c"', '"b"']).replace('"0", 1]', '"00", 1]')
    text = text.replace('"1", 2]', '"10", 2]').replace('1 = "0"', '1 = "00"').replace('2 = "1"', '2 = "10"')
    with pytest.raises(ConfigError) as e:
        _load(tmp_path, text)
    assert "names different from the gates' (both: 'b', 'c')" in e.value.expected, e.value


def test_an_outputs_key_that_is_not_a_number_is_a_configuration_error(tmp_path):
    text = _table_text(['"g0"']) + 'x = "1"\n'
    with pytest.raises(ConfigError) as e:
        _load(tmp_path, text)
    assert e.value.key_path.endswith("x") and "a state number" in e.value.expected, e.value


def test_a_conflict_names_the_next_state_of_each_row(tmp_path):
    """Row 12 of Table 3 given row 11's gates 0011 1100 but state 2: in state 6 (row 11's
    state, row 12's predecessor) those gates hold state 6 (row 11, stable under its own gates)
    and would lead to state 2 (row 12)."""
    text = TABLE3.read_text()
    old = '[12, "0011 0100", "0111", 6]'
    assert old in text
    path = tmp_path / "t.toml"
    path.write_text(text.replace(old, '[12, "0011 1100", "1100", 2]'))
    with pytest.raises(ConfigError) as e:
        load_table(path)
    assert e.value.key_path == "rows[11]", e.value
    assert "in state 6 the gates 00111100 lead to state 6 there and to state 2 here" in e.value.expected, e.value


def test_the_pla_inputs_are_the_gates_then_q1_to_qb(circuit, table3):
    """Table 3 needs three flip-flops (docs/leg_automaton.md §3)."""
    assert circuit.pla.inputs == table3.gates + ("Q1", "Q2", "Q3")


def test_gates_plus_flip_flops_may_fill_the_minimisers_inputs_but_not_exceed_them(table3, monkeypatch):
    """Table 3: 8 gates and 3 flip-flops, 11 PLA inputs. With the minimiser's limit at 11 it
    compiles; at 10 it is refused naming ``gates``: 10 − 3 = 7 gates at most, 8 given."""
    import rtctl.logic.synth as synth

    monkeypatch.setattr(synth, "MAX_VARIABLES", 11)
    assert compile_table(table3).n_bits == 3
    monkeypatch.setattr(synth, "MAX_VARIABLES", 10)
    with pytest.raises(ConfigError) as e:
        compile_table(table3)
    assert e.value.key_path == "gates", e.value
    assert e.value.expected.startswith("at most 7 gates for a table that needs 3 flip-flops"), e.value
    assert "at most 10); got 8" in e.value.expected, e.value


@pytest.mark.parametrize("n_states", [3, 4, 5, 7])
def test_the_random_cycle_does_not_end_in_state_1(n_states):
    """The cycle starts in state 1; its last row is the first row's predecessor, so it must be
    in another state (a row may not repeat its successor's state)."""
    for seed in range(60):
        seq = state_sequence("random", n_states, seed)
        assert seq[0] == 1 and seq[-1] != 1, (seed, seq)


@pytest.mark.parametrize("n_states", range(2, 17))
def test_every_row_of_the_random_cycle_changes_state(n_states):
    """The module doc: a tour, then random jumps — every row leaves the state of the row before
    it, the first row the last one's (the cycle closes). The last row's fix-up away from state 1
    once put it in its predecessor's state (115 of 4500 sequences)."""
    for seed in range(300):
        seq = state_sequence("random", n_states, seed)
        assert len(seq) == 3 * n_states and sorted(set(seq)) == list(range(1, n_states + 1))
        assert all(a != b for a, b in zip(seq, seq[1:] + seq[:1])), (seed, seq)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_the_complete_cycle_takes_every_ordered_pair_once(n):
    seq = state_sequence("complete", n)
    assert len(seq) == n * (n - 1) and seq[0] == 1
    pairs = Counter(zip(seq, seq[1:] + seq[:1]))  # the last row leads back to the first
    assert pairs == Counter({(s, t): 1 for s in range(1, n + 1) for t in range(1, n + 1) if s != t})


def test_the_complete_table_loads_with_n_states(tmp_path):
    """Four states, each left for the three others: 12 rows over 4 gates, every state 1…4."""
    table = _load(tmp_path, synthetic_table("complete", 4, 4))
    assert len(table.states) == 12 and sorted(set(table.states)) == [1, 2, 3, 4]


@pytest.mark.parametrize("rows", ["5", '"rows"'])
def test_rows_that_are_not_an_array_are_a_configuration_error(tmp_path, rows):
    """``rows`` must be an array of at least two rows: a number or a string is refused naming
    ``rows`` (a number used to reach len() and crash)."""
    text = _table_text(['"g0"'])
    start = text.index("rows = [")
    text = text[:start] + f"rows = {rows}\n" + text[text.index("]\n\n[outputs]") + 2:]
    with pytest.raises(ConfigError) as e:
        _load(tmp_path, text)
    assert e.value.key_path == "rows" and "at least two rows" in e.value.expected, e.value
