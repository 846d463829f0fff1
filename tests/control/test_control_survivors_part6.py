"""Tests for control mutants that survived the fast pass of the restarted run over every mutant
(docs/mutation/control.md), part 6:

* the ARMA/GMV telemetry's r̂, R̂ and ε are the filter's statistics of those names (a mapping
  by row number let ε be published as R̂);
* inside the dead zone every parameter rate is 0, also after a tick that adapted;
* a loop with ρ = 1 exactly (no damping, no adaptation) is not stable;
* the stability margins' search: a factor is doubled or halved at most 12 times, so a loop
  still stable at ×4096 (or 1/4096) reports ∞ (or 0), and a finite margin is bisected in log
  to within 2^(2^−20) of the edge (docs/cstar_delay.md).
"""
import numpy as np
import pytest

from arma_loop import shipped
from rtctl.control.base import Reference
from rtctl.control.margins import point_margins, stable_interval
from rtctl.control.slotine_li import SlotineLi
from rtctl.hal.joints import JointCommand, JointState


def test_the_telemetrys_noise_statistics_are_the_filters():
    """After a few steps ε takes both signs while R̂ stays at or above R_min: a channel named R̂
    that carried ε (or r̂) would not."""
    cfg, c = shipped()
    n = cfg.model.nq
    y0 = cfg.sim.vector("initial_q", n)
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:] = y0
    ref.q[:] = y0 + 2e-3
    c.reset(state)
    eps = []
    for k in range(12):
        state.position[:] = y0 + 1e-4 * np.sin(1.7 * k)
        c.update(0.02 * k, state, ref, cmd)
        eps.append(c.internals["eps"].copy())
    f, tel = c.filter, c.internals
    eps = np.array(eps)
    assert (eps < 0).any() and (eps > 0).any()
    assert np.all(tel["R_hat"] >= f.R_min) and np.all(tel["R_hat"] > 0)
    for name, row in (("r_hat", f.r_hat), ("R_hat", f.R_hat), ("eps", f.eps)):
        assert np.shares_memory(tel[name], row) and tel[name].shape == row.shape == (n,), name
        np.testing.assert_array_equal(tel[name], row)
    assert not np.array_equal(tel["R_hat"], tel["eps"]) and not np.array_equal(tel["R_hat"], tel["r_hat"])


@pytest.mark.parametrize("edge, expected", [(5000.0, np.inf), (4000.0, 4000.0)])
def test_a_factor_beyond_twelve_doublings_is_unbounded(edge, expected):
    lo, hi = stable_interval(lambda f: f < edge)
    assert lo == 0.0  # stable down to 1/4096 and below: no lower edge
    assert hi == pytest.approx(expected, rel=1e-6) and (hi == np.inf or hi <= edge)


@pytest.mark.parametrize("edge, expected", [(1 / 5000, 0.0), (1 / 4000, 1 / 4000)])
def test_a_factor_below_twelve_halvings_is_unbounded_below(edge, expected):
    lo, hi = stable_interval(lambda f: f > edge)
    assert hi == np.inf
    assert lo == pytest.approx(expected, rel=1e-6) and (lo == 0.0 or lo >= edge)


@pytest.mark.parametrize("edge", [1.3, 7.3, 77.7, 0.031])
def test_a_finite_margin_is_bisected_to_within_one_millionth_of_its_edge(edge):
    """20 log-bisections of one doubling: the stable end is at most 2^(2^−20) − 1 ≈ 6.6e−7 below
    the edge, relative."""
    lo, hi = stable_interval(lambda f: 0.01 < f < edge) if edge > 1 else stable_interval(lambda f: edge < f < 100)
    found = hi if edge > 1 else lo
    ratio = edge / found if edge > 1 else found / edge
    assert 1.0 <= ratio <= 2.0 ** (2.0**-20) * (1 + 1e-12)


def test_a_loop_on_the_unit_circle_is_not_stable():
    """Stable means ρ < 1 (docs/cstar_delay.md): with no damping and no adaptation the map is
    the identity, ρ = 1 exactly — an undamped joint keeps any error forever. No factor of
    either gain makes it stable."""
    m = point_margins(np.eye(2), np.zeros(2), np.zeros((2, 2)), 0.001, 0)
    assert m.rho == 1.0 and m.rho_pd == 1.0
    assert np.isnan([m.p_max, m.kd_min, m.kd_max]).all()


def test_inside_the_dead_zone_every_rate_is_zero_after_an_adapting_tick(puma):
    """dπ̂/dt = 0 while ‖s‖ ≤ dead_zone — all ten parameters of every link, also when the tick
    before adapted (a zeroing loop one short left the tenth rate, I_zz's, from that tick)."""
    rng = np.random.default_rng(9)
    q_d, qd_d, qdd_d = rng.uniform(-1.5, 1.5, 6), rng.uniform(-2, 2, 6), rng.uniform(-5, 5, 6)
    q, qd = q_d + rng.normal(0, 0.2, 6), rng.uniform(-2, 2, 6)
    c = SlotineLi(puma, lam=5.0, kd=50.0, gamma=rng.uniform(0.1, 3, (6, 10)), dead_zone=1e-3)
    _, adapting = c.compute(q, qd, q_d, qd_d, qdd_d)
    assert np.any(adapting[:, 9] != 0.0)  # the tenth rate moved
    _, resting = c.compute(q_d, qd_d, q_d, qd_d, qdd_d)  # s = 0
    np.testing.assert_array_equal(resting, 0.0)
