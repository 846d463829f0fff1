"""Tests for logic (leg synthesis) mutants that survived the full run's fast pass (docs/mutation/logic.md),
each against an expectation worked out by hand, by brute force in the test, or taken from the
documentation:

* the assignment search's default budget is the 40,000 nodes per flip-flop count that
  docs/leg_automaton.md states;
* a circuit model refuses ``max_passes`` below 1 with its message, and accepts exactly 1;
* a model's ``actuators(word)`` reads exactly the actuator bits of an output word (the bits above
  J1…Jb, K1…Kb, as many as there are actuators), nothing above them;
* the emulator takes gate words in [0, 2**n_gates): both ends accepted, -1 and 2**n_gates
  refused with the message naming the width;
* a PLA is immutable (a frozen dataclass): assigning a field raises FrozenInstanceError;
* a PLA's truth tables agree with a brute-force evaluation of its AND and OR planes;
* the minimiser takes its minterms from any iterable (a set, a generator, an array), and refuses
  minterms outside [0, 2**n), either end, with the message naming the range;
* the prime implicants through a minterm agree, for functions of 1 to 6 variables, with the
  primes found by brute force over every cube;
* a guard whose exit vector differs from each other vector of its state in a single gate tests
  every gate (a table of two gates where state 1 holds on three vectors and leaves on the fourth);
* the exact cover has the fewest primes, then literals, of every subset of the primes that covers
  the ON-set (brute force, random four-variable functions and one where the first cover found,
  taking the prime that covers most, is not the smallest);
* among covers of equal cost the exact cover keeps the first found in the order its
  documentation gives (most constrained minterm first), worked out by hand.
"""
import dataclasses
import inspect
import random

import numpy as np
import pytest

from rtctl.logic import assign, load_table
from rtctl.logic.emulate import CircuitModel, Emulator
from rtctl.logic.flow import flow_table, guards
from rtctl.logic.pla import Pla
from rtctl.logic.qm import exact_cover, minimise, minimise_proved, primes_through


def test_the_assignment_search_budget_defaults_to_the_documented_40000_nodes():
    """docs/leg_automaton.md: "It gets a budget of 40,000 search nodes per flip-flop count"."""
    default = inspect.signature(assign.candidate_assignments).parameters["budget"].default
    assert default == 40_000


# A hand-made circuit: inputs g0, g1 (gates) and Q1 (bit 0, 1, 2); J1 = g0, K1 = g̅0, A = Q1, B = g1.
# Output word (module doc of rtctl.logic.emulate): J1 bit 0, K1 bit 1, then A bit 2, B bit 3.
G0, G0_BAR, G1, Q1 = (0b001, 0b001), (0b001, 0b000), (0b010, 0b010), (0b100, 0b100)


def _small_pla() -> Pla:
    return Pla.from_functions(["g0", "g1", "Q1"], {"J1": [G0], "K1": [G0_BAR], "A": [Q1], "B": [G1]})


def test_a_circuit_model_needs_at_least_one_pass():
    with pytest.raises(ValueError, match="max_passes must be ≥ 1"):
        CircuitModel.from_pla(_small_pla(), n_gates=2, n_bits=1, max_passes=0)
    model = CircuitModel.from_pla(_small_pla(), n_gates=2, n_bits=1, max_passes=1)
    assert model.max_passes == 1


def test_the_actuator_bits_are_exactly_those_above_j_and_k():
    """Two actuators (A, B) above J1 and K1: word bits 2 and 3. A word with every bit 0…4 set
    reads 0b11; bit 4 (just above B) is not an actuator; J1 and K1 (bits 0, 1) neither."""
    model = CircuitModel.from_pla(_small_pla(), n_gates=2, n_bits=1)
    assert model.n_actuators == 2
    assert model.actuators(0b11111) == 0b11
    assert model.actuators(0b10011) == 0
    assert model.actuators(0b01000) == 0b10
    assert model.actuators(0b00100) == 0b01
    # and through the emulator, by hand: g0 = 1 sets Q1 (J1), so A = Q1 = 1; g1 = 1 gives B = 1
    emu = Emulator(model)
    emu.apply(0b11)
    assert (emu.code, emu.actuators) == (1, 0b11)
    emu.apply(0b00)  # K1 = g̅0 = 1 clears Q1: A = 0, B = g1 = 0
    assert (emu.code, emu.actuators) == (0, 0)


def test_the_emulator_takes_gate_words_of_exactly_n_gates_bits():
    model = CircuitModel.from_pla(_small_pla(), n_gates=2, n_bits=1)
    emu = Emulator(model)
    assert emu.apply(0) >= 0
    assert emu.apply(0b11) >= 0  # the largest 2-bit word
    for bad in (-1, 0b100):
        with pytest.raises(ValueError, match=f"gates must be a 2-bit word, got {bad}"):
            emu.apply(bad)


def test_a_pla_is_immutable():
    pla = _small_pla()
    with pytest.raises(dataclasses.FrozenInstanceError):
        pla.terms = ()
    with pytest.raises(dataclasses.FrozenInstanceError):
        pla.inputs = ("x",)


def test_truth_tables_agree_with_the_planes_evaluated_by_brute_force():
    """Inputs a, b, c (bit 0, 1, 2); y0 = a b̅, y1 = a b̅ + c, y2 = b c. For every minterm m the
    test evaluates each output as the OR of its terms, a term being on when m agrees with it on
    its care bits; a term shared by two outputs counts once in each."""
    t_ab, t_c, t_bc = (0b011, 0b001), (0b100, 0b100), (0b110, 0b110)
    pla = Pla.from_functions(["a", "b", "c"], {"y0": [t_ab], "y1": [t_ab, t_c], "y2": [t_bc]})
    table = pla.truth_tables()
    assert table.shape == (8, 3)
    for m in range(8):
        a, b, c = m & 1, m >> 1 & 1, m >> 2 & 1
        expected = [bool(a and not b), bool((a and not b) or c), bool(b and c)]
        assert table[m].tolist() == expected, m


def test_minterms_may_be_given_as_any_iterable():
    """f(x0, x1) = Σm(1, 3): x0 = 1 in both, so one cube (care 0b01, value 0b01)."""
    assert minimise(2, {1, 3}) == [(0b01, 0b01)]
    assert minimise(2, (m for m in (3, 1))) == [(0b01, 0b01)]
    assert minimise(2, np.array([1, 3])) == [(0b01, 0b01)]
    assert minimise(2, [1], dc={3}) == [(0b01, 0b01)]


def test_minterms_outside_the_function_are_refused_at_either_end():
    """Two variables: minterms 0…3. 3 alone is x0 x1 (care 0b11, value 0b11); 4 and -1 are refused,
    as ON minterms or don't-cares, with the message naming [0, 4)."""
    assert minimise(2, [3]) == [(0b11, 0b11)]
    assert minimise(2, [0]) == [(0b11, 0b00)]
    for on, dc in (([4], ()), ([-1], ()), ([1], [4]), ([1], [-1]), ([0, 3, 4], ())):
        with pytest.raises(ValueError, match=r"minterms must be in \[0, 4\)"):
            minimise(2, on, dc)


def _brute_primes(n: int, off: set) -> list:
    """Every prime implicant of the function whose OFF-set is ``off``: a cube (care, value) is an
    implicant when no OFF minterm agrees with it on its care bits, prime when freeing any one of
    its care bits makes it meet the OFF-set."""
    def implicant(care, value):
        return not any(o & care == value for o in off)

    out = []
    for care in range(1 << n):
        for value in range(1 << n):
            if value & ~care or not implicant(care, value):
                continue
            bits = [1 << i for i in range(n) if care >> i & 1]
            if not any(implicant(care & ~b, value & ~b) for b in bits):
                out.append((care, value))
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_the_primes_through_a_minterm_agree_with_brute_force(n):
    rng = random.Random(1000 + n)
    for _ in range(4):
        labels = [rng.choice("10-0") for _ in range(1 << n)]  # ON, OFF, don't-care
        on = [m for m in range(1 << n) if labels[m] == "1"]
        off = {m for m in range(1 << n) if labels[m] == "0"}
        if not on or not off:
            continue
        primes = _brute_primes(n, off)
        off_arr = np.array(sorted(off), dtype=np.int64)
        for m in on:
            expected = sorted(p for p in primes if m & p[0] == p[1])
            assert sorted(primes_through(n, m, off_arr)) == expected, (n, m)


SQUARE = """name = "two gates, every vector seen in state 1"
cyclic = true
gates = ["g0", "g1"]
actuators = ["A"]
rows = [
    [1, "00", "0", 1],
    [2, "10", "0", 1],
    [3, "01", "0", 1],
    [4, "11", "1", 2],
]

[outputs]
1 = "0"
2 = "1"
"""


def test_a_guard_may_need_every_gate(tmp_path):
    """State 1 holds on 00, 10 and 01 and leaves for state 2 on 11: a term containing 11 and none
    of the other three must test both gates (freeing either would take in 01 or 10), so the guard
    is the single two-literal term g0 g1 (care 0b11, value 0b11). State 2 leaves on 00 (the
    cycle's first row) and has only 11 besides: either gate low separates them, two one-literal
    terms g̅0 and g̅1."""
    path = tmp_path / "square.toml"
    path.write_text(SQUARE)
    found = {(g.transition.state, g.transition.gates): g.terms for g in guards(flow_table(load_table(path)))}
    assert found == {(1, 0b11): ((0b11, 0b11),), (2, 0b00): ((0b01, 0b00), (0b10, 0b00))}


def _brute_minimum(on: list, primes: list) -> tuple:
    """(fewest primes, then fewest literals) of a cover of ``on``, over every subset of the primes."""
    best = None
    for mask in range(1, 1 << len(primes)):
        picked = [p for i, p in enumerate(primes) if mask >> i & 1]
        if all(any(m & c == v for c, v in picked) for m in on):
            cost = (len(picked), sum(c.bit_count() for c, _ in picked))
            best = cost if best is None or cost < best else best
    return best


def _random_function(seed: int, n: int = 4) -> tuple:
    rng = random.Random(seed)
    labels = [rng.choice("1100-") for _ in range(1 << n)]
    return [m for m in range(1 << n) if labels[m] == "1"], [m for m in range(1 << n) if labels[m] == "-"]


# Random functions of four variables, and one (no don't-cares) whose first cover found, taking
# at each minterm the prime that covers most, has five primes where four suffice.
COVER_CASES = [_random_function(seed) for seed in range(6)] + [([1, 3, 4, 5, 6, 7, 8, 9, 10, 14], [])]


@pytest.mark.parametrize("on, dc", COVER_CASES)
def test_the_exact_cover_is_minimum_by_brute_force(on, dc):
    """The cover found (within the default budget, so proved) has the fewest primes, then the
    fewest literals, of all the subsets of the primes that cover the ON-set; and it is a cover:
    every ON minterm in some cube, no OFF minterm in any."""
    n = 4
    off = set(range(1 << n)) - set(on) - set(dc)
    primes = sorted(p for p in _brute_primes(n, off) if any(m & p[0] == p[1] for m in on))
    assert len(primes) <= 16  # (keeps the brute force small)
    cover, proved = minimise_proved(n, on, dc)
    assert proved
    assert all(any(m & c == v for c, v in cover) for m in on)
    assert not any(m & c == v for c, v in cover for m in off)
    assert (len(cover), sum(c.bit_count() for c, _ in cover)) == _brute_minimum(on, primes)


def test_among_equal_covers_the_first_found_in_the_documented_order_is_kept():
    """ON-set {0, 1, 3} of three variables with don't-cares {4, 7} (OFF: 2, 5, 6). The primes,
    as (care, value): (3, 0) = {0, 4}, (3, 3) = {3, 7}, (5, 1) = {1, 3}, (6, 0) = {0, 1}. Every
    ON minterm lies in two of them, so none is essential and the minterms keep their order
    0, 1, 3. Three covers tie at 2 primes and 4 literals: {0,1}+{3,7}, {0,1}+{1,3}, {0,4}+{1,3}.
    The search branches on the first uncovered minterm (the most constrained), trying the primes
    that cover most of what is left first, then fewer literals, then list order, and keeps the
    first cover of a cost: at minterm 0, (6, 0) (covers 0 and 1) before (3, 0); then at minterm
    3, (3, 3) and (5, 1) each cover one, with two literals, so (3, 3) comes first in the list.
    The first cover is (6, 0) + (3, 3), returned in list order."""
    primes = [(3, 0), (3, 3), (5, 1), (6, 0)]
    assert exact_cover([0, 1, 3], primes) == ([(3, 3), (6, 0)], True)
