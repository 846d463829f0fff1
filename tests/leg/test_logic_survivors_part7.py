"""Tests for logic (leg synthesis) mutants left by the full run (docs/mutation/logic.md): the compile
and replay reports and the exhaustive checks behind them, each against docs/leg_automaton.md,
a brute-force evaluation or a case worked out by hand:

* the guard circuit for Table 3 does not read K_d3 (docs/leg_automaton.md §4), and the report
  says so — checked also by brute force over the PLA's truth tables;
* the report labels the spare codes as the documentation does: under the exact semantics 100
  is an unstable intermediate state and 011 is unused; under the guard semantics both spares
  (001, 010) are intermediates;
* the race proof's counts for Table 3 are the documented ones (1536 cases, none with two
  flip-flops excited at once, at most 2 changes exact, 6 guard), and on a planted one-step
  double jump the cases "with a choice of order" are those a brute-force search finds;
* a circuit that never switches fails exactly on the table's 8 exits, with no change on any
  path; a flip-flop that toggles forever is reported as a cycle of two changes;
* the settle limit: Table 3's two routed transitions take 2 changes, so they pass with
  max_passes = 3 and are the two failures with max_passes = 2;
* the replay counts an order that fires an exit early as failed even when it ends in the
  row's state (a three-state table worked out by hand), and the replay report prints each
  failing order with its reason;
* the compile report lists the mismatches the agreement check found.
"""

import pytest

from leg_helpers import one_jump_circuit
from rtctl.logic import CircuitModel, compile_table, load_table
from rtctl.logic.pla import Pla
from rtctl.logic.report import format_compile, format_replay
from rtctl.logic.verify import RaceReport, agreement, race_proof, replay


@pytest.fixture(scope="module")
def guard_circuit(table3):
    return compile_table(table3, "guard")


def _report(circuit, max_passes=None):
    passes = circuit.settle_passes if max_passes is None else max_passes
    model = CircuitModel.from_pla(circuit.pla, circuit.table.n_gates, circuit.n_bits, passes)
    return format_compile(circuit, agreement(circuit, model), race_proof(circuit, model))


def _unread_by_brute_force(circuit):
    """The gates no output of the PLA depends on: flipping gate i never changes a truth-table row."""
    truth = circuit.pla.truth_tables()
    return [g for i, g in enumerate(circuit.table.gates)
            if all((truth[m] == truth[m ^ 1 << i]).all() for m in range(len(truth)))]


def test_the_guard_report_names_the_gate_the_circuit_does_not_read(guard_circuit):
    assert _unread_by_brute_force(guard_circuit) == ["K_d3"]
    assert "  gates the circuit does not read: K_d3" in _report(guard_circuit).splitlines()


def test_the_exact_report_labels_its_spare_codes_as_documented(circuit):
    lines = _report(circuit).splitlines()
    assert "  100 spare, unstable intermediate state" in lines
    assert "  011 spare, unused (don't care)" in lines


def test_the_guard_report_labels_both_spares_intermediate(guard_circuit):
    lines = _report(guard_circuit).splitlines()
    assert "  001 spare, unstable intermediate state" in lines
    assert "  010 spare, unstable intermediate state" in lines


@pytest.mark.parametrize("semantics, longest", [("exact", 2), ("guard", 6)])
def test_the_race_proof_counts_of_table3_are_the_documented_ones(circuit, guard_circuit, semantics, longest):
    """docs/leg_automaton.md §3 and §4: 1536 cases, none with two flip-flops excited at once."""
    c = circuit if semantics == "exact" else guard_circuit
    report = race_proof(c, CircuitModel.from_pla(c.pla, 8, c.n_bits, c.settle_passes))
    assert (report.checked, report.races, report.longest, report.ok) == (6 * 256, 0, longest, True)


def _choices_by_brute_force(circuit, model):
    """(state, gates) pairs from whose code some reachable code has two or more flip-flops
    excited: breadth-first over every non-empty subset of the excited ones switching."""
    count = 0
    for s in circuit.flow.states:
        for x in range(1 << circuit.table.n_gates):
            seen, frontier, choice = set(), [circuit.assignment.codes[s]], False
            while frontier:
                q = frontier.pop()
                if q in seen:
                    continue
                seen.add(q)
                e = model.excited(q, x)
                choice |= bin(e).count("1") >= 2
                frontier += [q ^ sub for sub in range(1, e + 1) if sub & e == sub]
            count += choice
    return count


def test_the_cases_with_a_choice_of_order_agree_with_brute_force(table3, circuit):
    """State 1 → 2 (000 → 110) planted as one jump: two flip-flops excited at once."""
    bad = one_jump_circuit(table3, circuit)
    model = CircuitModel.from_pla(bad.pla, 8, 3)
    expected = _choices_by_brute_force(bad, model)
    assert expected > 0
    assert race_proof(bad, model).races == expected


def _model_with(circuit, on):
    """Table 3's PLA shape with every function empty (never on) except those in ``on``, always on."""
    pla = Pla.from_functions(circuit.pla.inputs, {n: ([(0, 0)] if n in on else []) for n in circuit.pla.outputs})
    return CircuitModel.from_pla(pla, 8, circuit.n_bits)


def test_a_circuit_that_never_switches_fails_exactly_on_the_exits(circuit):
    """Nothing is ever excited: every path is empty (0 changes), the circuit stays on its code,
    which is wrong exactly where the automaton leaves the state — the table's 8 exits."""
    fresh = RaceReport()  # nothing explored yet: no case, no choice, no change
    assert (fresh.checked, fresh.races, fresh.longest, fresh.ok) == (0, 0, 0, True)
    report = race_proof(circuit, _model_with(circuit, ()))
    assert (report.checked, report.races, report.longest) == (6 * 256, 0, 0)
    flow, a = circuit.flow, circuit.assignment
    exits = {(s, circuit.table.gate_bits(x)) for s in flow.states for x in flow.exits[s]}
    assert len(exits) == 8
    assert {(f["state"], f["gates"]) for f in report.failures} == exits
    assert all(f["finals"] == [a.codes[f["state"]]] and not f["cycle"] and f["longest"] == 0 for f in report.failures)


def test_a_flip_flop_that_toggles_forever_is_a_cycle_of_two_changes(circuit):
    """J1 = K1 = 1: Q1 toggles on every pass. From any code c the only path is c → c ⊕ 1 → c,
    two changes, the second closing the cycle; no stable code is reached."""
    report = race_proof(circuit, _model_with(circuit, ("J1", "K1")))
    assert len(report.failures) == 6 * 256 and report.races == 0 and report.longest == 2
    assert all(f["cycle"] and f["finals"] == [] and f["longest"] == 2 for f in report.failures)


def test_the_settle_limit_is_max_passes_minus_one_changes(circuit):
    """Table 3's routed transitions, 1 → 2 on 0010 0110 and 4 → 1 on 1100 0100, take 2 changes
    (docs/leg_automaton.md §3): within max_passes = 3, beyond max_passes = 2 — the only two
    failures then, each reaching the right code."""
    model3 = CircuitModel.from_pla(circuit.pla, 8, 3, max_passes=3)
    assert race_proof(circuit, model3).ok
    report = race_proof(circuit, CircuitModel.from_pla(circuit.pla, 8, 3, max_passes=2))
    assert sorted((f["state"], f["gates"], f["longest"], f["cycle"]) for f in report.failures) == [
        (1, "00100110", 2, False), (4, "11000100", 2, False)]
    assert all(f["finals"] == [f["expected"]] for f in report.failures)


# Three states over two gates (g0 is the first character). δ: (1, 00) → 1, (1, 11) → 2,
# (1, 10) → 1, (1, 01) → 3, (2, 11) → 2, (2, 10) → 1, (2, 00) → 1, (3, 01) → 3, (3, 11) → 2.
EARLY = """name = "early exits"
cyclic = true
gates = ["g0", "g1"]
actuators = ["A", "B"]
rows = [
    [1, "00", "00", 1],
    [2, "11", "10", 2],
    [3, "10", "00", 1],
    [4, "01", "01", 3],
    [5, "11", "10", 2],
    [6, "00", "00", 1],
]

[outputs]
1 = "00"
2 = "10"
3 = "01"
"""


@pytest.fixture(scope="module")
def early(tmp_path_factory):
    path = tmp_path_factory.mktemp("early") / "early.toml"
    path.write_text(EARLY)
    c = compile_table(load_table(path))
    return c, replay(c, CircuitModel.from_pla(c.pla, 2, c.n_bits, c.settle_passes))


def test_an_order_that_exits_early_fails_even_when_it_ends_in_the_rows_state(early):
    """By hand, for the rows changing two gates (g0 first, then g1 first):
    step 2 (1 on 00 → 2 on 11): via 10 state 1 holds, fine; via 01 state 1 leaves for 3 early,
    and 3 on 11 goes to 2 — the right state, but the exit fired early: a failure.
    step 4 (1 on 10 → 3 on 01): via 00 fine; via 11 state 1 leaves for 2, which holds on 01.
    step 6 (2 on 11 → 1 on 00): via 01 (unseen in 2) it holds, fine; via 10 state 2 leaves
    for 1 early, and 1 holds on 00 — the right state, still a failure.
    Each of them: 2 orders, 1 ending properly; the one-gate rows: 1 of 1."""
    _, rows = early
    assert [(r.step, r.orders, r.ok) for r in rows] == [(1, 1, 1), (2, 2, 1), (3, 1, 1), (4, 2, 1), (5, 1, 1),
                                                       (6, 2, 1)]
    failed = {r.step: (r.failures[0]["order"], r.failures[0]["state"]) for r in rows if r.failures}
    assert failed == {2: (["g1", "g0"], 2), 4: (["g1", "g0"], 2), 6: (["g1", "g0"], 1)}


def test_the_replay_report_prints_each_failing_order_and_why(early):
    circuit, rows = early
    lines = format_replay(circuit, rows).splitlines()
    orders = [line.strip() for line in lines if line.strip().startswith("order ")]
    assert len(orders) == 3 and all(o.startswith("order g1 g0: ") for o in orders), lines
    assert any("gates 01" in o and "exit of state 1 to state 3" in o for o in orders), lines
    assert lines[-1] == "6 of 9 orders end in the table's state; rows where some order cannot: 2, 4, 6"


def test_the_compile_report_lists_the_mismatches(circuit):
    """A circuit model that never switches disagrees with the automaton on the 8 exits."""
    model = _model_with(circuit, ())
    agree = agreement(circuit, model)
    assert len(agree["mismatches"]) >= 8
    lines = format_compile(circuit, agree, race_proof(circuit, model)).splitlines()
    assert any(line.startswith("    mismatch: ") for line in lines)
    assert f"{len(agree['mismatches'])} MISMATCHES" in "\n".join(lines)
