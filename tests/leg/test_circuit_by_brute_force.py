"""The synthesised circuit's pieces against brute force: the J-K excitation sets against the
flip-flop's excitation table, and the emulator's settle count (the passes that changed the
state) against a step-by-step evaluation of the PLA straight from its terms and OR plane."""
import numpy as np
import pytest

from rtctl.logic import Emulator
from rtctl.logic.emulate import NOT_SETTLED
from rtctl.logic.synth import DONT_CARE, excitation

# Q → Q⁺ : (J, K), None = don't care  (Q⁺ = J Q̄ + K̄ Q)
JK_TABLE = {(0, 0): (0, None), (0, 1): (1, None), (1, 0): (None, 1), (1, 1): (None, 0)}


def test_excitation_sets_are_the_jk_flip_flops_excitation_table(table3, circuit):
    spec, n_gates = circuit.spec, table3.n_gates
    for k in range(circuit.n_bits):
        want = {"J_on": set(), "J_dc": set(), "K_on": set(), "K_dc": set()}
        for code in range(spec.shape[0]):
            for gates in range(spec.shape[1]):
                m = gates | code << n_gates
                nxt = int(spec[code, gates])
                if nxt == DONT_CARE:
                    want["J_dc"].add(m)
                    want["K_dc"].add(m)
                    continue
                j, kk = JK_TABLE[(code >> k & 1, nxt >> k & 1)]
                for name, bit in (("J", j), ("K", kk)):
                    if bit is None:
                        want[f"{name}_dc"].add(m)
                    elif bit:
                        want[f"{name}_on"].add(m)
        (j_on, j_dc), (k_on, k_dc) = excitation(spec, n_gates, k)
        got = {"J_on": set(j_on.tolist()), "J_dc": set(j_dc.tolist()), "K_on": set(k_on.tolist()),
               "K_dc": set(k_dc.tolist())}
        for name in want:
            assert got[name] == want[name], (f"flip-flop {k + 1}: {name}", len(got[name] ^ want[name]))


def _pla_step(pla, n_gates, n_bits, code, gates):
    """One pass, from the PLA itself: the active terms' outputs by name, then Q⁺ = J Q̄ + K̄ Q per bit."""
    word = gates | code << n_gates
    active = [t for t, (care, value) in enumerate(pla.terms) if word & care == value]
    on = {pla.outputs[o] for t in active for o in np.flatnonzero(pla.plane[t])}
    nxt = 0
    for b in range(n_bits):
        q = code >> b & 1
        j, k = f"J{b + 1}" in on, f"K{b + 1}" in on
        nxt |= int((j and not q) or (not k and q)) << b
    return nxt


@pytest.mark.parametrize("max_passes", [1, 2, 3, 4])
def test_settle_counts_the_passes_that_changed_the_state(table3, circuit, model, max_passes):
    from dataclasses import replace

    m = replace(model, max_passes=max_passes)
    counts = {}
    for code in range(1 << circuit.n_bits):
        for gates in range(1 << table3.n_gates):
            changes, q = 0, code
            while changes <= max_passes:  # (a cycle: more changes than passes, not settled)
                nxt = _pla_step(circuit.pla, table3.n_gates, circuit.n_bits, q, gates)
                if nxt == q:
                    break
                q, changes = nxt, changes + 1
            want = changes if changes < max_passes else NOT_SETTLED
            em = Emulator(m, code)
            got = em.apply(gates)
            assert got == want, (code, gates, got, want)
            if want != NOT_SETTLED:
                assert em.code == q
            counts[want] = counts.get(want, 0) + 1
    assert counts.get(0) and (max_passes == 1 or counts.get(1))  # stays and one-step changes both occur


# -- the guard semantics (issue 29 part 2) ---------------------------------------------------

@pytest.fixture(scope="module")
def guard_circuit(table3):
    from rtctl.logic import compile_table

    return compile_table(table3, "guard")


def test_guard_circuit_equals_the_independent_guard_reference_on_every_pair(table3, guard_circuit):
    """All 6 × 256 (state, gate vector) pairs: the PLA stepped pass by pass from its terms (not
    the compiled emulator) settles where the brute-force reference goes, one flip-flop at a
    time (no pass excites two: no race, whatever the switching order), within the settle
    limit; its actuator bits are that state's Moore output."""
    from leg_guard_reference import GuardReference

    ref = GuardReference(table3)
    assert {k: sorted(v) for k, v in ref.guards.items()} == {
        k: sorted(v) for k, v in guard_circuit.guard.exit_terms.items()}
    a, n = guard_circuit.assignment, table3.n_gates
    moved = 0
    for s in table3.state_labels:
        for x in range(1 << n):
            q, changes = a.codes[s], 0
            while changes < guard_circuit.settle_passes:
                nxt = _pla_step(guard_circuit.pla, n, guard_circuit.n_bits, q, x)
                if nxt == q:
                    break
                assert bin(nxt ^ q).count("1") == 1, (s, table3.gate_bits(x), q, nxt)  # single-flip-flop steps
                q, changes = nxt, changes + 1
            want = ref.next_state(s, x)
            assert a.state_of(q) == want, (s, table3.gate_bits(x), a.state_of(q), want)
            word = x | q << n
            on = {guard_circuit.pla.outputs[o] for t, (care, value) in enumerate(guard_circuit.pla.terms)
                  if word & care == value for o in np.flatnonzero(guard_circuit.pla.plane[t])}
            bits = sum(1 << i for i, name in enumerate(("K1'", "K2'", "A1", "A2")) if name in on)
            assert bits == table3.outputs[want]
            moved += want != s
    assert moved > 19 - 11  # unseen vectors move the state too: the guards, not the table's vectors


def test_guard_circuit_race_proof_and_agreement(table3, guard_circuit):
    from leg_guard_reference import GuardReference

    from rtctl.logic import CircuitModel
    from rtctl.logic.verify import agreement, race_proof

    model = CircuitModel.from_pla(guard_circuit.pla, table3.n_gates, guard_circuit.n_bits, guard_circuit.settle_passes)
    agree, race = agreement(guard_circuit, model), race_proof(guard_circuit, model)
    ref = GuardReference(table3)
    unseen_moves = sum(ref.next_state(s, x) != s for s in table3.state_labels for x in range(256)) - 8
    assert not agree["mismatches"] and (agree["exit"], agree["stay"], agree["guard"]) == (8, 11, unseen_moves)
    assert race.ok and race.checked == 1536 and race.longest == guard_circuit.settle_passes - 1
