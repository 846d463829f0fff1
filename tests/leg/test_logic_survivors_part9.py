"""Tests for logic-compiler mutants that survived the suite (part 9; docs/mutation/logic.md). Each
expectation comes from the documentation, checked by an independent construction:

* synthetic tables step their gate vectors along a Gray sequence: consecutive rows differ in
  exactly one gate, and no vector repeats (the module doc of rtctl.logic.synthetic);
* at most 8 shortest routes are kept per transition (docs/leg_automaton.md), the first 8 in
  code order — checked against every shortest route enumerated as an order of bit flips;
* the search uses 3 to 5 flip-flops: 33 states need more than 5 and are refused before any
  search, 32 are searched with 5;
* Table 3 compiles to the assignment docs/leg_automaton.md prints, although its two candidates
  make PLAs of the same size (15 terms, 86 literals): a tie goes to the first in code order;
* a Berkeley ``.pla`` ends at ``.e``: whatever follows it is not read; a product term before
  both ``.i`` and ``.o`` is an error naming its line;
* a row's state must have an output in ``[outputs]``: an integer state without one is a
  configuration error naming the row's state column, not a KeyError;
* a compiled circuit model is an immutable value (the model of a model/data pair: shared by
  every emulator of the circuit);
* an event table may have at most 16 states, 12 gates and 256 rows (docs/leg_automaton.md),
  the numbers written out: tests that count from the module's own constants cannot see them
  change.
"""
import dataclasses
import itertools
import tomllib
from types import SimpleNamespace

import pytest

from leg_helpers import TABLE3, table_refusal
from rtctl.errors import ConfigError, RtctlError
from rtctl.logic import Pla, compile_table, load_table
from rtctl.logic.assign import AssignmentError, _shortest_paths, candidate_assignments
from rtctl.logic.flow import FlowTable
from rtctl.logic.synthetic import KINDS, synthetic_table
from rtctl.logic.table import load_table as load_event_table


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


DOCUMENTED_TABLE3 = {1: "000", 2: "110", 3: "111", 4: "101", 5: "010", 6: "001"}  # Q1 Q2 Q3


def test_table3_compiles_to_the_documented_assignment_the_first_of_two_equal_candidates():
    circuit = compile_table(load_table(TABLE3))
    a = circuit.assignment
    assert {s: a.code_str(c) for s, c in a.codes.items()} == DOCUMENTED_TABLE3
    assert (circuit.pla.n_terms, circuit.pla.n_literals) == (15, 86)
    assert len(circuit.search.candidates) == 2 and circuit.search.candidates[0] == a


def test_a_pla_ends_at_dot_e():
    text = ".i 2\n.o 1\n.ilb a b\n.ob y\n.type f\n.p 1\n11 1\n.e\n"
    pla = Pla.from_espresso(text)
    assert pla.equations() == ["y = a b"]
    assert Pla.from_espresso(text + "0- 1\n-0 1\n").equations() == ["y = a b"]
    assert Pla.from_espresso(text + "this is not a product term\n").equations() == ["y = a b"]


@pytest.mark.parametrize("header", [".o 1\n", ".i 2\n", ""])
def test_a_product_term_before_both_dot_i_and_dot_o_names_its_line(header):
    text = header + "11 1\n.i 2\n.o 1\n.e\n"
    line = header.count("\n") + 1
    with pytest.raises(RtctlError, match=f"^line {line}: a product term before .i and .o$"):
        Pla.from_espresso(text)


def test_a_row_whose_state_has_no_output_is_a_configuration_error(tmp_path):
    text = TABLE3.read_text()
    k = next(k for k, row in enumerate(tomllib.loads(text)["rows"]) if row[3] == 2)  # the first row in state 2
    edited = text.replace('"1100", 2],', '"1100", 9],', 1)  # (its line, as Table 3 writes it)
    assert tomllib.loads(edited)["rows"][k][3] == 9
    e = table_refusal(tmp_path, edited)
    assert e.key_path == f"rows[{k}][3]" and "a state with an output in [outputs]" in e.expected


def test_a_circuit_model_is_immutable(model):
    with pytest.raises(dataclasses.FrozenInstanceError):
        model.max_passes = model.max_passes + 1


def _load(tmp_path, text):
    path = tmp_path / "t.toml"
    path.write_text(text)
    return load_event_table(path)


@pytest.mark.parametrize(("n_states", "ok"), [(16, True), (17, False)])
def test_an_event_table_has_at_most_16_states(tmp_path, n_states, ok):
    text = synthetic_table("chain", n_states, 5)
    if ok:
        assert len(_load(tmp_path, text).state_labels) == 16
    else:
        with pytest.raises(ConfigError, match="at most 16 states, got 17"):
            _load(tmp_path, text)


@pytest.mark.parametrize(("n_gates", "ok"), [(12, True), (13, False)])
def test_an_event_table_has_at_most_12_gates(tmp_path, n_gates, ok):
    text = synthetic_table("chain", 4, n_gates)
    if ok:
        assert _load(tmp_path, text).n_gates == 12
    else:
        with pytest.raises(ConfigError, match="at most 12 gates"):
            _load(tmp_path, text)


@pytest.mark.parametrize(("n_rows", "ok"), [(256, True), (257, False)])
def test_an_event_table_has_at_most_256_rows(tmp_path, n_rows, ok):
    """Two states taking turns over Gray-coded gate vectors of 9 gates (512 distinct)."""
    rows = [f'[{k + 1}, "{k ^ k >> 1:09b}", "{k & 1}", {1 + (k & 1)}],' for k in range(n_rows)]
    gates = ", ".join(f'"g{i}"' for i in range(9))
    text = (f'name = "long"\ncyclic = true\ngates = [{gates}]\nactuators = ["A"]\nrows = [\n' + "\n".join(rows)
            + '\n]\n\n[outputs]\n1 = "0"\n2 = "1"\n')
    if ok:
        assert len(_load(tmp_path, text).states) == 256
    else:
        with pytest.raises(ConfigError, match="at most 256 rows, got 257"):
            _load(tmp_path, text)


def _primes_by_brute_force(on: list[int], n: int) -> list[tuple[int, int]]:
    """Every cube (care, value) inside the ON set that no larger such cube contains."""
    ons = set(on)
    cubes = [(care, value) for care in range(1 << n) for value in range(1 << n)
             if not value & ~care and all(m in ons for m in range(1 << n) if m & care == value)]
    return [c for c in cubes if not any(d != c and c[0] & d[0] == d[0] and c[1] & d[0] == d[1] for d in cubes)]


def _cheapest_cover(on, primes) -> tuple[int, int]:
    """(primes, literals) of a minimum cover, by trying every set of primes, smallest first."""
    for r in range(1, len(primes) + 1):
        costs = [(r, sum(primes[i][0].bit_count() for i in sub)) for sub in itertools.combinations(range(len(primes)), r)
                 if all(any(m & primes[i][0] == primes[i][1] for i in sub) for m in on)]
        if costs:
            return min(costs)
    raise AssertionError("no cover")


def test_a_cover_called_proved_is_a_minimum_cover_whatever_the_budget():
    """``exact_cover`` returns the best cover found and True only when its search ended within
    the budget. A function of 5 variables whose minimum cover (7 primes, 26 literals) its
    search finds late: cut after exactly 11 nodes, the best so far has 8 primes, and a search
    cut there must not call it proved."""
    from rtctl.logic.qm import exact_cover

    on = [0, 2, 3, 8, 10, 11, 13, 15, 21, 22, 23, 27, 28, 29, 30]
    primes = _primes_by_brute_force(on, 5)
    minimum = _cheapest_cover(on, primes)
    assert minimum == (7, 26)
    proved_at = []
    for budget in range(0, 120):
        cover, proved = exact_cover(on, primes, budget)
        assert all(any(m & c == v for c, v in cover) for m in on)
        if proved:
            assert (len(cover), sum(c.bit_count() for c, _ in cover)) == minimum, budget
            proved_at.append(budget)
    assert proved_at and proved_at == list(range(proved_at[0], 120))  # (proved from some budget on)


@pytest.mark.parametrize("kind", KINDS)
def test_synthetic_rows_carry_the_gray_code_of_their_index_and_their_states_low_four_bits(tmp_path, kind):
    """The module doc of rtctl.logic.synthetic: row k's gate vector is the k-th Gray code
    k ^ (k >> 1), and the actuator bits of state s are s's low four bits — read back through
    the table loader (bit i = gate i, actuator i)."""
    table = _load(tmp_path, synthetic_table(kind, 6, 7, seed=2))
    assert list(table.inputs) == [k ^ (k >> 1) for k in range(len(table.inputs))]
    assert all(table.outputs[s] == s & 15 for s in table.states)


@pytest.mark.parametrize("text", [".i 2\n.e\n", ".o 1\n.e\n", ".i 2\n", ""])
def test_a_pla_without_dot_i_or_dot_o_is_no_pla(text):
    with pytest.raises(RtctlError, match=r"^not a \.pla: \.i and \.o are missing$"):
        Pla.from_espresso(text)


def test_an_assignment_without_routes_settles_in_one_pass():
    """``Assignment.settle_passes``: one pass per change on the longest route, and one that finds
    nothing more to change — with no route at all, that one pass."""
    from rtctl.logic.assign import Assignment

    assert Assignment(1, {1: 0, 2: 1}, {}).settle_passes == 1
    assert Assignment(2, {1: 0, 2: 3}, {(1, 0): (0, 1, 3)}).settle_passes == 3


@pytest.mark.parametrize("on", [[-1, 3], [3, -1], [-5, 0, 15], [0, 16], [16]])
def test_minterms_outside_the_range_are_refused_wherever_they_are(on):
    from rtctl.logic.qm import minimise

    with pytest.raises(ValueError, match=r"minterms must be in \[0, 16\)"):
        minimise(4, on)


def test_the_plas_inputs_are_the_gates_then_q1_to_qb(circuit, table3):
    assert circuit.pla.inputs == tuple(table3.gates) + ("Q1", "Q2", "Q3")


def test_a_compiled_circuit_is_immutable(circuit):
    with pytest.raises(dataclasses.FrozenInstanceError):
        circuit.pla = None


@pytest.mark.parametrize("key", ["01", "-1", "+1", "1_0"])
def test_an_outputs_key_is_a_plain_state_number(tmp_path, key):
    text = TABLE3.read_text()
    edited = text.replace('\n1 = "', f'\n"{key}" = "', 1)
    assert edited != text
    e = table_refusal(tmp_path, edited)
    assert e.key_path == f"outputs.{key}" and "state number" in e.expected
