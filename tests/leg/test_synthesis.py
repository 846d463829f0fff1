"""The synthesised circuit against the table, exhaustively; minimisation against truth tables
and against espresso (pyeda); the .pla file round trip; the Table 3 replay."""
import itertools
import re

import numpy as np
from hypothesis import given, settings, strategies as st

from leg_helpers import TABLE3, one_jump_circuit, rtctl
from rtctl.logic import CircuitModel, Emulator, Pla, compile_table, load_table
from rtctl.logic.emulate import NOT_SETTLED
from rtctl.logic.qm import evaluate, minimise
from rtctl.logic.verify import race_proof, replay


def table_automaton(table):
    """δ straight from the rows (not from rtctl.logic.flow): row k's gates in row k−1's state
    lead to row k's state, which they keep; everything else holds."""
    delta = {}
    n = len(table.states)
    for k in range(n):
        x, s = table.inputs[k], table.states[k]
        delta[(table.states[k - 1], x)] = s
        delta[(s, x)] = s
    return lambda s, x: delta.get((s, x), s), delta


def test_circuit_equals_automaton_on_every_pair(table3, circuit, model):
    step, defined = table_automaton(table3)
    em = Emulator(model)
    held = 0
    for s in table3.state_labels:
        for x in range(256):
            em.code = circuit.assignment.codes[s]
            assert em.apply(x) != NOT_SETTLED
            want = step(s, x)
            assert circuit.assignment.state_of(em.code) == want, (s, table3.gate_bits(x))
            assert em.actuators == table3.outputs[want]
            held += (s, x) not in defined
    assert held == 6 * 256 - len(defined) == 6 * 256 - 19  # 8 exits + 11 stays defined


def test_three_flip_flops_and_no_critical_race(circuit, model):
    a = circuit.assignment
    assert a.n_bits == 3 and a.codes[1] == 0
    for (s, x), path in a.routes.items():  # every step of every route changes one flip-flop
        assert all(bin(p ^ q).count("1") == 1 for p, q in zip(path, path[1:]))
        assert all(a.state_of(c) is None for c in path[1:-1])
    report = race_proof(circuit, model)
    assert report.ok and report.checked == 6 * 256 and report.longest <= model.max_passes - 1


def test_race_proof_finds_a_critical_race(table3, circuit):
    """The chosen codes with 1 → 2 (000 → 110) taken in one jump: Q1 and Q2 race, and if Q2
    wins the circuit lands on 010, state 5's code, which holds on that gate vector."""
    bad = one_jump_circuit(table3, circuit)
    report = race_proof(bad, CircuitModel.from_pla(bad.pla, 8, 3))
    assert not report.ok
    failure = next(f for f in report.failures if f["state"] == 1)
    codes = circuit.assignment.codes
    assert codes[5] in failure["finals"] and codes[2] in failure["finals"]


def _expected_functions(table, a):
    """J/K and actuator values on every specified (code, gates) point, from the table's δ and
    the assignment's routes: {name: {minterm: bit}}."""
    step, _ = table_automaton(table)
    nxt = {}
    for s, c in a.codes.items():
        for x in range(256):
            t = step(s, x)
            nxt[(c, x)] = c if t == s else a.routes[(s, x)][1]
    for (s, x), path in a.routes.items():
        for p, q in zip(path[1:-1], path[2:]):
            nxt[(p, x)] = q
    want = {f"{p}{k + 1}": {} for k in range(3) for p in "JK"}
    for (c, x), n in nxt.items():
        for k in range(3):
            q, q1 = c >> k & 1, n >> k & 1
            m = x | c << 8
            if q == 0:
                want[f"J{k + 1}"][m] = q1
            else:
                want[f"K{k + 1}"][m] = 1 - q1
    for i, name in enumerate(("K1'", "K2'", "A1", "A2")):
        want[name] = {x | c << 8: table.outputs[s] >> i & 1 for s, c in a.codes.items() for x in range(256)}
    return want


def test_minimised_functions_equal_their_truth_tables(table3, circuit):
    want = _expected_functions(table3, circuit.assignment)
    assert set(want) == set(circuit.pla.outputs)
    for name, points in want.items():
        truth = evaluate(circuit.pla.function(name), 11)
        bad = [m for m, bit in points.items() if truth[m] != bit]
        assert not bad, (name, bad[:5])
    assert sum(len(p) for p in want.values()) > 6 * 6 * 256 // 2  # most of the 2¹¹ are specified


def test_no_function_has_more_terms_than_espresso_finds(table3, circuit):
    from pyeda.boolalg.espresso import DTYPE, FTYPE, espresso

    want = _expected_functions(table3, circuit.assignment)
    for name, points in want.items():
        cover = {(tuple(2 if m >> i & 1 else 1 for i in range(11)), (bit,)) for m, bit in points.items() if bit}
        cover |= {(tuple(2 if m >> i & 1 else 1 for i in range(11)), (2,)) for m in range(2048) if m not in points}
        theirs = espresso(11, 1, cover, intype=FTYPE | DTYPE)
        assert len(circuit.pla.function(name)) <= len(theirs), name


def test_quine_mccluskey_on_a_textbook_function():
    """f = Σm(4, 8, 10, 11, 12, 15) + d(9, 14) over 4 variables: three terms is the minimum."""
    cubes = minimise(4, [4, 8, 10, 11, 12, 15], [9, 14])
    assert len(cubes) == 3 and set(np.flatnonzero(evaluate(cubes, 4))) <= {4, 8, 9, 10, 11, 12, 14, 15}


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 3), st.data())
def test_quine_mccluskey_is_exact_on_small_functions(n, data):
    values = data.draw(st.lists(st.sampled_from((0, 1, 2)), min_size=1 << n, max_size=1 << n))
    on = [m for m, v in enumerate(values) if v == 1]
    dc = [m for m, v in enumerate(values) if v == 2]
    cubes = minimise(n, on, dc)
    truth = evaluate(cubes, n)
    assert all(truth[m] for m in on) and not any(truth[m] for m, v in enumerate(values) if v == 0)
    # brute force: no cover with fewer terms exists among all implicants
    implicants = [(c, v) for c in range(1 << n) for v in range(1 << n) if v & ~c == 0
                  and not any(values[m] == 0 for m in range(1 << n) if m & c == v)]
    for k in range(len(cubes)):
        for combo in itertools.combinations(implicants, k):
            t = evaluate(list(combo), n)
            assert not all(t[m] for m in on), (values, combo)


def test_pla_file_round_trips(circuit, tmp_path):
    text = circuit.pla.to_espresso("leg")
    back = Pla.from_espresso(text)
    assert back.inputs == circuit.pla.inputs and back.outputs == circuit.pla.outputs
    assert back.terms == circuit.pla.terms and np.array_equal(back.plane, circuit.pla.plane)
    assert np.array_equal(back.truth_tables(), circuit.pla.truth_tables())
    assert back.to_espresso("leg") == text


def test_pla_file_reads_in_pyeda_and_labels_are_the_tables(circuit, tmp_path):
    from pyeda.parsing.pla import parse

    out = tmp_path / "leg.pla"
    result = rtctl("leg", "compile", TABLE3, "--pla", out)
    assert result.returncode == 0, result.stderr
    text = out.read_text()
    assert ".ilb t_d h_d K_d1 K_d2 K_d3 a_d h_d1 h_d2 Q1 Q2 Q3" in text
    assert ".ob J1 K1 J2 K2 J3 K3 K1' K2' A1 A2" in text  # actuator K1 K2 primed, as in the paper
    # pyeda's reader takes only \w labels (espresso takes any token): map the primes for it
    d = parse(text.replace("'", "_p"))
    assert d["ninputs"] == 11 and d["noutputs"] == 10 and d["output_labels"][6] == "K1_p"
    ours = {(tuple({"0": 1, "1": 2, "-": 3}[c] for c in circuit.pla.and_row(t)), tuple(int(u) for u in row))
            for t, row in zip(circuit.pla.terms, circuit.pla.plane)}
    assert d["cover"] == ours
    assert re.search(r"^\.p 15$", text, re.M)


def test_table3_replay_every_order(circuit, model):
    rows = replay(circuit, model)
    assert [r.orders for r in rows] == [1, 1, 1, 2, 1, 1, 1, 1, 1, 120, 1, 1]
    assert all(r.ok == r.orders for r in rows)


def test_replay_reports_an_order_that_cannot_end_in_the_tables_state(tmp_path):
    """Row 5 made to leave state 2 on 1010 0110: changing t_d before a_d on the way to row 4
    passes through that vector, so state 2 is left one row early."""
    text = TABLE3.read_text().replace('[ 5, "1110 0010"', '[ 5, "1010 0110"')
    path = tmp_path / "t.toml"
    path.write_text(text)
    circuit = compile_table(load_table(path))
    model = CircuitModel.from_pla(circuit.pla, 8, circuit.n_bits)
    row4 = replay(circuit, model)[3]
    assert (row4.orders, row4.ok) == (2, 1)
    (failure,) = row4.failures
    assert failure["order"] == ["t_d", "a_d"] and failure["state"] == 3
    assert "1010 0110".replace(" ", "") in failure["why"] and "exit of state 2 to state 3" in failure["why"]
    result = rtctl("leg", "replay", path)
    assert result.returncode == 0 and "rows where some order cannot: 4" in result.stdout
