"""Tests for control mutants that survived the fast pass of the run over every mutant
(docs/mutation/control.md), part 3: the ARMA/GMV controller and the GMV law, each against the
documented behaviour or an independent reference:

* the first filter step of the controller is the Kalman update of (18)-(23) with the drift mean
  q̂ in the prediction (filterpy as the reference), and a Q̂ that overflows is named as such;
* the histories after ``reset`` and ``resume``: the measured position (0 without a state), u = 0,
  and no preview on the first update (checked against :func:`gmv_control`);
* the telemetry's â, b̂, r̂ are the estimates the law used;
* ρ must be finite and > 0 (constructor and ``rtctl set``), u_max > 0 (the law);
* the margins: M's numerical range independent of its units, a P unstable at its configured
  gain gets its margin below 1 from the grid, the loop points along the move with the drive train.
* the op counter: a counted division is a true division (counted as a multiplication), its
  comparisons are strict; an adapting tick adapts however small the error (no dead zone).
* the documented defaults, from the constructor and from a configuration that leaves them out;
* the options' shapes: r0 may be negative, one row of θ̂(0) for every joint, no booleans, Q0 ≥ 0.
"""
import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from arma_loop import SHIPPED, replaced, shipped
from rtctl.config import load_config
from rtctl.control.arma_gmv import ArmaGmv
from rtctl.control.base import Reference
from rtctl.control.gmv import gmv_control
from rtctl.control.tunable import read_value
from rtctl.errors import ConfigError, ControllerError
from rtctl.estimation import ArxOrder
from rtctl.hal.joints import JointCommand, JointState
from rtctl.runtime import build

THETA0 = [2.0, -1.0, 1e-4, 1e-4, 0.0]


def _rig(n, q):
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:] = q
    ref.q[:] = q
    return state, ref, cmd


def _without(tmp_path, *keys):
    """The shipped job with the single-line options ``keys`` left out."""
    text = replaced(SHIPPED.read_text(), {})
    path = tmp_path / "run.toml"
    path.write_text("\n".join(ln for ln in text.splitlines()
                              if ln.split("=", 1)[0].strip() not in keys))
    cfg = load_config(path)
    return cfg, build(cfg).controllers[0]


def _expected_u(c, i, theta, r_hat, y, y_hist, u_hist, y_star):
    j = c.joints[i]
    return gmv_control(theta, r_hat, y, y_hist, u_hist, c.order, y_star, c.joint_params[0, i],
                       c.model.tau_max[j])


def test_the_first_filter_step_is_the_kalman_update_with_the_drift_mean():
    """(19)-(23) for one step from θ̂(0), P(0), q̂(0), Q̂(0), r̂(0), R̂(0), nothing adapted:
    filterpy's predict (x + q̂, P + Q̂) and update (z = y − r̂). Q_min ≠ q̂(0): the mutant that
    hands Q_min to the filter as q̂ moves θ̂ by Q_min instead."""
    cfg, _ = shipped()
    model = cfg.model
    q0 = np.array([1e-3, -2e-3, 1e-6, 0.0, 2e-6])
    Q0 = np.array([1e-7, 2e-7, 1e-12, 1e-12, 1e-12])
    P0 = np.array([1e-6, 1e-6, 1e-10, 1e-10, 1e-10])
    c = ArmaGmv(model, theta0=THETA0, P0=P0, rho=1e-9, r0=0.01, R0=1e-4, q0=q0, Q0=Q0,
                Q_min=[5e-3, 5e-3, 5e-3, 5e-3, 5e-3], adapt=())
    n = model.nq
    y0 = np.array([0.7, -0.4, 1.1])
    state, ref, cmd = _rig(n, y0)
    c.reset(state)
    c.update(0.0, state, ref, cmd)  # primes the histories: y(k−1) = y(k−2) = y0, u(k−1) = u0
    u0 = cmd.tau_ff.copy()
    state.position[:] = y0 + np.array([0.01, 0.02, -0.03])
    c.update(0.02, state, ref, cmd)
    for i in range(n):
        kf = KalmanFilter(dim_x=5, dim_z=1)
        kf.x = np.array(THETA0, dtype=float).reshape(5, 1)
        kf.P = np.diag(P0)
        kf.F = np.eye(5)
        kf.B = np.eye(5)
        kf.Q = np.diag(Q0)
        kf.R = np.array([[1e-4]])
        kf.H = np.array([[y0[i], y0[i], u0[i], 0.0, 0.0]])  # h(k) of (15), d = 1
        kf.predict(u=q0.reshape(5, 1))
        kf.update(np.array([[state.position[i] - 0.01]]))
        np.testing.assert_allclose(c.filter.theta[:, i], kf.x[:, 0], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(c.filter.P[i], kf.P, rtol=1e-6, atol=1e-18)


def test_a_drift_covariance_that_overflows_is_named():
    """Q̂ adapted (R̂ not): y = 10²⁰⁰ makes K ε² Kᵀ of (27) overflow while θ̂, P, r̂ stay finite;
    the controller fails naming Q̂ before computing a torque from it."""
    cfg, _ = shipped()
    c = ArmaGmv(cfg.model, theta0=THETA0, P0=[1e-6, 1e-6, 1e-10, 1e-10, 1e-10], rho=1e-9, adapt=("r", "Q"))
    state, ref, cmd = _rig(cfg.model.nq, [0.7, -0.4, 1.1])
    c.reset(state)
    c.update(0.0, state, ref, cmd)
    state.position[0] = 1e200
    with pytest.raises(ControllerError, match="joint 'waist': non-finite drift covariance Q̂"):
        c.update(0.02, state, ref, cmd)


def test_the_first_update_after_a_reset_starts_from_the_measured_position_without_preview():
    """Step 1 of the module docstring: on the first update the histories are y = the measured
    position, u = 0; T is not known yet, so y* = q_d (no preview, though q̇_d ≠ 0)."""
    cfg, c = shipped()
    n = cfg.model.nq
    y0 = cfg.sim.vector("initial_q", n)
    state, ref, cmd = _rig(n, y0)
    ref.q[:] = y0 + 1e-3
    ref.qd[:] = 0.3
    ref.qdd[:] = 2.0
    for with_state in (True, False):
        c.reset(state if with_state else None)
        c.update(5.0, state, ref, cmd)
        for i, j in enumerate(c.joints):
            past_y = np.full(2, y0[j] if with_state else 0.0)  # 0 without a state (docstring)
            expected = _expected_u(c, i, c.filter.theta0[:, i], 0.0, y0[j], past_y, np.zeros(3), ref.q[j])
            assert cmd.tau_ff[j] == pytest.approx(expected, rel=1e-12, abs=1e-9)


def test_resume_keeps_the_estimates_and_restarts_the_histories():
    cfg, c = shipped()
    n = cfg.model.nq
    y0 = cfg.sim.vector("initial_q", n)
    state, ref, cmd = _rig(n, y0)
    ref.q[:] = y0 + 1e-3
    c.reset(state)
    for k in range(4):
        c.update(0.02 * k, state, ref, cmd)
    state.position[:] = y0 + 0.05
    ref.qd[:] = 0.3
    for with_state in (True, False):
        if not with_state:  # near 0, where the histories' 0 keeps the torque off its limit
            state.position[:] = 1e-5
            ref.q[:] = 2e-5
        theta, r_hat = c.filter.theta.copy(), c.filter.r_hat.copy()
        c.resume(state if with_state else None)
        c.update(9.0, state, ref, cmd)  # no filter step, no preview on the first update
        np.testing.assert_array_equal(c.filter.theta, theta)
        for i, j in enumerate(c.joints):
            past_y = np.full(2, state.position[j] if with_state else 0.0)
            expected = _expected_u(c, i, theta[:, i], r_hat[i], state.position[j], past_y, np.zeros(3), ref.q[j])
            assert cmd.tau_ff[j] == pytest.approx(expected, rel=1e-12, abs=1e-9)
            assert with_state or abs(cmd.tau_ff[j]) < c.model.tau_max[j]


def test_the_telemetrys_estimates_are_those_the_law_used():
    """internals' â, b̂, r̂ put into the law (tests/control/test_gmv.py checks it against the
    polynomial form) give the torque commanded — after three filter steps, when r̂ differs
    from R̂ and from the prediction error y − hᵀθ̂(k+1|k)."""
    cfg, c = shipped()
    n = cfg.model.nq
    y0 = cfg.sim.vector("initial_q", n)
    state, ref, cmd = _rig(n, y0)
    ref.q[:] = y0 + 2e-3
    c.reset(state)
    for k in range(4):
        y_hist, u_hist = c.y_hist.copy(), c.u_hist.copy()
        state.position[:] = y0 + 1e-4 * k * k
        c.update(0.02 * k, state, ref, cmd)
    tel = c.internals
    assert np.all(np.abs(tel["r_hat"]) > 1e-6)  # a real r̂ (gravity), far from R̂ ≈ 1e-8
    for i, j in enumerate(c.joints):
        theta = np.concatenate([tel["a_hat"][:, i], tel["b_hat"][:, i]])
        y_star = ref.q[j]  # q̇_d = q̈_d = 0
        expected = _expected_u(c, i, theta, tel["r_hat"][i], state.position[j], y_hist[:, i], u_hist[:, i], y_star)
        assert cmd.tau_ff[j] == pytest.approx(expected, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("rho", [0.0, -0.5, [1e-9, np.inf, 1e-9]])
def test_rho_must_be_finite_and_positive(rho):
    cfg, _ = shipped()
    with pytest.raises(ValueError, match="rho must be finite and > 0"):
        ArmaGmv(cfg.model, theta0=THETA0, P0=1e-6, rho=rho)


def test_rho_set_at_run_time_must_be_positive():
    _, c = shipped()
    tunable = c.tunables()["rho"]
    assert read_value(tunable, "controllers[0]", "rho", 2e-9).tolist() == [2e-9] * 3
    with pytest.raises(ConfigError):
        read_value(tunable, "controllers[0]", "rho", 0.0)


def test_the_constructors_defaults_are_documented():
    cfg, _ = shipped()
    c = ArmaGmv(cfg.model, theta0=THETA0, P0=1e-6, rho=1e-9)
    f = c.filter
    assert f.lam == 0.98 and c.divisor == 1
    assert np.all(f.r_hat == 0.0) and np.all(f.R_hat == 1e-8) and f.R_min == 1e-12
    assert np.all(f.q_hat == 0.0) and np.all(f.Q_hat == 0.0) and np.all(f.Q_min == 0.0)
    assert list(f.switches[:4]) == [1, 1, 0, 0] and f.noise_form == "sage_husa"


def test_options_left_out_take_the_documented_defaults(tmp_path):
    cfg, c = _without(tmp_path, "na", "nb", "d", "lam", "adapt", "r0", "R0", "Q0", "R_min", "noise_form")
    f = c.filter
    assert c.order == ArxOrder(2, 2, 1) and f.lam == 0.98
    assert list(f.switches[:4]) == [1, 1, 0, 0]  # r̂ and R̂ adapted, q̂ and Q̂ not
    assert np.all(f.r_hat == 0.0) and np.all(f.q_hat == 0.0) and np.all(f.Q_min == 0.0)
    assert np.all(f.R_hat == 1e-8) and f.R_min == 1e-12 and np.all(f.Q_hat == 0.0)


def test_r0_may_be_negative(tmp_path):
    """r̂ is the virtual noise's mean (it carries gravity, of either sign): not bounded below."""
    _, c = shipped(tmp_path, r0="[-0.5, 0.25, -1e-3]")
    assert c.filter.r_hat.tolist() == [-0.5, 0.25, -1e-3]


def test_one_row_of_theta0_is_every_joints(tmp_path):
    _, c = shipped(tmp_path, theta0="[2.0, -1.0, 1e-4, 2e-4, 3e-4]")
    np.testing.assert_array_equal(c.filter.theta0, np.tile([[2.0], [-1.0], [1e-4], [2e-4], [3e-4]], (1, 3)))


@pytest.mark.parametrize("key, value", [("theta0", "[2.0, -1.0, true, 1e-4, 0.0]"), ("Q0", "-1.0")])
def test_a_boolean_or_a_negative_covariance_names_the_key(tmp_path, key, value):
    with pytest.raises(ConfigError) as err:
        shipped(tmp_path, **{key: value})
    assert err.value.key_path == f"controllers[0].{key}"


def test_the_law_names_the_lengths_it_got_and_needs_a_positive_limit():
    order = ArxOrder(2, 2, 1)
    theta = np.array(THETA0)
    with pytest.raises(ValueError, match="got 4, 2, 3"):
        gmv_control(theta[:4], 0.0, 0.0, [0, 0], [0, 0, 0], order, 1.0, 1e-9)
    for u_max in (0.0, -0.5):
        with pytest.raises(ValueError, match="u_max must be > 0"):
            gmv_control(theta, 0.0, 0.0, [0, 0], [0, 0, 0], order, 1.0, 1e-9, u_max=u_max)


# the stability margins (rtctl.control.margins)

@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_the_range_of_the_adaptation_stiffness_does_not_depend_on_its_units(scale):
    """M = c·diag(900, 10⁻⁵): both directions are excited (10⁻⁵/900 ≫ rounding) whatever the
    unit c of M, so the map keeps two directions of w: size (d + 1) n + 2."""
    from rtctl.control.margins import closed_loop

    A = closed_loop(np.eye(2), np.array([40.0, 10.0]), scale * np.diag([900.0, 1e-5]), 0.002, 1)
    assert A.shape == (2 * 2 + 2, 2 * 2 + 2)


def test_an_adaptation_unstable_at_the_configured_gain_gets_its_margin_below_one():
    """The scalar loop without delay is stable for P factors f < k / (T μ) (Jury, as in
    tests/control/test_margins.py); with μ ten times larger than k/T, f = 1 is unstable and the
    largest stable factor is k / (T μ) = 0.1, found from the grid below 1."""
    from rtctl.control.margins import point_margins

    h, k, T = 0.19, 15.0, 0.002
    mu = 10.0 * k / T
    m = point_margins(np.array([[h]]), np.array([k]), np.array([[mu]]), T, 0)
    assert m.rho > 1.0
    assert m.p_max == pytest.approx(k / (T * mu), rel=1e-5)


def test_loop_points_follow_the_trajectory_from_its_start_with_the_drive_train(puma):
    """(H, M, K_D + B) at the start, middle and end of a move, computed by hand from the model:
    H with the rotors' armature and the damping with the viscous friction by default
    (``motor_model``), K_D alone without; M = Y diag(P) Yᵀ with the regressor at q̇_r = q̇_d."""
    from rtctl.control.margins import loop_points
    from rtctl.control.slotine_li import SlotineLi
    from rtctl.model.dynamics import mass_matrix
    from rtctl.model.regressor import slotine_li_regressor
    from rtctl.trajectory import JointLimits, through_waypoints

    c = SlotineLi(puma, params0="zeros", gamma=2.0, lam=10.0, kd=50.0)
    n = puma.nq
    start = np.array([0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0])
    limits = JointLimits(np.full(n, 10.0), np.full(n, 50.0), puma.q_min, puma.q_max)
    traj = through_waypoints([start + 0.3], limits, start=start, durations=[1.0], t0=2.0)
    points = list(loop_points(puma, c, traj, samples=3))
    bare = list(loop_points(puma, c, traj, samples=3, motor_model=False))
    assert len(points) == 3
    motors = puma.motors
    for (H, M, D), (H0, _, D0), t in zip(points, bare, [2.0, 0.5 * (2.0 + traj.t_end), traj.t_end]):
        q, qd, qdd = np.zeros(n), np.zeros(n), np.zeros(n)
        traj.sample(t, q, qd, qdd)
        np.testing.assert_allclose(H, mass_matrix(puma, q) + np.diag(motors.armature), rtol=1e-12)
        np.testing.assert_allclose(H0, mass_matrix(puma, q), rtol=1e-12)
        np.testing.assert_allclose(D, 50.0 + motors.viscous, rtol=1e-12)
        np.testing.assert_array_equal(D0, np.full(n, 50.0))
        Y = slotine_li_regressor(puma, q, qd, qd, qdd, "cstar")
        np.testing.assert_allclose(M, Y @ np.diag(c.gamma.reshape(-1)) @ Y.T, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(points[0][0], mass_matrix(puma, start) + np.diag(motors.armature), rtol=1e-9)


# the operation counter (rtctl.control.opcount)

def test_counted_division_is_true_division_counted_as_a_multiplication_and_comparisons_are_strict():
    from rtctl.control.opcount import Counted, Tally

    Counted.tally = Tally()
    q = Counted(7.0) / 2.0
    assert float(q) == 3.5 and (Counted.tally.mul, Counted.tally.add) == (1, 0)
    one = Counted(1.0)
    assert not one < 1.0 and not one > 1.0  # comparisons as on floats (and not counted)
    assert one < 1.5 and not one < 0.5 and one > 0.5 and not one > 1.5
    assert (Counted.tally.mul, Counted.tally.add) == (1, 0)


def test_an_adapting_tick_counts_the_adaptation_however_small_the_error(puma):
    """``adapt=True``: the parameter update runs (no dead zone) even for ‖s‖ ≪ 1, so it counts
    more than the control law alone and gives a non-zero dπ̂/dt."""
    from rtctl.control.opcount import count_slotine_li_tick
    from rtctl.control.slotine_li import SlotineLi

    n = puma.nq
    c = SlotineLi(puma, lam=5.0, kd=5.0, gamma=1.0)
    q = np.full(n, 0.3)
    state = (q, np.full(n, 1e-3), q + 1e-3, np.zeros(n), np.zeros(n))  # ‖s‖ ≈ 10⁻², s² ≈ 10⁻⁴
    on, _, rate = count_slotine_li_tick(puma, "cstar", state, c.params_hat, c.gamma, c.lam, c.kd, adapt=True)
    off, _, none = count_slotine_li_tick(puma, "cstar", state, c.params_hat, c.gamma, c.lam, c.kd, adapt=False)
    assert on.mul > off.mul and on.add > off.add
    assert np.abs(rate).max() > 0.0 and np.all(none == 0.0)
