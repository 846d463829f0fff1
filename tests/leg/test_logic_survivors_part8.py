"""Tests for logic (leg synthesis) mutants that survived the full run, each against an
expectation worked out by hand, by brute force in the test, or taken from the documentation:

* the assignment search starts at the fewest flip-flops that can code the states, ⌈log₂ n⌉
  (3 states: 2, 5 states: 3), and tries no smaller count;
* under the guard semantics a spare code that no route passes is a don't-care for every
  flip-flop's J and K (a three-state star whose fourth code is unused);
* the exact cover is the cheapest (fewest terms, then fewest literals) of every cover by the
  primes, found by brute force, on a four-variable function with don't-cares where a lower
  bound one too high cuts the cheapest branch;
* the compile report names the gates the guard circuit does not read (a table whose guards are
  b and ¬b reads neither a nor c), names the functions whose cover was not proved minimum, and
  says "minimised exactly" when every cover was proved (small functions are, within the budget);
* a transition's firing mask has bit x for each gate vector x its guard fires on;
* an actuator named like a flip-flop input (the synthetic tables' K1 and K2, with two
  flip-flops) is primed in the PLA, as the paper renames K1 K2 to K1' K2';
* the replay report has a line per row: the step, the changed gates, the number of orders and
  how many end in the table's state, as docs/leg_automaton.md's replay of Table 3 lists them;
* synthetic tables: rows numbered 1, 2, … as Table 3's steps are; every kind starts in state 1;
  a random tour's last row leaves to state 1 (tours whose jumps end on 1 are moved off it);
  the complete table is Hierholzer's circuit traced by hand;
* the compile report's flow table: each state's output, the vectors it stays on, its exits;
* the race proof counts the cases with a choice of order: none for Table 3 (documented: 1536
  cases, in none are two flip-flops excited at once), at least one when a transition jumps two
  bits;
* a settle that runs out of passes leaves the state of its last pass (settle's doc); an output
  word must fit an int64 (62 bits are accepted, 64 refused with the message);
* a search result is immutable; a step that is not an integer is refused naming rows[k][0];
* the replay ends an order at the first gate change the circuit does not settle after
  (fundamental mode: the next change waits for the circuit to settle), and says which;
* Table 3's circuit model allows 4 passes by default (3 needed, one spare: documented);
* an output for a state no row is in is refused naming outputs.<state>, the first of several.
"""
import dataclasses
import itertools
import re

import numpy as np
import pytest

from leg_helpers import TABLE3, one_jump_circuit
from rtctl.errors import ConfigError
from rtctl.logic import CircuitModel, Emulator, Pla, compile_table, load_table
from rtctl.logic.assign import candidate_assignments
from rtctl.logic.emulate import NOT_SETTLED
from rtctl.logic.flow import flow_table
from rtctl.logic.guard import firing_masks, guard_automaton
from rtctl.logic.qm import minimise
from rtctl.logic.report import format_compile, format_replay
from rtctl.logic.synth import DONT_CARE, excitation
from rtctl.logic.synthetic import KINDS, state_sequence, synthetic_table
from rtctl.logic.verify import agreement, race_proof, replay


def _load(tmp_path, text, name="t.toml"):
    path = tmp_path / name
    path.write_text(text)
    return load_table(path)


def _report(circuit):
    model = CircuitModel.from_pla(circuit.pla, circuit.table.n_gates, circuit.n_bits, circuit.settle_passes)
    return format_compile(circuit, agreement(circuit, model), race_proof(circuit, model))


# -- the assignment search's first flip-flop count -------------------------------------------

def test_the_assignment_search_starts_at_the_fewest_flip_flops_that_code_the_states(tmp_path):
    """n states need ⌈log₂ n⌉ flip-flops: 3 states 2, 5 states 3; fewer cannot code them, so the
    search does not try them (the first count tried is that one, and the chain is coded by it)."""
    for n_states, n_gates, bits in [(3, 2, 2), (5, 3, 3)]:
        flow = flow_table(_load(tmp_path, synthetic_table("chain", n_states, n_gates)))
        search = candidate_assignments(flow)
        assert [t[0] for t in search.tried] == [bits]
        assert search.candidates[0].n_bits == bits


# -- guard semantics: unused spare codes are don't-cares -------------------------------------

# State 1 leaves to 2 when a rises and to 3 when b rises; 2 and 3 go back to 1 on 00. Three
# states in two flip-flops: 1 = 00 and its two neighbours for 2 and 3, no route, so code 11 is
# a spare code no route passes under any gate vector.
STAR3 = """
name = "star of three"
cyclic = true
gates = ["a", "b"]
actuators = ["X", "Y"]
rows = [
    [1, "00", "00", 1],
    [2, "10", "10", 2],
    [3, "00", "00", 1],
    [4, "01", "01", 3],
]

[outputs]
1 = "00"
2 = "10"
3 = "01"
"""


def test_guard_semantics_leave_a_spare_code_off_every_route_dont_care(tmp_path):
    circuit = compile_table(_load(tmp_path, STAR3), "guard")
    a = circuit.assignment
    assert a.n_bits == 2 and list(a.spare) == [0b11] and not any(len(p) > 2 for p in a.routes.values())
    assert (circuit.spec[0b11, :] == DONT_CARE).all()
    n = circuit.table.n_gates
    minterms = {x | 0b11 << n for x in range(1 << n)}
    for k in range(a.n_bits):
        (_, j_dc), (_, k_dc) = excitation(circuit.spec, n, k)
        assert minterms <= set(j_dc.tolist()) and minterms <= set(k_dc.tolist())
    # the circuit still does what the guard semantics says on every state's code
    model = CircuitModel.from_pla(circuit.pla, n, a.n_bits, circuit.settle_passes)
    assert not agreement(circuit, model)["mismatches"] and race_proof(circuit, model).ok


# -- the exact cover against brute force -----------------------------------------------------

def _brute_force_minimum(n, on, dc):
    """(terms, literals) of the cheapest cover of ``on`` by cubes containing no OFF minterm."""
    off = set(range(1 << n)) - set(on) - set(dc)
    cubes = []
    for care in range(1 << n):
        for value in range(1 << n):
            if value & ~care:
                continue
            inside = {m for m in range(1 << n) if m & care == value}
            if not inside & off and inside & set(on):
                cubes.append((care, value, inside))
    # a cheapest cover can be made of primes (a cube in no larger implicant): fewer literals each
    primes = [c for c in cubes if not any(d[2] > c[2] for d in cubes)]
    for size in range(1, len(primes) + 1):
        costs = [sum(bin(p[0]).count("1") for p in pick) for pick in itertools.combinations(primes, size)
                 if set().union(*(p[2] for p in pick)) >= set(on)]
        if costs:
            return size, min(costs)


def test_the_exact_cover_is_the_cheapest_on_a_function_with_dont_cares():
    """f = Σm(4, 6, 8, 9, 10, 11, 12, 13, 15) + d(1, 2, 3): four terms, nine literals at best
    (brute force); a branch and bound that thinks each subtree needs one term and one literal
    more than its bound says cuts that cover and keeps one of ten literals."""
    on, dc = [4, 6, 8, 9, 10, 11, 12, 13, 15], [1, 2, 3]
    want = _brute_force_minimum(4, on, dc)
    assert want == (4, 9)
    cover = minimise(4, on, dc)
    assert (len(cover), sum(bin(c).count("1") for c, _ in cover)) == want
    m = np.arange(16)
    covered = np.zeros(16, dtype=bool)
    for care, value in cover:
        covered |= (m & care) == value
    assert covered[on].all() and not covered[sorted(set(range(16)) - set(on) - set(dc))].any()


# -- the compile report ----------------------------------------------------------------------

# Three gates; only b matters: state 1 leaves to 2 when b rises, 2 goes back when it falls.
ONLY_B = """
name = "only b"
cyclic = true
gates = ["a", "b", "c"]
actuators = ["A"]
rows = [
    [1, "000", "0", 1],
    [2, "010", "1", 2],
]

[outputs]
1 = "0"
2 = "1"
"""


def test_the_report_names_the_gates_the_guard_circuit_does_not_read(tmp_path):
    """The guards are b (1 → 2) and ¬b (2 → 1), the output A is Q1: the PLA reads b and Q1,
    never a or c."""
    circuit = compile_table(_load(tmp_path, ONLY_B), "guard")
    lines = _report(circuit).splitlines()
    assert "  gates the circuit does not read: a, c" in lines
    assert "  1 → 2:  b" in lines and "  2 → 1:  ¬b" in lines


def test_firing_masks_have_bit_x_for_each_vector_x_the_guard_fires_on(tmp_path):
    """Gates a (bit 0), b (bit 1), c (bit 2): 1 → 2 (on 010) fires on its guard b, the vectors
    2, 3, 6, 7; 2 → 1 (on 000) on ¬b, the vectors 0, 1, 4, 5."""
    flow = flow_table(_load(tmp_path, ONLY_B))
    masks = firing_masks(guard_automaton(flow))
    assert masks == {(1, 0b010): sum(1 << x for x in (2, 3, 6, 7)), (2, 0b000): sum(1 << x for x in (0, 1, 4, 5))}


def test_the_report_names_the_functions_not_proved_minimum(tmp_path):
    """docs/leg_automaton.md: `rtctl leg compile` names the functions whose cover is the best
    found within the budget ("minimised exactly except …")."""
    circuit = compile_table(_load(tmp_path, ONLY_B))
    report = _report(dataclasses.replace(circuit, unproved=("J1", "K1")))
    assert ("Equations (J-K excitation Q⁺ = J Q̄ + K̄ Q, outputs; minimised exactly except J1, K1: "
            "the best cover found within the search budget):") in report.splitlines()


def test_small_functions_are_proved_minimum_and_the_report_says_so(tmp_path):
    """A two-state, three-gate table: J1, K1 and A are functions of 4 variables at most, whose
    exact covers take a handful of nodes of the 5,000 each gets."""
    circuit = compile_table(_load(tmp_path, ONLY_B))
    assert circuit.unproved == ()
    assert "Equations (J-K excitation Q⁺ = J Q̄ + K̄ Q, outputs; minimised exactly):" in _report(circuit).splitlines()


def test_actuators_named_like_flip_flop_inputs_are_primed(tmp_path):
    """A synthetic table's actuators are K1 K2 A1 A2; three states take two flip-flops, whose
    inputs are J1 K1 J2 K2: the actuators K1 and K2 become K1' and K2' (synth's doc, the paper's
    renaming), A1 and A2 keep their names."""
    circuit = compile_table(_load(tmp_path, synthetic_table("chain", 3, 2)))
    assert circuit.n_bits == 2
    assert circuit.pla.outputs == ("J1", "K1", "J2", "K2", "K1'", "K2'", "A1", "A2")


# -- the replay report -----------------------------------------------------------------------

def test_the_replay_report_lists_every_row_of_table_3(table3, circuit):
    """docs/leg_automaton.md, "Replay of Table 3 in every bit order": row (step), changed
    gates, orders, orders that end in the table's state."""
    model = CircuitModel.from_pla(circuit.pla, table3.n_gates, circuit.n_bits, circuit.settle_passes)
    lines = format_replay(circuit, replay(circuit, model)).splitlines()
    documented = {1: ("K_d2", 1), 2: ("h_d1", 1), 3: ("(none)", 1), 4: ("t_d a_d", 2), 5: ("h_d", 1),
                  6: ("K_d1", 1), 7: ("h_d1", 1), 8: ("a_d", 1), 9: ("h_d2", 1),
                  10: ("h_d K_d1 K_d2 K_d3 h_d2", 120), 11: ("t_d", 1), 12: ("K_d3", 1)}
    got = {}
    for line in lines:
        m = re.fullmatch(r"\s*(\d+)\s+(\d+)  (.+?)\s+(\d+)\s+(\d+)  (\d+)", line)
        if m:
            row, step, changed, orders, ok, state = int(m[1]), int(m[2]), m[3].strip(), int(m[4]), int(m[5]), int(m[6])
            assert row == step - 1 and state == table3.states[row] and ok == orders
            got[step] = (changed, orders)
    assert got == documented
    assert lines[-1] == "132 of 132 orders end in the table's state"


# -- synthetic tables ------------------------------------------------------------------------

def test_synthetic_rows_are_numbered_from_1_as_table_3s_steps_are(tmp_path):
    assert load_table(TABLE3).steps == tuple(range(1, 13))
    for kind in KINDS:
        table = _load(tmp_path, synthetic_table(kind, 4, 4), f"{kind}.toml")
        assert table.steps == tuple(range(1, len(table.states) + 1))


def test_every_synthetic_kind_starts_in_state_1():
    """The module doc's shapes all leave from state 1 (1 → 2 → …, 1 → 2 → 1 → 3 …, a tour from
    1, the complete circuit closing on its first state): the power-on state is state 1."""
    for kind in KINDS:
        for n in (3, 4, 6):
            assert state_sequence(kind, n)[0] == 1, (kind, n)


def test_a_random_tour_closes_on_state_1_from_another_state():
    """A random table is cyclic and starts in state 1, so its last row must be in another state
    (a row leaving to state 1). Seeds whose tour of jumps ends on state 1 (n = 3: seeds 2, 4, 7,
    8; n = 4: seeds 2, 7) have that last row moved off it; every jump before it changes state."""
    for n, seed in [(3, 2), (3, 4), (3, 7), (3, 8), (4, 2), (4, 7)] + [(n, s) for n in (2, 5, 8) for s in range(5)]:
        seq = state_sequence("random", n, seed)
        assert len(seq) == 3 * n and set(seq) == set(range(1, n + 1))
        assert seq[0] == 1 and seq[-1] != 1, (n, seed, seq)
        assert all(seq[k] != seq[k + 1] for k in range(len(seq) - 2)), (n, seed, seq)


def test_the_complete_table_is_hierholzers_circuit_traced_by_hand():
    """Hierholzer's algorithm from state 1, taking the smallest state not yet gone to first:
    n = 3 walks 1 → 2 → 1 → 3 → 1 and is stuck; 3 still goes to 2, 2 to 3: the circuit is
    1 2 1 3 2 3 (and back to 1). n = 4 walks the star 1 2 1 3 1 4 1, then from 4 the rest:
    4 → 2 → 3 → 2 → 4 → 3 → 4."""
    assert state_sequence("complete", 3) == [1, 2, 1, 3, 2, 3]
    assert state_sequence("complete", 4) == [1, 2, 1, 3, 1, 4, 2, 3, 2, 4, 3, 4]
    for n in (3, 4, 5):
        seq = state_sequence("complete", n)
        pairs = [(seq[k], seq[(k + 1) % len(seq)]) for k in range(len(seq))]
        assert sorted(pairs) == [(s, t) for s in range(1, n + 1) for t in range(1, n + 1) if s != t]


# -- the flow table in the compile report ----------------------------------------------------

def test_the_report_lists_each_states_vectors_and_exits(tmp_path):
    """ONLY_B by hand: state 1 (A = 0) stays on 000 and leaves on 010 for 2; state 2 (A = 1)
    stays on 010 and leaves on 000 for 1."""
    lines = _report(compile_table(_load(tmp_path, ONLY_B))).splitlines()
    k = lines.index("Flow table (gate bits in the order above; every other vector holds the state):")
    assert lines[k + 1:k + 3] == ["  state 1 [0]  stays on 000;  exits 010 → 2",
                                  "  state 2 [1]  stays on 010;  exits 000 → 1"]


# -- the race proof's count of choices -------------------------------------------------------

def test_table_3s_race_proof_finds_no_choice_of_order(circuit, model):
    """docs/leg_automaton.md §3: 1536 cases; in none are two flip-flops excited at once."""
    report = race_proof(circuit, model)
    assert (report.checked, report.races, report.ok) == (1536, 0, True)
    assert "(1536 cases; 0 with a choice of order)" in _report(circuit)


def test_a_two_bit_jump_gives_the_race_proof_a_choice_of_order(table3, circuit):
    """The chosen codes with 1 → 2 (000 → 110) taken in one jump: under 1 → 2's gate vector
    state 1's code excites Q1 and Q2 at once, a choice of order (and a critical race)."""
    bad = one_jump_circuit(table3, circuit)
    report = race_proof(bad, CircuitModel.from_pla(bad.pla, 8, 3))
    assert report.races >= 1 and not report.ok


# -- the emulator ----------------------------------------------------------------------------

def _toggle_pla(extra_actuators=0, n_bits=1):
    """Gates g0 g1, state Q1…Qb: J1 = g0, K1 = ¬g0 (Q1 follows g0), the other flip-flops never
    excited, and actuators A0… = Q1."""
    inputs = ["g0", "g1"] + [f"Q{k + 1}" for k in range(n_bits)]
    q1 = (1 << 2, 1 << 2)
    functions = {"J1": [(0b01, 0b01)], "K1": [(0b01, 0b00)]}
    for k in range(1, n_bits):
        functions[f"J{k + 1}"], functions[f"K{k + 1}"] = [], []
    for i in range(max(extra_actuators, 1)):
        functions[f"A{i}"] = [q1]
    return Pla.from_functions(inputs, functions)


def test_a_settle_that_runs_out_of_passes_keeps_the_last_passs_state():
    """settle's doc: NOT_SETTLED, io then holds the last pass. One pass allowed: g0 = 1 sets Q1
    in that pass, and there is none left to confirm it; the state is the pass's, Q1 = 1."""
    emu = Emulator(CircuitModel.from_pla(_toggle_pla(), n_gates=2, n_bits=1, max_passes=1))
    assert emu.apply(0b01) == NOT_SETTLED
    assert emu.code == 1
    assert emu.apply(0b01) == 0 and emu.code == 1 and emu.actuators == 1  # settled there: A0 = Q1


def test_an_output_word_must_fit_an_int64():
    """The output word, J1…Jb K1…Kb then the actuators, is an int64 of at most 62 outputs
    (CircuitModel.from_pla): a 62-bit word (1 flip-flop, 60 actuators) fits; 63 bits (61
    actuators) and 64 (4 flip-flops, 56 actuators) are refused by their message."""
    model = CircuitModel.from_pla(_toggle_pla(60), n_gates=2, n_bits=1)
    assert model.n_actuators == 60
    emu = Emulator(model)
    emu.apply(0b01)
    assert emu.actuators == (1 << 60) - 1  # every actuator is Q1
    with pytest.raises(ValueError, match="too many outputs for one word"):
        CircuitModel.from_pla(_toggle_pla(56, n_bits=4), n_gates=2, n_bits=4)
    with pytest.raises(ValueError, match="too many outputs for one word"):
        CircuitModel.from_pla(_toggle_pla(61), n_gates=2, n_bits=1)


# -- the search result -----------------------------------------------------------------------

def test_a_search_result_is_immutable(tmp_path):
    search = candidate_assignments(flow_table(_load(tmp_path, ONLY_B)))
    with pytest.raises(dataclasses.FrozenInstanceError):
        search.tried = ()


# -- the table's step column -----------------------------------------------------------------

def test_a_step_that_is_not_an_integer_is_refused_naming_its_row(tmp_path):
    """table.py: every error names the row; a step is an integer (not true, not "2", not 2.5)."""
    for bad in ("true", '"2"', "2.5"):
        text = ONLY_B.replace('[2, "010"', f'[{bad}, "010"')
        with pytest.raises(ConfigError, match=r"rows\[1\]\[0\].*the step number"):
            _load(tmp_path, text)


# -- the replay stops an order where the circuit does not settle -----------------------------

# Two gates that change together from row to row: state 1 on 00, state 2 on 11.
BOTH = """
name = "both"
cyclic = true
gates = ["a", "b"]
actuators = ["A"]
rows = [
    [1, "00", "0", 1],
    [2, "11", "1", 2],
]

[outputs]
1 = "0"
2 = "1"
"""


def test_the_replay_names_the_first_change_the_circuit_does_not_settle_after(tmp_path):
    """A faulty model (J1 = K1 = a: Q1 toggles for ever while a = 1) replays row 2 (00 → 11):
    in the order a, b the circuit never settles after a, so fundamental mode ends the order
    there; in the order b, a it settles after b (nothing excited) and not after a."""
    circuit = compile_table(_load(tmp_path, BOTH))
    pla = Pla.from_functions(["a", "b", "Q1"], {"J1": [(0b001, 0b001)], "K1": [(0b001, 0b001)], "A": [(0b100, 0b100)]})
    rows = replay(circuit, CircuitModel.from_pla(pla, n_gates=2, n_bits=1))
    row = next(r for r in rows if r.step == 2)
    assert (row.changed, row.orders, row.ok) == (("a", "b"), 2, 0)
    why = {tuple(f["order"]): f["why"] for f in row.failures}
    assert why == {("a", "b"): "did not settle after a changed (gates 10)",
                   ("b", "a"): "did not settle after a changed (gates 11)"}


# -- the settle limit's default --------------------------------------------------------------

def test_table_3s_model_defaults_to_its_settle_need_plus_one_spare_pass(circuit, table3):
    """docs/leg_automaton.md: Table 3's circuit needs 3 passes (a two-change route and a
    confirming pass); max_passes defaults to 4 for it, one spare."""
    assert circuit.settle_passes == 3
    assert CircuitModel.from_pla(circuit.pla, table3.n_gates, circuit.n_bits).max_passes == 4


# -- an output for a state no row is in ------------------------------------------------------

def test_an_output_for_a_state_no_row_is_in_is_refused_naming_the_first(tmp_path):
    """table.py: every error names where it is. One such state (3) is named; of two (3 and 4),
    the first."""
    with pytest.raises(ConfigError, match=r"outputs\.3.*a state that some row is in"):
        _load(tmp_path, ONLY_B + '3 = "1"\n')
    with pytest.raises(ConfigError, match=r"outputs\.3.*a state that some row is in"):
        _load(tmp_path, ONLY_B + '4 = "0"\n3 = "1"\n')
