"""Tests for the estimation mutants that survived the suite (mutation run estimation-s30).

Each checks a documented expectation, computed by hand: the printed equation (27) on one
scalar step; the bound 0 < λ < 1 of the printed reference; the coefficient names θ = [a_1 …
a_na, b_0 … b_nb] (arx module docstring, ``rtctl identify --help``); the gain's R ≥ 10⁻⁹ hᵀPh
(sage_husa module docstring); the filter's options are keywords; ``rtctl identify --joints``
names the first unknown joint and exits 2.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from rtctl.cli import main
from rtctl.errors import RtctlError
from rtctl.estimation import ArxOrder, SageHusa, identify, simulate
from rtctl.estimation.identify import identify_run
from rtctl.estimation.printed import PrintedSageHusa
from rtctl.estimation.sage_husa import EPS, PRED_ERR, RCOV_HAT, R_HAT, first_nonfinite, state_size
from rtctl.telemetry import Recorder


def test_printed_drift_covariance_is_equation_27_on_a_hand_computed_step():
    """p = 1, h = 2, y = 3, θ̂(0) = 0, P(0) = 1, Q̂(0) = 1/2, r̂ = 0, R̂ = 1, only Q̂ adapted; by hand:
    d_0 = 1; P(1|0) = 3/2; ε = 3; s = hPh = 6; K = (3/2)·2/(6 + 1) = 3/7; P(1|1) = (1 − 2K)·3/2 = 3/14;
    (27): Q̂(1) = 0·Q̂(0) + 1·(K²ε² + P(1|1) − P(0|0)) = 81/49 + 3/14 − 1 = 85/98.
    Step 2, h = 1, y = 0: d_1 = (1 − λ)/(1 − λ²) = 1/(1 + λ) with λ = 1/2: 2/3."""
    f = PrintedSageHusa(1, lam=0.5, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.5], adapt=("Q",))
    assert f.update([2.0], 3.0) == pytest.approx(3.0)
    np.testing.assert_allclose(f.theta, [9 / 7], rtol=1e-12)
    np.testing.assert_allclose(f.P, [[3 / 14]], rtol=1e-12)
    np.testing.assert_allclose(f.Q, [[85 / 98]], rtol=1e-12)
    # step 2, in exact fractions from the equations (19)-(23), (27)
    theta, P, Q, R = Fraction(9, 7), Fraction(3, 14), Fraction(85, 98), Fraction(1)
    h, y, d = Fraction(1), Fraction(0), Fraction(2, 3)
    P_pred = P + Q  # (22)
    eps = y - h * theta  # (20), r̂ = 0, q̂ = 0
    K = P_pred * h / (h * P_pred * h + R)  # (21)
    P_new = (1 - K * h) * P_pred  # (23)
    Q_new = (1 - d) * Q + d * (K * K * eps * eps + P_new - P)  # (27)
    assert f.update([1.0], 0.0) == pytest.approx(float(eps), rel=1e-12)
    np.testing.assert_allclose(f.Q, [[float(Q_new)]], rtol=1e-12)


@pytest.mark.parametrize("lam", [0.0, 1.0, 1.5, -0.5])
def test_printed_reference_refuses_a_forgetting_factor_outside_0_1(lam):
    """0 < λ < 1 (the module docstring of sage_husa, which the printed reference follows)."""
    with pytest.raises(ValueError, match="lam"):
        PrintedSageHusa(1, lam=lam, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.0])


def test_printed_reference_takes_a_forgetting_factor_just_inside_0_1():
    for lam in (1e-9, 1.0 - 1e-9):
        assert PrintedSageHusa(1, lam=lam, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.0]).lam == lam


@pytest.mark.parametrize(("na", "nb"), [(1, 1), (2, 2), (3, 1), (1, 4)])
def test_arx_coefficient_names_are_a1_to_a_na_then_b0_to_b_nb(na, nb):
    """θ = [a_1 … a_na, b_0 … b_nb] (eq. 14): one name per coefficient, in that order."""
    order = ArxOrder(na, nb, 1)
    expected = [f"a{j}" for j in range(1, na + 1)] + [f"b{j}" for j in range(0, nb + 1)]
    assert order.names() == expected
    assert len(order.names()) == order.p


def test_gain_never_trusts_y_more_than_1e9_times_the_prediction():
    """The gain uses max(R̂, 10⁻⁹ hᵀPh): with R̂ at a floor of 10⁻¹² ≪ 10⁻⁹·s, one step with
    h = 1, P = 1 (s = 1) leaves P(1|1) = s R_gain/(s + R_gain) = 10⁻⁹/(1 + 10⁻⁹) (module
    docstring), not ≈ 10⁻¹²; θ̂ moves by the fraction s/(s + R_gain) of ε."""
    f = SageHusa(1, 1, lam=0.9, P0=1.0, R0=1e-12, R_min=1e-12, adapt=())
    f.update(0, [1.0], 1.0)
    R_gain = 1e-9 * 1.0
    np.testing.assert_allclose(f.P[0, 0, 0], R_gain / (1.0 + R_gain), rtol=1e-5)
    np.testing.assert_allclose(f.theta[0, 0], 1.0 / (1.0 + R_gain), rtol=1e-12)


def test_filter_options_are_keywords():
    """SageHusa(m, p, *, lam=…, …): m and p by position or by name, every option by name only
    (a positional 0.5 must not silently become λ)."""
    f = SageHusa(m=2, p=3, lam=0.9)
    assert (f.m, f.p, f.lam) == (2, 3, 0.9)
    with pytest.raises(TypeError):
        SageHusa(2, 3, 0.9)


def _recording(path, rows=40, meta=None):
    rng = np.random.default_rng(4)
    rec = Recorder(path, {"t": ((), "f8"), "q": (2, "f8"), "tau": (2, "f8")},
                   {"rate_hz": 100, "joints": ["a", "b"]} if meta is None else meta, wait_when_full=True)
    for k in range(rows):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / 100, rng.normal(size=2), rng.normal(size=2)
        rec.commit()
    rec.close()
    return str(path)


@pytest.mark.parametrize(("joints", "named"), [(["zz"], "zz"), (["a,yy", "zz"], "yy"), (["xx", "b", "ww"], "xx")])
def test_identify_names_the_first_unknown_joint_and_exits_2(tmp_path, capsys, joints, named):
    path = _recording(tmp_path / "run.msgpack")
    assert main(["identify", path, "--joints", *joints]) == 2
    err = capsys.readouterr().err
    assert f"unknown joint {named!r}" in err and "a, b" in err, err


def test_identify_names_unnamed_joints_j1_to_jn(tmp_path):
    """A recording without joint names: j1 … jn, as everywhere else (rtctl.telemetry.channels.joint_names);
    ``joints=["j2"]`` is the second column."""
    path = _recording(tmp_path / "run.msgpack", meta={"rate_hz": 100})
    assert identify_run(path)["joints"] == ["j1", "j2"]
    from rtctl.telemetry import read

    tel = read(path)
    got = identify_run(path, joints=["j2"])
    expected = identify(tel["q"].reshape(tel.rows, 2)[:, 1], tel["tau"].reshape(tel.rows, 2)[:, 1])
    assert got["joints"] == ["j2"]
    np.testing.assert_array_equal(got["theta"], expected["theta"])


@pytest.mark.parametrize(("option", "value"), [("--na", "0"), ("--nb", "0"), ("--d", "0"), ("--period", "0"),
                                               ("--lam", "0"), ("--lam", "1"), ("--p0", "0"), ("--r0", "-1e-300")])
def test_identify_command_refuses_the_boundary_values_naming_the_option(tmp_path, capsys, option, value):
    """Orders from 1, period > 0, 0 < λ < 1, p0 > 0, r0 ≥ 0 (``rtctl identify --help``): the value
    just outside is refused by the command's own check, exit 2 naming the option."""
    path = _recording(tmp_path / "run.msgpack")
    assert main(["identify", path, f"{option}={value}"]) == 2
    err = capsys.readouterr().err
    assert f"<command line>: {option}: " in err, err


@pytest.mark.parametrize(("option", "value"), [("--na", "1"), ("--nb", "1"), ("--d", "1"), ("--period", "0.01"),
                                               ("--lam", "1e-6"), ("--lam", "0.999999"), ("--p0", "1e-6"),
                                               ("--r0", "0")])
def test_identify_command_takes_the_values_just_inside_the_bounds(tmp_path, capsys, option, value):
    path = _recording(tmp_path / "run.msgpack")
    assert main(["identify", path, f"{option}={value}"]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("lam", [0.0, 1.0, -0.5, 1.5])
def test_filter_refuses_a_forgetting_factor_outside_0_1(lam):
    """0 < λ < 1 (module docstring)."""
    with pytest.raises(ValueError, match="lam"):
        SageHusa(1, 2, lam=lam)


@pytest.mark.parametrize(("m", "p"), [(0, 2), (2, 0)])
def test_filter_needs_a_channel_and_a_coefficient(m, p):
    with pytest.raises(ValueError, match="at least one"):
        SageHusa(m, p)


def test_filter_takes_the_values_just_inside_its_bounds():
    f = SageHusa(1, 1, lam=1e-9, R_min=1e-300, P0=0.0, Q0=0.0, R0=0.0, Q_min=0.0)
    assert (f.m, f.p, f.lam, f.R_min) == (1, 1, 1e-9, 1e-300)
    assert SageHusa(1, 1, lam=1.0 - 1e-9).lam == 1.0 - 1e-9


@pytest.mark.parametrize("R_min", [0.0, -1e-12, np.inf, np.nan])
def test_filter_refuses_a_noise_floor_that_is_not_a_finite_positive_number(R_min):
    with pytest.raises(ValueError, match="R_min"):
        SageHusa(1, 2, R_min=R_min)


@pytest.mark.parametrize("name", ["P0", "Q0", "Q_min", "R0"])
@pytest.mark.parametrize("value", [-0.5, -1e-300, -2.0])
def test_filter_refuses_a_negative_variance(name, value):
    with pytest.raises(ValueError, match=name):
        SageHusa(1, 2, **{name: value})


@pytest.mark.parametrize(("h", "y"), [([1.0, 0.5], np.nan), ([1.0, 0.5], np.inf), ([np.nan, 0.5], 1.0),
                                      ([1.0, -np.inf], 1.0)])
def test_update_refuses_a_non_finite_regressor_or_measurement_and_changes_nothing(h, y):
    f = SageHusa(1, 2, adapt=("r", "R", "q", "Q"))
    before = f.state.copy()
    with pytest.raises(ValueError, match="finite"):
        f.update(0, h, y)
    np.testing.assert_array_equal(f.state, before)


@pytest.mark.parametrize("i", [-1, 2])
def test_update_refuses_a_channel_out_of_range(i):
    f = SageHusa(2, 2)
    with pytest.raises(ValueError, match=r"out of range 0\.\.1"):
        f.update(i, [1.0, 0.5], 1.0)
    f.update(1, [1.0, 0.5], 1.0)  # the last channel is in range


def test_a_regressor_without_variance_moves_no_estimate():
    """h = 0: s = hᵀPh = 0, y carries no news about θ, K = 0. By (18), (22), (23), (26), (27) with
    K = 0, q̂(0) = 0, Q̂(0) = 0: θ̂ and P stay, q̂ = (1 − d)·0 + d·(θ̂(1|1) − θ̂(0|0)) = 0 and
    Q̂ = d·(0 + P(1|1) − P(0|0)) = 0; only r̂ (24) learns from y."""
    f = SageHusa(1, 3, lam=0.9, theta0=[0.5, -1.0, 2.0], P0=[1.0, 2.0, 3.0], adapt=("r", "q", "Q"))
    theta0, P0 = f.theta.copy(), f.P.copy()
    for y in (1.0, -2.0, 3.0):
        f.update(0, np.zeros(3), y)
    np.testing.assert_array_equal(f.theta, theta0)
    np.testing.assert_array_equal(f.P, P0)
    np.testing.assert_array_equal(f.q_hat, 0.0)
    np.testing.assert_array_equal(f.Q_hat, 0.0)
    assert f.r_hat[0] != 0.0


def test_the_statistics_weight_follows_d_k_after_lambda_k_underflows():
    """d_k = (1 − λ)/(1 − λ^(k+1)) for every k (module docstring): with λ = 0.01, λ^(k+1) < 1e-200
    after 100 steps and d_k = 1 − λ from then on. Checked on r̂ (24) with h = 0 (so y − hᵀθ̂ = y)."""
    lam = 0.01
    f = SageHusa(1, 1, lam=lam, adapt=("r",))
    rng = np.random.default_rng(2)
    for k in range(160):
        y = float(rng.normal())
        r_before = float(f.r_hat[0])
        f.update(0, [0.0], y)
        d = (1.0 - lam) / (1.0 - lam ** (k + 1))
        assert f.r_hat[0] == pytest.approx((1.0 - d) * r_before + d * y, rel=1e-12, abs=1e-15), k


@pytest.mark.parametrize("y0", [None, 0.5])
def test_simulate_by_hand(y0):
    """ARX(1, 1, 1), θ = [a1, b0, b1] = [0.5, 1, 2], from rest (past y = y0 or 0, past u = 0):
    y(k) = 0.5 y(k−1) + u(k−1) + 2 u(k−2) + w(k)."""
    u, w = [1.0, 0.0, 3.0, 0.0, 2.0], [1.0, 0.0, 0.0, -1.0, 0.0]  # u(4) acts after the end
    yp = 0.0 if y0 is None else y0
    y = []
    for k in range(5):
        prev = y[k - 1] if k >= 1 else yp
        y.append(0.5 * prev + (u[k - 1] if k >= 1 else 0.0) + 2 * (u[k - 2] if k >= 2 else 0.0) + w[k])
    # written out for y0 = None: 1, 0.5 + 1 = 1.5, 0.75 + 0 + 2 = 2.75, 1.375 + 3 + 0 − 1 = 3.375, 1.6875 + 0 + 6
    if y0 is None:
        assert y == [1.0, 1.5, 2.75, 3.375, 7.6875]
    got = simulate(ArxOrder(1, 1, 1), [0.5, 1.0, 2.0], u, w, y0=y0)
    np.testing.assert_allclose(got, y, rtol=1e-15)


def test_simulate_by_hand_two_lags_and_dead_time_two():
    """ARX(2, 1, 2): y(k) = a1 y(k−1) + a2 y(k−2) + b0 u(k−2) + b1 u(k−3) + w(k), past y = y0."""
    a1, a2, b0, b1, y0 = 0.5, -0.25, 1.0, 3.0, 2.0
    u, w = [1.0, 2.0, 0.0, 0.0, 0.0, 5.0], [0.0, 1.0, 0.0, 0.0, 0.0, 0.0]
    y = []
    for k in range(6):
        yk = lambda j: y[k - j] if k - j >= 0 else y0  # noqa: E731
        uk = lambda j: u[k - j] if k - j >= 0 else 0.0  # noqa: E731
        y.append(a1 * yk(1) + a2 * yk(2) + b0 * uk(2) + b1 * uk(3) + w[k])
    got = simulate(ArxOrder(2, 1, 2), [a1, a2, b0, b1], u, w, y0=y0)
    np.testing.assert_allclose(got, y, rtol=1e-15)


@pytest.mark.parametrize(("m", "p"), [(1, 1), (2, 3), (3, 5)])
def test_state_is_exactly_the_documented_views_end_to_end(m, p):
    """θ̂ (p, m), P (m, p, p), drift (3, p, m), signals (4, m), fade (m): views of one contiguous
    ``state`` in that order (module docstring), nothing before, between or after them."""
    sizes = [p * m, m * p * p, 3 * p * m, 4 * m, m]
    assert state_size(m, p) == sum(sizes)
    f = SageHusa(m, p)
    assert f.state.size == sum(sizes)
    views = (f.theta, f.P, f.drift, f.signals, f.fade)
    assert [v.shape for v in views] == [(p, m), (m, p, p), (3, p, m), (4, m), (m,)]
    start = 0
    for v, n in zip(views, sizes):
        assert np.shares_memory(v, f.state) and v.size == n
        assert v.__array_interface__["data"][0] == f.state.__array_interface__["data"][0] + 8 * start
        start += n
    assert start == f.state.size


def test_no_innovation_before_the_first_measurement_nor_after_reset():
    """ε (20) and y − hᵀθ̂(k+1|k) need a measurement: 0 in a new filter and again after reset(),
    which restores every initial value."""
    f = SageHusa(2, 3, r0=[0.1, 0.2], R0=[0.3, 0.4], adapt=("r", "R", "q", "Q"))
    fresh = f.state.copy()
    np.testing.assert_array_equal(f.signals[EPS], 0.0)
    np.testing.assert_array_equal(f.signals[PRED_ERR], 0.0)
    np.testing.assert_array_equal(f.r_hat, [0.1, 0.2])
    np.testing.assert_array_equal(f.R_hat, [0.3, 0.4])
    for i in range(2):
        f.update(i, [1.0, -0.5, 0.25], 2.0)
    assert np.all(f.signals[EPS] != 0.0)
    f.reset()
    np.testing.assert_array_equal(f.state, fresh)
    np.testing.assert_array_equal(f.signals[EPS], 0.0)


@pytest.mark.parametrize(("y_shape", "u_shape"), [((20, 2), (20, 3)), ((20, 2), (19, 2)), ((20, 2), (20,)),
                                                  ((20,), (20, 2)), ((20, 1, 1), (20, 1, 1)), ((1, 2), (1, 2))])
def test_identify_refuses_y_and_u_of_different_shapes_or_fewer_than_2_samples(y_shape, u_shape):
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="same shape"):
        identify(rng.normal(size=y_shape), rng.normal(size=u_shape))


def test_identify_takes_two_samples():
    got = identify([0.0, 1.0], [1.0, 0.0])
    assert got["eps"].shape == (1, 1)


def test_identify_command_refuses_a_recording_with_a_non_finite_position_exit_2(tmp_path, capsys):
    """identify's ValueError ("y and u must be finite") is a refusal of the input, not a bug: exit 2
    with the reason (the CLI's exit codes), not a traceback."""
    path = tmp_path / "run.msgpack"
    rec = Recorder(path, {"t": ((), "f8"), "q": (1, "f8"), "tau": (1, "f8")}, {"rate_hz": 100, "joints": ["a"]},
                   wait_when_full=True)
    for k in range(10):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / 100, np.nan if k == 5 else 0.1 * k, 1.0
        rec.commit()
    rec.close()
    assert main(["identify", str(path)]) == 2
    assert "finite" in capsys.readouterr().err


@pytest.mark.parametrize("bad", ["y", "u"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_identify_refuses_a_non_finite_y_or_u(bad, value):
    y, u = np.linspace(0.0, 1.0, 10), np.ones(10)
    (y if bad == "y" else u)[4] = value
    with pytest.raises(ValueError, match="finite"):
        identify(y, u)


def test_identify_run_reads_every_recorded_tick_without_a_period(tmp_path):
    """Default: every recorded tick (identify_run's docstring), the fit of all rows."""
    path = _recording(tmp_path / "run.msgpack", rows=30)
    from rtctl.telemetry import read

    tel = read(path)
    got = identify_run(path)
    assert got["samples"] == got["rows"] == 30 and got["period"] == pytest.approx(0.01)
    expected = identify(tel["q"].reshape(30, 2), tel["tau"].reshape(30, 2))
    np.testing.assert_array_equal(got["theta"], expected["theta"])


def test_identify_run_refuses_a_period_that_leaves_one_sample(tmp_path):
    """40 rows at 100 Hz every 0.5 s (50 rows): one sample, at least 2 needed."""
    path = _recording(tmp_path / "run.msgpack", rows=40)
    with pytest.raises(RtctlError, match="at least 2 needed"):
        identify_run(path, period=0.5)


@pytest.mark.parametrize("missing", ["q", "tau"])
def test_identify_command_names_a_missing_column_exit_2(tmp_path, capsys, missing):
    schema = {"t": ((), "f8"), "q": (1, "f8"), "tau": (1, "f8")}
    del schema[missing]
    rec = Recorder(tmp_path / "run.msgpack", schema, {"rate_hz": 100, "joints": ["a"]}, wait_when_full=True)
    for k in range(5):
        for col in schema:
            rec.row[col][...] = k
        rec.commit()
    rec.close()
    assert main(["identify", str(tmp_path / "run.msgpack")]) == 2
    assert f"no column {missing!r}" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["theta0", "P0", "q0", "Q0", "Q_min", "r0", "R0"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_filter_refuses_non_finite_initial_values(name, value):
    with pytest.raises(ValueError, match=f"{name} must be finite"):
        SageHusa(1, 2, **{name: value})


@pytest.mark.parametrize("name", ["na", "nb", "d"])
def test_arx_order_refuses_zero(name):
    """Orders from 1 (docs/arma_kalman.md; d ≥ 1 the dead time)."""
    with pytest.raises(ValueError, match=name):
        ArxOrder(**{name: 0})


def test_filter_defaults_are_the_documented_ones():
    """The signature's defaults (the API reference): λ = 0.98, θ̂(0) = 0, P(0) = I, r̂(0) = 0,
    R̂(0) = 10⁻⁶ (also ``rtctl identify --r0``'s), q̂(0) = Q̂(0) = 0, r̂ and R̂ adapted, R_min = 10⁻¹²,
    the Sage–Husa noise form."""
    f = SageHusa(2, 3)
    assert f.lam == 0.98 and f.R_min == 1e-12 and f.noise_form == "sage_husa"
    np.testing.assert_array_equal(f.theta, 0.0)
    np.testing.assert_array_equal(f.P, np.broadcast_to(np.eye(3), (2, 3, 3)))
    np.testing.assert_array_equal(f.r_hat, 0.0)
    np.testing.assert_array_equal(f.R_hat, 1e-6)
    np.testing.assert_array_equal(f.q_hat, 0.0)
    np.testing.assert_array_equal(f.Q_hat, 0.0)
    np.testing.assert_array_equal(f.Q_min, 0.0)
    assert f.switches[:4].astype(bool).tolist() == [True, True, False, False]  # r̂, R̂ on; q̂, Q̂ off


def test_no_news_along_h_when_s_is_exactly_zero_even_if_Ph_is_not():
    """s = hᵀP(k+1|k)h ≤ 0: "y carries no news about θ" (sage_husa_step): K = 0, θ̂ and P stay.
    P = [[1, 1], [1, 0]] (numerically indefinite, as rounding can leave it), h = (0, 1): s = 0
    while Ph = (1, 0)."""
    f = SageHusa(1, 2, R0=0.5, adapt=())
    f.P[0] = [[1.0, 1.0], [1.0, 0.0]]
    P_before = f.P.copy()
    f.update(0, [0.0, 1.0], 3.0)
    np.testing.assert_array_equal(f.theta, 0.0)
    np.testing.assert_array_equal(f.P, P_before)


@pytest.mark.parametrize("noise_form", ["sage_husa", "residual"])
def test_R_sample_is_eps_squared_exactly_when_s_is_zero(noise_form):
    """h = 0 (s = 0, K = 0): (25) ε² − 0 and (25′) (y − hᵀθ̂(1|1) − r̂)² + 0 are both ε²; with
    d_0 = 1, R̂(1) = ε² = 1 for y = 1, r̂ = 0 — exactly (R̂(0) = 49: 49·(1/49) ≠ 1 in floating point,
    so a detour through the gain shows)."""
    f = SageHusa(1, 2, R0=49.0, adapt=("R",), noise_form=noise_form)
    f.update(0, [0.0, 0.0], 1.0)
    assert f.R_hat[0] == 1.0


def test_printed_reference_options_are_keywords():
    f = PrintedSageHusa(p=1, lam=0.5, theta0=[0.0], P0=[1.0], r0=0.0, R0=1.0, Q0=[0.0])
    assert f.lam == 0.5
    with pytest.raises(TypeError):
        PrintedSageHusa(1, 0.5, [0.0], [1.0], 0.0, 1.0, [0.0])


def test_identify_command_says_how_many_samples_of_how_many_rows(tmp_path, capsys):
    """40 rows at 100 Hz, --period 0.02: every 2nd row, 20 samples (docs/operations.md: identify
    says how many rows it read)."""
    path = _recording(tmp_path / "run.msgpack", rows=40)
    assert main(["identify", path, "--period", "0.02"]) == 0
    out = capsys.readouterr().out
    assert "sample time 0.02 s; 20 samples of 40 recorded rows" in out, out


def test_first_nonfinite_flags_finite_statistics_whose_sum_overflows():
    """"finite values whose sum overflowed (≈ 1e308: diverged all the same)": r̂ = R̂ = 1e308."""
    f = SageHusa(1, 2)
    f.signals[R_HAT, 0] = f.signals[RCOV_HAT, 0] = 1e308
    assert first_nonfinite(0, f.theta, f.P, f.q_hat, f.Q_hat, f.signals) >= 0


def test_identify_first_sample_only_fills_the_histories():
    """identify's docstring: histories start from y(0) and u = 0, the first sample only fills them.
    ARX(1, 1, 1), N = 2: one filter step, h(1) = [y(0), u(0), u(−1) = 0], measurement y(1); from
    θ̂(0) = 0, r̂(0) = 0 the innovation is ε = y(1)."""
    y, u = [0.5, 2.0], [3.0, -1.0]
    got = identify(y, u, ArxOrder(1, 1, 1))
    assert got["eps"].tolist() == [[2.0]] and got["prediction_error"].tolist() == [[2.0]]
    f = SageHusa(1, 3, theta0=0.0, P0=1e3)
    f.update(0, [0.5, 3.0, 0.0], 2.0)
    np.testing.assert_array_equal(got["theta"], f.theta.T)
