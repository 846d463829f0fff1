"""Operation counts come from the code that runs: the instrumented plain-Python mirror of the
tick gives the compiled kernel's outputs exactly; the counts are affine in n (an O(n) law);
C* does fewer operations than classic, and exactly where the paper says (the bracket)."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.bench.control import format_table, random_chain as revolute_chain
from rtctl.control.opcount import count_slotine_li_tick
from rtctl.control.slotine_li import SlotineLi


def count(model, law, adapt=True, seed=0):
    rng = np.random.default_rng(seed)
    state = [rng.uniform(-1, 1, model.nq) for _ in range(5)]
    c = SlotineLi(model, law=law, lam=rng.uniform(1, 9, model.nq), kd=rng.uniform(1, 9, model.nq),
                  gamma=rng.uniform(0.1, 2, (model.nq, 10)))
    tally, tau, params_dot = count_slotine_li_tick(model, law, state, c.params_hat, c.gamma, c.lam, c.kd, adapt)
    return tally, (tau, params_dot), c.compute(*state)


@pytest.mark.parametrize("law", ["cstar", "classic"])
def test_mirror_reproduces_the_compiled_kernel(law, random_chain, puma):
    for model in (puma, random_chain(5, 3)):  # with prismatic joints
        _, mirrored, compiled = count(model, law)
        np.testing.assert_array_equal(mirrored[0], compiled[0])
        np.testing.assert_array_equal(mirrored[1], compiled[1])


def test_counts_are_affine_in_n_and_cstar_is_cheaper():
    per_link = {}
    for law in ("cstar", "classic"):
        counts = {n: count(revolute_chain(n, n), law)[0] for n in (2, 6, 12, 24)}
        slope = (counts[24].mul - counts[12].mul) / 12
        for n in (2, 6):
            assert counts[12].mul - counts[n].mul == slope * (12 - n)
            assert counts[12].add - counts[n].add == (counts[24].add - counts[12].add) / 12 * (12 - n)
        assert all(c.trig == 2 * n for n, c in counts.items())  # one sin, one cos per revolute joint
        tau_only = count(revolute_chain(24, 24), law, adapt=False)[0]
        per_link[law] = (slope, (counts[24].mul - tau_only.mul) / 24)
    (cstar_total, cstar_update), (classic_total, classic_update) = per_link["cstar"], per_link["classic"]
    # Per link the update costs C* one φ and one cross product besides φ(e, w); classic three φ and two.
    assert cstar_update == 82 and classic_update == 164
    assert cstar_total == 347 and classic_total == 525


def test_bench_table_formats(puma):
    row = {"robot": "x", "n": 2, "cstar": {"tick_us": 1.0, "compiled_us": 0.5, "mul": 1, "add": 2},
           "classic": {"tick_us": 2.0, "compiled_us": 1.0, "mul": 3, "add": 4}, "pinocchio_tau_us": None,
           "cstar_over_classic": 0.5, "cstar_over_classic_compiled": 0.5, "cstar_over_pinocchio": None}
    text = format_table({"rows": [row], "t24_over_t6": {"cstar": 3.0, "classic": 3.0},
                         "t24_over_t6_compiled": {"cstar": 3.0, "classic": 3.0},
                         "goals": {"cstar_over_classic_le_0.75": True, "cstar_tick_le_half_pinocchio": None}})
    assert "x" in text and "n/a" in text and "yes" in text
