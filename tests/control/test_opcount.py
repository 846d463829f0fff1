"""Operation counts of one Slotine–Li tick, derived from the equations and compared with the
counter (:func:`rtctl.control.opcount.count_slotine_li_tick`, which counts what the kernel's
source executes on counting scalars).

The expected counts are built below from the cost of each term of the recursion
(docs/cstar_slotine_li.md; equation numbers are Huo, Gao & Cheng's), each term from the cost of
3-vector operations, evaluated as the formula is written (no common subexpressions between
terms; a joint axis is a general 6-vector S_i, its zeros multiplied too: the kernels take any
axis). For a tree of n_R revolute and n_P prismatic joints with r root links they are

    ops = n · PER_LINK + n_R · JCALC_REVOLUTE + n_P · JCALC_PRISMATIC − r · ROOT_SAVING + CONSTANT,

so for a serial chain of n revolute joints (C*: 347 n − 86 mul, 264 n − 72 add; classic:
525 n − 86 mul, 402 n − 72 add) — the closed forms docs/cstar_slotine_li.md quotes. The
comparison is exact: a double-counted cross product, a term computed twice or a pass added to
the kernel changes a coefficient by at least 6.

Where the source differs from the plain evaluation it is in the table, with its size: the first
link skips transforming v_0 = u_0 = 0 and carries only −g (ROOT_SAVING, exact, once per root);
the cross products v × e, u × e, u × v go through the scaled cross product with scale 1
(SCALE_BY_ONE, 6 mul each), and a few sums start from a stored 0 (15 adds per root link, 1 for
‖s‖², 6 per link for the classic bracket).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from rtctl.bench.control import format_table, random_chain as revolute_chain
from rtctl.control.opcount import count_slotine_li_tick
from rtctl.control.slotine_li import SlotineLi
from rtctl.model.robot import PRISMATIC, REVOLUTE


def cost(mul, add):
    return np.array([mul, add])


# 3-vectors and 3×3 matrices
ROT3 = cost(9, 6)  # E x: three dot products of length 3
CROSS3 = cost(6, 3)  # a × b
ADD3 = cost(0, 3)
DOT3 = cost(3, 2)
SCALE3 = cost(3, 0)
MATMUL3 = 3 * ROT3  # R_tree J: a rotation applied to three columns
# 6-vectors (motion m = [ω; v], force f = [n; f])
ADD6, SCALE6, DOT6 = cost(0, 6), cost(6, 0), cost(6, 5)
XMOTION = 2 * ROT3 + CROSS3 + ADD3  # X m = [E ω; E (v − r × ω)]
XFORCE_T = 2 * ROT3 + CROSS3 + ADD3  # Xᵀ f = [Eᵀ n + r × Eᵀ f; Eᵀ f]
CRM = 3 * CROSS3 + ADD3  # v × m = [ω × m_ω; ω × m_v + v × m_ω]
CRF = 3 * CROSS3 + ADD3  # v ×* f = [ω × n + v × f; ω × f]
INERTIA = ROT3 + CROSS3 + ADD3 + SCALE3 + CROSS3 + ADD3  # I m = [J ω + h × v; m v − h × ω] (J symmetric 3×3)
PHI = DOT3 + 2 * CROSS3 + ADD3 + cost(9, 3)  # φ(x, y): m: v_x·v_y; h: v_y × ω_x + v_x × ω_y; J: 3 + 3·2 products
SCALE_BY_ONE = cost(6, 0)  # a cross product through the scaled one, scale 1
ADD_ONTO_ZERO = cost(0, 1)  # a sum the source starts from a stored 0

# Joint transform X_i = X_J(q_i) X_T (jcalc); trig counted apart: a sin and a cos per revolute joint
RODRIGUES = 3 * cost(2, 1) + 6 * cost(3, 1) + cost(0, 1)  # J_ab = t a_a a_b + c δ_ab ∓ s a_c, t = 1 − c; entrywise
JCALC_REVOLUTE = RODRIGUES + MATMUL3  # E = (R_tree J)ᵀ, r = p_tree
JCALC_PRISMATIC = ROT3 + SCALE3 + ADD3  # E = R_treeᵀ, r = p_tree + R_tree a q

SHARED = [  # every link, both laws
    ("(18) q̇_r = q̇_d − Λ q̃, q̈_r = q̈_d − Λ (q̇ − q̇_d), s = q̇ − q̇_r", cost(2, 5)),
    ("dead zone: ‖s‖² term (summed from 0: n adds, not n − 1)", cost(1, 1)),
    ("(34) v_i = X_i v_λ + S_i q̇_i", XMOTION + SCALE6 + ADD6),
    ("(34) u_i = X_i u_λ + S_i q̇_r,i", XMOTION + SCALE6 + ADD6),
    ("(35) w_i = X_i w_λ + S_i q̈_r,i + v_i × S_i q̇_r,i", XMOTION + 2 * (SCALE6 + ADD6) + CRM),
    ("(37) τ_i = S_iᵀ f_i − k_i s_i", DOT6 + cost(1, 1)),
    ("(37) f_λ += X_iᵀ f_i (every link; the root's is in ROOT_SAVING)", XFORCE_T + ADD6),
]
FORCE = {
    "cstar": [("(36) f_i = Î_i w_i + v_i ×* Î_i u_i", 2 * INERTIA + CRF + ADD6)],
    "classic": [("(23) f_i = Î_i w_i + ½ [v ×* Î u + u ×* Î v + Î (u × v)]",
                 4 * INERTIA + 2 * CRF + CRM + 2 * ADD6 + SCALE6 + ADD6),
                ("    u × v scaled by 1; the bracket summed from 0", SCALE_BY_ONE + 6 * ADD_ONTO_ZERO)],
}
UPDATE = {  # with e_i = v_i − u_i (40), ADD6
    "cstar": [("(41)-(42) −P_i [φ(e, w) − φ(v × e, u)]", ADD6 + 2 * PHI + CRM + 10 * cost(1, 1)),
              ("    v × e scaled by 1", SCALE_BY_ONE)],
    "classic": [("(26)-(27) −P_i [φ(e, w) + ½ (φ(e, u × v) − φ(v × e, u) − φ(u × e, v))] (u × v from (23))",
                 ADD6 + 4 * PHI + 2 * CRM + 10 * cost(2, 3)),
                ("    v × e, u × e scaled by 1", 2 * SCALE_BY_ONE)],
}
# A root link saves the transforms of its parent's zero quantities; its sums S q̇ etc. are still
# added onto a stored 0 (v_1, u_1, w_1's angular half: 15 adds a root-specific pass would save too).
ROOT_SAVING = (2 * XMOTION  # v_0 = u_0 = 0: nothing to transform (34)
               + XMOTION - ROT3  # w_0 = [0; −g]: only E (−g) (35)
               + XFORCE_T + ADD6)  # no parent to pass f_i to (37)
CONSTANT = cost(1, 0)  # dead zone: δ·δ


def per_link(law, adapt):
    return sum(c for _, c in SHARED + FORCE[law] + (UPDATE[law] if adapt else []))


def expected(model, law, adapt):
    """(mul, add, trig) of one tick by the closed form."""
    types = np.asarray(model.joint_types)
    n_r, n_p = int(np.sum(types == REVOLUTE)), int(np.sum(types == PRISMATIC))
    roots = int(np.sum(np.asarray(model.parent) < 0))
    ops = (model.nq * per_link(law, adapt) + n_r * JCALC_REVOLUTE + n_p * JCALC_PRISMATIC
           - roots * ROOT_SAVING + CONSTANT)
    return int(ops[0]), int(ops[1]), 2 * n_r


def count(model, law, adapt=True, seed=0):
    rng = np.random.default_rng(seed)
    state = [rng.uniform(-1, 1, model.nq) for _ in range(5)]
    c = SlotineLi(model, law=law, lam=rng.uniform(1, 9, model.nq), kd=rng.uniform(1, 9, model.nq),
                  gamma=rng.uniform(0.1, 2, (model.nq, 10)))
    tally, tau, params_dot = count_slotine_li_tick(model, law, state, c.params_hat, c.gamma, c.lam, c.kd, adapt)
    return tally, (tau, params_dot), c.compute(*state)


def a_tree(chain):
    """Two branched subtrees on the base, from a 7-link chain."""
    return dataclasses.replace(chain, parent=np.array([-1, 0, 1, 1, -1, 4, 4]))


@pytest.mark.parametrize("law", ["cstar", "classic"])
@pytest.mark.parametrize("adapt", [True, False])
def test_counts_equal_the_closed_form_from_the_equations(law, adapt, puma, random_chain):
    robots = [revolute_chain(n, n) for n in (1, 2, 3, 6, 7)] + [puma, random_chain(9, 4), a_tree(random_chain(7, 1))]
    assert any(np.any(r.joint_types == PRISMATIC) for r in robots) and any(np.sum(r.parent < 0) > 1 for r in robots)
    for robot in robots:
        tally = count(robot, law, adapt)[0]
        assert (tally.mul, tally.add, tally.trig) == expected(robot, law, adapt), robot.name


def test_closed_forms_for_a_revolute_chain_are_the_documented_ones():
    """mul(n) = a n + b, add(n) = c n + d for an n-joint revolute chain, as docs/cstar_slotine_li.md states them."""
    def form(law, adapt):
        slope = per_link(law, adapt) + JCALC_REVOLUTE
        offset = CONSTANT - ROOT_SAVING
        return tuple(f"{slope[k]} n − {-offset[k]}" for k in range(2))

    assert form("cstar", True) == ("347 n − 86", "264 n − 72")
    assert form("classic", True) == ("525 n − 86", "402 n − 72")
    assert form("cstar", False) == ("265 n − 86", "208 n − 72")
    assert form("classic", False) == ("361 n − 86", "286 n − 72")
    doc = (Path(__file__).resolve().parents[2] / "docs" / "cstar_slotine_li.md").read_text()
    for law in ("cstar", "classic"):
        for adapt in (True, False):
            assert all(f in doc for f in form(law, adapt)), (law, adapt)


@pytest.mark.parametrize("law", ["cstar", "classic"])
def test_counted_tick_gives_the_compiled_kernels_outputs(law, random_chain, puma):
    """The counts are of the code that runs: the counted mirror's τ and dπ̂/dt are the compiled kernel's, bit for bit."""
    for model in (puma, random_chain(5, 3)):  # with prismatic joints
        _, mirrored, compiled = count(model, law)
        np.testing.assert_array_equal(mirrored[0], compiled[0])
        np.testing.assert_array_equal(mirrored[1], compiled[1])


def test_bench_table_formats(puma):
    row = {"robot": "x", "n": 2, "cstar": {"tick_us": 1.0, "compiled_us": 0.5, "mul": 1, "add": 2},
           "classic": {"tick_us": 2.0, "compiled_us": 1.0, "mul": 3, "add": 4}, "pinocchio_tau_us": None,
           "cstar_over_classic": 0.5, "cstar_over_classic_compiled": 0.5, "cstar_over_pinocchio": None,
           "model_based": {"computed_torque": {"call_us": 0.75}, "pd_gravity": {"call_us": 1.25}}}
    text = format_table({"rows": [row], "t24_over_t6": {"cstar": 3.0, "classic": 3.0},
                         "t24_over_t6_compiled": {"cstar": 3.0, "classic": 3.0},
                         "goals": {"cstar_over_classic_le_0.75": True, "cstar_tick_le_half_pinocchio": None}})
    assert "x" in text and "n/a" in text and "yes" in text
    assert "x C* 0.50 classic 1.00 CT 0.75 PD 1.25" in text  # update() − kernel, per law
