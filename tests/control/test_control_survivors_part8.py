"""Tests for control mutants that survived the fast pass of the run over every mutant, resumed
again in two shards (docs/mutation/control.md), part 8:

* a Slotine–Li configuration that leaves its options out gets the documented defaults: the
  C* law, no projection, no dead zone, no drive-train model;
* ARMA/GMV: a drift mean q̂ (26) that overflowed while θ̂, P, r̂ and R̂ stayed finite is named as
  the drift mean (a check of the wrong row named it the drift covariance Q̂);
* ARMA/GMV: the first adapted drift covariance is (27) from filterpy's Kalman step, floored at
  ``Q_min`` and not at Q̂(0) (handing the filter Q̂ as its floor let Q̂ never fall);
* the margins' search, with 1 unstable, starts from the stable grid factor nearest to 1, as
  documented (another stable interval further away is not the one reported);
* the trajectory's margins include the drive train by default, as the loop's points do, and
  are by default the worst of 24 points for 0, 1 and 2 periods of delay (docs/cstar_delay.md and
  ``rtctl margins --help``).
"""
import itertools

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from arma_loop import shipped
from rtctl.config import load_config
from rtctl.control import margins as margins_module
from rtctl.control.arma_gmv import ArmaGmv
from rtctl.control.base import Reference
from rtctl.control.margins import PointMargins, stable_interval, trajectory_margins
from rtctl.control.slotine_li import LAWS, SlotineLi
from rtctl.errors import ControllerError
from rtctl.hal.joints import JointCommand, JointState
from rtctl.runtime import build
from rtctl.trajectory import JointLimits, through_waypoints
from test_config import configured  # (the shipped C* job with lam, kd, gamma only)
from test_control_survivors import _primed  # (the shipped ARMA/GMV job, one update made)


def test_slotine_li_options_left_out_get_the_documented_defaults(tmp_path):
    (c,) = build(load_config(configured(tmp_path, ""))).controllers
    assert c.law == "cstar" and "cstar" in LAWS
    assert not c.projection and c.dead_zone == 0.0
    assert not c.motor_model  # "motor_model = true adds the robot file's armature …"


def test_a_drift_mean_that_overflowed_alone_is_named(tmp_path):
    """q̂(k+1) = (1 − d_k) q̂ + d_k (q̂ + K ε) overflows where θ̂(k+1|k+1) = θ̂ + q̂ + K ε does not
    (θ̂ = −q̂ ≈ −max float, a huge y making K ε large): the fault names q̂. Which coefficient,
    sign and y reach that state depends on the regressor, so every case of the grid where the
    update left q̂ alone non-finite must name it, and at least one case must."""
    named = []
    for a, sign, y in itertools.product(range(5), (1.0, -1.0), (1e306, 1e307)):
        c, state, ref, cmd = _primed(tmp_path, adapt="{ r = false, R = false, q = true, Q = false }")
        f = c.filter
        f.P[1] = 1e4 * np.eye(f.P.shape[1])  # a large gain K
        f.theta[a, 1], f.q_hat[a, 1] = -sign * 1.7976e308, sign * 1.7976e308
        state.position[1] = y
        try:
            c.update(0.02, state, ref, cmd)
            continue
        except ControllerError as e:
            message = str(e)
        others_finite = (np.isfinite(f.theta[:, 1]).all() and np.isfinite(f.P[1]).all()
                         and np.isfinite(f.signals[:2, 1]).all())
        if others_finite and not np.isfinite(f.q_hat[:, 1]).all():
            named.append(message)
    assert named and all(m == "joint 'shoulder': non-finite drift mean q̂" for m in named), named


def test_the_first_adapted_drift_covariance_is_27_floored_at_q_min():
    """Q̂ adapted alone from Q̂(0) = 10⁻³ with Q_min = 10⁻¹⁵: with d_0 = 1, (27) gives
    Q̂(1) = max(K_a² ε² + P(1|1)_aa − P(0|0)_aa, Q_min), K, ε and P(1|1) from filterpy's predict
    and update. A small innovation makes the sample fall below Q̂(0) for some coefficient."""
    cfg, _ = shipped()
    model = cfg.model
    theta0 = np.array([2.0, -1.0, 1e-4, 1e-4, 0.0])
    P0 = np.array([1e-6, 1e-6, 1e-10, 1e-10, 1e-10])
    Q0, Q_min = 1e-3, 1e-15
    c = ArmaGmv(model, theta0=theta0, P0=P0, rho=1e-9, r0=0.0, R0=1e-4, Q0=Q0, Q_min=Q_min, adapt=("Q",))
    n = model.nq
    y0 = np.array([0.7, -0.4, 1.1])
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:] = ref.q[:] = y0
    c.reset(state)
    c.update(0.0, state, ref, cmd)  # primes the histories: y(k−1) = y(k−2) = y0, u(k−1) = u0
    u0 = cmd.tau_ff.copy()
    state.position[:] = y0 + np.array([1e-4, -2e-4, 3e-4])
    c.update(0.02, state, ref, cmd)
    fell = False
    for i in range(n):
        kf = KalmanFilter(dim_x=5, dim_z=1)
        kf.x = theta0.reshape(5, 1).copy()
        kf.P = np.diag(P0)
        kf.Q = Q0 * np.eye(5)
        kf.R = np.array([[1e-4]])
        kf.H = np.array([[y0[i], y0[i], u0[i], 0.0, 0.0]])  # h(k) of (15), d = 1
        kf.predict()
        kf.update(np.array([[state.position[i]]]))
        K, eps = kf.K[:, 0], kf.y[0, 0]
        expected = np.maximum(K * K * eps * eps + np.diag(kf.P) - P0, Q_min)
        np.testing.assert_allclose(c.filter.Q_hat[:, i], expected, rtol=1e-6, atol=1e-18)
        fell |= bool((expected < Q0).any())
    assert fell  # (the case the floor decides)


def test_with_one_unstable_the_search_starts_from_the_nearest_stable_grid_factor():
    """Stable on [0.2, 0.4] and on [5, 20]: the grid's 10^−½ is nearer to 1 than its 10, so the
    interval reported is the first, to the bisection's precision."""
    lo, hi = stable_interval(lambda f: 0.2 <= f <= 0.4 or 5.0 <= f <= 20.0)
    assert lo == pytest.approx(0.2, rel=1e-4) and hi == pytest.approx(0.4, rel=1e-4)


def _move(puma):
    c = SlotineLi(puma, params0="zeros", gamma=2.0, lam=10.0, kd=50.0)
    n = puma.nq
    start = np.array([0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0])
    limits = JointLimits(np.full(n, 10.0), np.full(n, 50.0), puma.q_min, puma.q_max)
    return c, through_waypoints([start + 0.3], limits, start=start, durations=[1.0], t0=0.0)


def test_trajectory_margins_include_the_drive_train_by_default(puma):
    c, traj = _move(puma)
    margins = {m: trajectory_margins(puma, c, traj, 500.0, delays=(1,), samples=2, motor_model=m)
               for m in (True, False)}
    assert margins[True] != margins[False]  # (so the default is told apart)
    assert trajectory_margins(puma, c, traj, 500.0, delays=(1,), samples=2) == margins[True]


def test_trajectory_margins_take_24_points_and_delays_0_1_2_by_default(puma, monkeypatch):
    c, traj = _move(puma)
    calls = []

    def counted(H, KD, M, T, d):
        calls.append(d)
        return PointMargins(rho=0.5, p_max=2.0, kd_min=0.5, kd_max=2.0, rho_pd=0.5)

    monkeypatch.setattr(margins_module, "point_margins", counted)
    out = trajectory_margins(puma, c, traj, 500.0, motor_model=True)
    assert sorted(out) == [0, 1, 2]
    assert sorted(calls) == [0] * 24 + [1] * 24 + [2] * 24
