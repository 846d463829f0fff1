"""Tests for control mutants that survived the fast pass of the run over every mutant, resumed in
two shards (docs/mutation/control.md), part 7:

* the consistency projection makes the corrections its module docstring states, one after the
  other, and as many as it reports: at most ``MAX_CORRECTIONS`` per call, the next call going on
  where the last stopped. The reference is the docstring's relaxed half-space projection written
  with numpy's eigenvectors and the pseudo-inertia built from its definition (a loop one short
  made 15 corrections and reported 16);
* the Slotine–Li controller's tick projects π̂ + h dπ̂/dt the same way, every link on its own
  gains (a scratch row shared with the eigen-solver's matrix corrupted the eigenvector);
* after ``reset`` the controller is a new one, the projection's remembered cut directions
  forgotten too (a remembered cut that still cuts is taken before the eigenvector), and its
  first update integrates nothing, so projects nothing: π̂ stays π̂(0);
* the GMV law refuses any one history of the wrong length, and takes any u_max > 0;
* the margins' report marks every ρ ≥ 1 UNSTABLE; an option's error says what it needs (> 0
  or ≥ 0).
"""
import numpy as np
import pytest

from random_robots import random_params
from rtctl.control.base import Reference
from rtctl.control.consistency import MAX_CORRECTIONS, RELAXATION, TOLERANCE, project_link
from rtctl.control.gmv import gmv_control
from rtctl.control.margins import PointMargins, format_margins
from rtctl.control.slotine_li import SlotineLi
from rtctl.errors import ConfigError
from rtctl.estimation import ArxOrder
from rtctl.hal.joints import JointCommand, JointState


def pseudo_inertia(p):
    """P(π) = [[½ tr(J) 1 − J, h], [hᵀ, m]], π = (m, h, Ixx, Ixy, Iyy, Ixz, Iyz, Izz)."""
    J = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
    return np.block([[0.5 * np.trace(J) * np.eye(3) - J, p[1:4, None]], [p[None, 1:4], p[0:1, None]]])


BASIS = [pseudo_inertia(e) for e in np.eye(10)]  # P is linear in π: a_x[k] = xᵀ P(e_k) x


def corrected(p, gamma, limit):
    """The docstring's corrections, at most ``limit``: while λ_min(P(π̂)) < −TOLERANCE·|tr P|,
    π̂ ← π̂ − ρ (a_x·π̂ / a_xᵀ Γ a_x) Γ a_x with x the unit eigenvector of λ_min. → (π̂, count)."""
    p = p.copy()
    for count in range(limit):
        P = pseudo_inertia(p)
        lam, V = np.linalg.eigh(P)
        if lam[0] >= -TOLERANCE * abs(np.trace(P)):
            return p, count
        a = np.array([V[:, 0] @ B @ V[:, 0] for B in BASIS])
        p -= RELAXATION * (a @ p) / (a @ (gamma * a)) * gamma * a
    return p, limit


def _cases(need_more_than, need_at_most, n):
    rng = np.random.default_rng(7)
    found = []
    while len(found) < n:
        p = random_params(rng) * rng.uniform(-1.5, 2.5, 10)
        gamma = rng.uniform(0.05, 20, 10)
        if need_more_than < corrected(p, gamma, 60)[1] <= need_at_most:
            found.append((p, gamma))
    return found


def _project(p, gamma, cut):
    return project_link(p, gamma, np.zeros((4, 4)), np.zeros((4, 4)), np.zeros(10), cut)


@pytest.mark.parametrize("case", range(3))
def test_a_call_makes_at_most_max_corrections_and_the_next_goes_on(case):
    p0, gamma = _cases(MAX_CORRECTIONS + 2, 60, 3)[case]
    p, cut = p0.copy(), np.zeros(4)
    assert _project(p, gamma, cut) == MAX_CORRECTIONS
    expected, _ = corrected(p0, gamma, MAX_CORRECTIONS)
    np.testing.assert_allclose(p, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    fewer, _ = corrected(p0, gamma, MAX_CORRECTIONS - 1)
    assert np.abs(p - fewer).max() > 1e-6 * np.abs(expected).max()  # (one correction less is told apart)
    more = _project(p, gamma, cut)  # the next tick, from the cut kept
    expected, total = corrected(p0, gamma, 2 * MAX_CORRECTIONS)
    assert more == total - MAX_CORRECTIONS
    np.testing.assert_allclose(p, expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max())


def test_a_call_that_reaches_the_set_reports_the_corrections_it_made():
    for p0, gamma in _cases(1, MAX_CORRECTIONS - 4, 5):
        p = p0.copy()
        count = _project(p, gamma, np.zeros(4))
        expected, need = corrected(p0, gamma, MAX_CORRECTIONS)
        assert count == need
        np.testing.assert_allclose(p, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_the_controllers_tick_projects_the_euler_step_of_every_link(puma):
    """update(): π̂ ← project(π̂ + h dπ̂/dt) (docs/cstar_slotine_li.md), here with links well
    outside the consistent set, so that the eigenvector path runs."""
    n = puma.nq
    c = SlotineLi(puma, lam=10.0, kd=50.0, gamma=np.linspace(0.5, 3.0, n), projection=True)
    rng = np.random.default_rng(3)
    c.params_hat[:] = puma.params * rng.uniform(-1.5, 2.5, puma.params.shape)
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:], state.velocity[:] = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    ref.q[:] = state.position + 0.1
    c.update(0.0, state, ref, cmd)  # the first tick takes no step: dπ̂/dt for the next
    stepped = c.params_hat + 1e-3 * c.params_dot
    c.update(1e-3, state, ref, cmd)
    outside = 0
    for i in range(n):
        expected, count = corrected(stepped[i], c.gamma[i], MAX_CORRECTIONS)
        outside += count > 0
        np.testing.assert_allclose(c.params_hat[i], expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    assert outside >= n // 2


def _ticks(c, state, ref, cmd, t0, n_ticks):
    taus = []
    for k in range(n_ticks):
        state.position[:] += 1e-3 * state.velocity
        c.update(t0 + 1e-3 * k, state, ref, cmd)
        taus.append(cmd.tau_ff.copy())
    return np.array(taus), c.params_hat.copy()


def test_after_reset_the_controller_runs_as_a_new_one(puma):
    n = puma.nq
    rng = np.random.default_rng(5)
    # −π of a real robot: P(−π) = −P(π) is negative definite, so every direction a reset left
    # behind would cut, and be taken before the eigenvector a new controller starts from.
    params0 = -puma.params
    q0, qd0 = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)

    def controller():
        return SlotineLi(puma, lam=10.0, kd=50.0, gamma=2.0, params0=params0, projection=True)

    def rig():
        state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
        state.position[:], state.velocity[:] = q0, qd0
        ref.q[:] = q0 + 0.1
        return state, ref, cmd

    used = controller()
    _ticks(used, *rig(), 0.0, 20)
    used.reset()
    again = _ticks(used, *rig(), 5.0, 20)
    new = _ticks(controller(), *rig(), 5.0, 20)
    np.testing.assert_array_equal(again[0], new[0])
    np.testing.assert_array_equal(again[1], new[1])


def test_the_first_update_leaves_the_initial_estimate_as_it_is(puma):
    n = puma.nq
    params0 = -puma.params  # outside the consistent set
    c = SlotineLi(puma, lam=10.0, kd=50.0, gamma=2.0, params0=params0, projection=True)
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.velocity[:] = 0.5
    c.update(3.0, state, ref, cmd)
    np.testing.assert_array_equal(c.params_hat, params0)


@pytest.mark.parametrize("y_hist, u_hist", [([0.0], [0.0, 0.0, 0.0]), ([0.0, 0.0], [0.0, 0.0])])
def test_the_gmv_law_refuses_either_history_of_the_wrong_length(y_hist, u_hist):
    with pytest.raises(ValueError, match="past outputs"):
        gmv_control([2.0, -1.0, 1e-4, 1e-4, 0.0], 0.0, 0.0, y_hist, u_hist, ArxOrder(2, 2, 1), 1.0, 1e-9)


def test_the_gmv_law_takes_a_limit_below_one():
    u = gmv_control([2.0, -1.0, 1e-4, 1e-4, 0.0], 0.0, 0.0, [0.0, 0.0], [0.0, 0.0, 0.0], ArxOrder(2, 2, 1), 1.0,
                    1e-9, u_max=0.5)
    assert u == 0.5  # (a 1 rad step asks for far more: saturated)


@pytest.mark.parametrize("rho, marked", [(0.999, False), (1.0, True), (1.5, True)])
def test_the_margins_report_marks_a_spectral_radius_from_one_up_unstable(rho, marked):
    text = format_margins("c", 1000.0, {0: PointMargins(rho=rho, p_max=2.0, kd_min=0.5, kd_max=3.0, rho_pd=0.9)})
    assert text.splitlines()[-1].endswith("UNSTABLE") == marked


@pytest.mark.parametrize("key, value, needs", [("rho", "0.0", "> 0"), ("R0", "-1.0", "≥ 0")])
def test_an_arma_option_out_of_range_says_what_it_needs(tmp_path, key, value, needs):
    from arma_loop import shipped

    with pytest.raises(ConfigError) as err:
        shipped(tmp_path, **{key: value})
    assert f"numbers {needs}," in str(err.value)
