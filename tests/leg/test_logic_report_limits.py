"""How much of a failure the leg compiler's reports show (docs/leg_automaton.md): the compile
report lists the first five mismatches of the agreement check and the first five failures of
the race proof, and ``replay`` keeps the first five failing orders of each row, while every
count stays complete. Checked with a circuit whose every function is empty: it never switches
and drives no actuator, so it disagrees with Table 3's automaton on all 6 × 256 (state, gate
vector) pairs, fails the race proof on its 8 exits and every order of step 10 (five gates
change: 120 orders)."""
from itertools import permutations

from rtctl.logic import CircuitModel
from rtctl.logic.pla import Pla
from rtctl.logic.report import format_compile, format_replay
from rtctl.logic.verify import agreement, race_proof, replay


def _never_switching(circuit):
    pla = Pla.from_functions(circuit.pla.inputs, {name: [] for name in circuit.pla.outputs})
    return CircuitModel.from_pla(pla, circuit.table.n_gates, circuit.n_bits)


def test_the_compile_report_lists_the_first_five_mismatches_and_counts_them_all(circuit):
    model = _never_switching(circuit)
    agree = agreement(circuit, model)
    assert len(agree["mismatches"]) == 6 * 256
    lines = format_compile(circuit, agree, race_proof(circuit, model)).splitlines()
    shown = [line for line in lines if line.startswith("    mismatch: ")]
    assert shown == [f"    mismatch: {m}" for m in agree["mismatches"][:5]]
    assert "1536 MISMATCHES" in "\n".join(lines)


def test_the_compile_report_lists_the_first_five_race_failures_and_counts_them_all(circuit):
    """The never-switching circuit stays on its code: the race proof fails on Table 3's 8 exits."""
    model = _never_switching(circuit)
    race = race_proof(circuit, model)
    assert len(race.failures) == 8
    lines = format_compile(circuit, agreement(circuit, model), race).splitlines()
    assert [line for line in lines if line.startswith("    race: ")] == [f"    race: {f}" for f in race.failures[:5]]
    assert "8 FAILURES" in "\n".join(lines)


def test_replay_keeps_the_first_five_failing_orders_of_a_row(table3, circuit):
    rows = replay(circuit, _never_switching(circuit))
    (step10,) = [r for r in rows if r.step == 10]
    changed = [i for i in range(table3.n_gates) if (table3.inputs[step10.row - 1] ^ table3.inputs[step10.row]) >> i & 1]
    assert (step10.orders, step10.ok) == (120, 0)
    first_five = [[table3.gates[i] for i in order] for order in list(permutations(changed))[:5]]
    assert [f["order"] for f in step10.failures] == first_five
    report = format_replay(circuit, rows).splitlines()
    i = next(k for k, line in enumerate(report) if line.split()[:2] == [str(step10.row), "10"])
    assert [line.split(":")[0].strip() for line in report[i + 1:i + 6]] == [f"order {' '.join(o)}" for o in first_five]
    assert not report[i + 6].strip().startswith("order ")
