"""Position, velocity and torque limits, in torque and impedance mode."""
import numpy as np
import pytest

from safety_rig import Q_MAX, Q_MIN, TAU_MAX, V_MAX, Rig
from rtctl.hal.joints import CommandMode
from rtctl.safety import FaultKind, Verdict
from rtctl.safety.limits import limits_table


def test_torque_is_clamped_and_counted(rig):
    rig.command.tau_ff[:] = [15.0, -25.0, 1.0]
    assert rig.step() == Verdict.OK
    np.testing.assert_array_equal(rig.command.tau_ff, [10.0, -20.0, 1.0])
    assert rig.stage.summary()["clamps"]["torque"] == [1, 1, 0]
    assert not rig.stage.faults


def test_soft_limit_zeroes_only_outward_torque(rig):
    rig.state.position[:] = [0.95, -1.95, 2.85]  # inside the 0.1 margin of the upper, lower, upper limit
    rig.command.tau_ff[:] = [3.0, -3.0, -2.0]  # out, out, back in
    assert rig.step() == Verdict.OK
    np.testing.assert_array_equal(rig.command.tau_ff, [0.0, 0.0, -2.0])
    assert rig.stage.summary()["clamps"]["position"] == [1, 1, 0]
    rig.state.position[:] = 0.85  # outside the margin: untouched
    rig.command.tau_ff[:] = [3.0, -3.0, -2.0]
    assert rig.step() == Verdict.OK
    np.testing.assert_array_equal(rig.command.tau_ff, [3.0, -3.0, -2.0])


def test_past_hard_limit_faults_and_holds_there(rig):
    rig.state.position[:] = [0.0, 2.05, 0.0]
    rig.command.tau_ff[:] = 1.0
    assert rig.step() == Verdict.FALLBACK
    (f,) = rig.stage.faults
    assert (f.kind, f.joint, f.value, f.tick) == (FaultKind.POSITION, 1, 2.05, 0)
    # hold: τ = K (q_hold − q) − D q̇ with the gains of the rig
    rig.state.position[:] = [0.01, 2.0, -0.02]
    rig.state.velocity[:] = [0.5, -0.1, 0.0]
    assert rig.step() == Verdict.FALLBACK
    expected = 100.0 * (np.array([0.0, 2.05, 0.0]) - rig.state.position) - 4.0 * rig.state.velocity
    np.testing.assert_allclose(rig.command.tau_ff, np.clip(expected, -TAU_MAX, TAU_MAX))


@pytest.mark.parametrize("v, verdict", [(2.0, Verdict.OK), (-2.0001, Verdict.FALLBACK)])
def test_velocity_over_limit_faults(rig, v, verdict):
    rig.state.velocity[0] = v
    assert rig.step() == verdict
    if verdict == Verdict.FALLBACK:
        assert rig.stage.faults[0].kind == FaultKind.VELOCITY and rig.stage.faults[0].value == v


def test_velocity_factor_scales_the_limit():
    r = Rig(velocity_factor=1.5)
    r.state.velocity[0] = 2.9
    assert r.step() == Verdict.OK
    r.state.velocity[0] = 3.1
    assert r.step() == Verdict.FALLBACK


def test_impedance_command_is_bounded():
    r = Rig(position_margin=0.1, kp_max=200.0, kd_max=5.0)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    r.state.position[:] = [0.5, 0.0, 2.95]
    r.state.velocity[:] = [0.0, 1.0, 0.0]
    c.kp[:] = [500.0, -1.0, 10.0]
    c.kd[:] = [1.0, 9.0, 0.0]
    c.q_des[:] = [0.95, 0.0, 3.5]
    c.qd_des[:] = [0.0, 7.0, 0.0]
    c.tau_ff[:] = [0.0, 0.0, 4.0]
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(c.kp, [200.0, 0.0, 10.0])
    np.testing.assert_array_equal(c.kd, [1.0, 5.0, 0.0])
    np.testing.assert_allclose(c.q_des, [0.9, 0.0, 2.9])  # inside the soft limits
    np.testing.assert_array_equal(c.qd_des, [0.0, 2.0, 0.0])
    tau = c.kp * (c.q_des - r.state.position) + c.kd * (c.qd_des - r.state.velocity) + c.tau_ff
    # joint 0: spring 200·0.4 = 80 → cut to 10; joint 1: 5·(2 − 1) = 5 passes;
    # joint 2 is past its soft limit: the spring pulls in (−0.5) but τ_ff = 4 would push out → τ = 0
    np.testing.assert_allclose(tau, [10.0, 5.0, 0.0], atol=1e-12)
    assert r.stage.summary()["clamps"] == {"torque": [1, 0, 0], "position": [0, 0, 1], "impedance": [1, 1, 1]}


def test_limits_table_refuses_nonsense():
    with pytest.raises(ValueError):
        limits_table(Q_MAX, Q_MIN, V_MAX, TAU_MAX)
    with pytest.raises(ValueError):
        limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, position_margin=1.5)
    with pytest.raises(ValueError):
        limits_table(Q_MIN, Q_MAX, -V_MAX, TAU_MAX)
    with pytest.raises(ValueError):
        limits_table(Q_MIN, Q_MAX[:2], V_MAX, TAU_MAX)
    with pytest.raises(ValueError):
        limits_table(Q_MIN, Q_MAX, V_MAX, np.array([10.0, 0.0, 5.0]))  # no torque on a joint
    with pytest.raises(ValueError):
        limits_table(Q_MIN, np.array([1.0, -2.0, 3.0]), V_MAX, TAU_MAX)  # a joint without range
    for gains in ({"kp_max": -1e-3}, {"kd_max": -1e-3}):
        with pytest.raises(ValueError):
            limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, **gains)
    limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, kp_max=0.0, kd_max=0.0)  # torque mode only: no gains at all
    limits_table(Q_MIN, Q_MAX, np.full(3, 0.5), np.full(3, 0.5))  # slow, weak joints: any positive limit
    limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, kp_max=0.5, kd_max=0.5)
    half = (Q_MAX - Q_MIN) / 2  # the soft limits may meet, not cross
    limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, position_margin=half)
    with pytest.raises(ValueError):
        limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, position_margin=np.nextafter(half, np.inf))
    for factor in (0.0, -1.0):
        with pytest.raises(ValueError):
            limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, velocity_factor=factor)
    for margin in (-1e-3, [0.0, -0.5, 0.0]):  # soft limits outside the hard ones
        with pytest.raises(ValueError, match="position_margin"):
            limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX, position_margin=margin)


def test_the_hard_limits_are_inclusive_and_a_reset_exactly_there_clears():
    r = Rig()
    r.state.position[:] = [Q_MAX[0], Q_MIN[1], 0.0]  # exactly on a limit: allowed
    assert r.step() == Verdict.OK
    r.state.position[:] = [Q_MAX[0] + 1e-9, 0.0, Q_MIN[2] - 1e-9]
    assert r.step() == Verdict.FALLBACK
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.POSITION, 0), (FaultKind.POSITION, 2)]
    r.state.position[:] = [Q_MAX[0], 0.0, Q_MIN[2]]  # back exactly on the limits: the cause is gone
    assert r.stage.reset()


def test_a_velocity_fault_clears_at_exactly_the_limit():
    r = Rig()
    r.state.velocity[2] = -V_MAX[2] - 0.5
    assert r.step() == Verdict.FALLBACK
    r.state.velocity[2] = -V_MAX[2]
    assert r.stage.reset()


def test_impedance_fields_are_clamped_into_range_and_counted_only_when_clamped():
    r = Rig(kp_max=500.0, kd_max=20.0, position_margin=0.1)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    c.q_des[:], c.qd_des[:], c.kp[:], c.kd[:] = [0.5, -1.0, 2.0], [0.1, -0.2, 1.0], [100.0, 50.0, 10.0], [2.0, 1.0, 3.0]
    assert r.step() == Verdict.OK  # everything in range: untouched, not counted
    np.testing.assert_array_equal(c.kp, [100.0, 50.0, 10.0])
    np.testing.assert_array_equal(c.kd, [2.0, 1.0, 3.0])
    assert r.stage.summary()["clamps"]["impedance"] == [0, 0, 0]
    c.kp[:], c.kd[:] = [-5.0, 900.0, 10.0], [-1.0, 2.0, 25.0]
    c.q_des[:] = [-0.95, -1.95, 2.95]  # joint 0 below the soft limit -0.9 … joint 2 above 2.9
    c.qd_des[:] = [0.1, -9.0, 1.0]
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(c.kp, [0.0, 500.0, 10.0])
    np.testing.assert_array_equal(c.kd, [0.0, 2.0, 20.0])
    np.testing.assert_allclose(c.q_des, [-0.9, -1.9, 2.9])
    np.testing.assert_allclose(c.qd_des, [0.1, -V_MAX[1], 1.0])
    assert r.stage.summary()["clamps"]["impedance"] == [1, 1, 1]
    # one field out of range at a time is counted too (a mutation run found kp alone uncounted)
    for field, joint, value, clamps in (("kp", 0, 600.0, [2, 1, 1]), ("kd", 1, 30.0, [2, 2, 1]),
                                        ("q_des", 2, 3.5, [2, 2, 2]), ("qd_des", 0, 9.0, [3, 2, 2])):
        c.q_des[:], c.qd_des[:], c.kp[:], c.kd[:] = [0.5, -1.0, 2.0], [0.1, -0.2, 1.0], [100.0, 50.0, 10.0], [2.0, 1.0, 3.0]
        getattr(c, field)[joint] = value
        assert r.step() == Verdict.OK
        assert r.stage.summary()["clamps"]["impedance"] == clamps, field


def test_the_impedance_torque_predicted_at_a_soft_limit_includes_the_damper():
    r = Rig(position_margin=0.1)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    r.state.position[:] = [0.95, 0.0, 0.0]  # past joint 0's soft limit at 0.9
    r.state.velocity[:] = [-1.0, 0.0, 0.0]
    c.q_des[:], c.kp[:] = [0.9, 0.0, 0.0], 0.0
    c.kd[:], c.qd_des[:] = [3.0, 0.0, 0.0], 0.0  # the damper alone pushes outward: 3 (0 − (−1)) = +3
    assert r.step() == Verdict.OK
    assert c.tau_ff[0] == pytest.approx(-3.0)  # shifted so that the drive's total is zero


def test_past_a_soft_limit_an_inward_torque_of_any_size_is_kept():
    r = Rig(position_margin=0.1)
    r.state.position[:] = [0.95, -1.95, 0.0]
    r.command.tau_ff[:] = [-0.5, 0.25, 0.0]  # small, inward
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, [-0.5, 0.25, 0.0])


@pytest.mark.parametrize("tau", [0.5, 1e-3])
def test_past_a_soft_limit_an_outward_torque_of_any_size_is_zeroed(tau):
    """The counterpart of the test above: however small, a push further out is zeroed (a dead
    band such as |τ| < 1 N·m would let a slow push creep through the limit)."""
    r = Rig(position_margin=0.1)
    r.state.position[:] = [0.95, -1.95, 0.0]  # inside the margin of the upper and the lower limit
    r.command.tau_ff[:] = [tau, -tau, tau]  # out, out, free
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, [0.0, 0.0, tau])
    assert r.stage.summary()["clamps"]["position"] == [1, 1, 0]


def test_at_exactly_the_soft_limit_the_torque_is_kept_and_just_past_it_zeroed():
    """"Past" the soft limit is strictly beyond it, at both ends (the clamp starts one ulp out)."""
    from rtctl.safety.kernels import SOFT_HI, SOFT_LO

    r = Rig(position_margin=0.1)
    hi, lo = r.stage.lim[SOFT_HI], r.stage.lim[SOFT_LO]
    r.state.position[:] = [hi[0], lo[1], hi[2]]
    r.command.tau_ff[:] = [3.0, -3.0, 2.0]  # all outward
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, [3.0, -3.0, 2.0])
    r.state.position[:] = [np.nextafter(hi[0], np.inf), np.nextafter(lo[1], -np.inf), np.nextafter(hi[2], np.inf)]
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, 0.0)


def test_an_impedance_target_exactly_at_the_soft_limit_is_not_a_clamp():
    from rtctl.safety.kernels import SOFT_HI, SOFT_LO

    r = Rig(position_margin=0.1)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    c.q_des[:] = [r.stage.lim[SOFT_HI, 0], r.stage.lim[SOFT_LO, 1], 0.0]
    target = c.q_des.copy()
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(c.q_des, target)
    assert r.stage.summary()["clamps"]["impedance"] == [0, 0, 0]


def test_without_a_margin_the_soft_limits_are_the_hard_ones():
    r = Rig()
    r.state.position[:] = [0.95, -1.95, 2.5]
    r.command.tau_ff[:] = [3.0, -3.0, 2.0]  # outward, within the joint limits
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, [3.0, -3.0, 2.0])


def test_small_impedance_gains_pass_unclamped():
    r = Rig(kp_max=200.0, kd_max=5.0)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    c.kp[:] = [0.5, 0.0, 1e-3]
    c.kd[:] = [0.5, 1e-3, 0.0]
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(c.kp, [0.5, 0.0, 1e-3])
    np.testing.assert_array_equal(c.kd, [0.5, 1e-3, 0.0])
    assert r.stage.summary()["clamps"]["impedance"] == [0, 0, 0]


def test_impedance_gains_and_velocities_exactly_at_their_limits_pass_unclamped():
    r = Rig(kp_max=200.0, kd_max=5.0)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    c.kp[:], c.kd[:] = [200.0, 1.0, 200.0], [5.0, 5.0, 1.0]
    c.qd_des[:] = [V_MAX[0], -V_MAX[1], 0.0]  # and target velocities exactly at theirs
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(c.kp, [200.0, 1.0, 200.0])
    np.testing.assert_array_equal(c.kd, [5.0, 5.0, 1.0])
    np.testing.assert_array_equal(c.qd_des, [V_MAX[0], -V_MAX[1], 0.0])
    assert r.stage.summary()["clamps"]["impedance"] == [0, 0, 0]


@pytest.mark.parametrize("option", [{"hold_stiffness": -1e-3}, {"damping": -1e-3},
                                    {"hold_stiffness": [50.0, -1.0, 50.0]}])
def test_negative_fallback_gains_are_refused(option):
    with pytest.raises(ValueError, match="hold_stiffness and damping"):
        Rig(**option)


def test_zero_fallback_gains_are_accepted():
    Rig(hold_stiffness=0.0, damping=0.0)


@pytest.mark.parametrize("option", [{"stale_ticks": 0}, {"following_ticks": 0}, {"estop_off_delay": -1e-3},
                                    {"fault_off_delay": -1e-3}, {"stop_velocity": -1e-3}])
def test_settings_just_beyond_their_bounds_are_refused(option):
    with pytest.raises(ValueError, match="stale_ticks >= 1, following_ticks >= 1 and non-negative"):
        Rig(**option)


def test_settings_at_their_bounds_are_accepted():
    Rig(stale_ticks=1, estop_off_delay=0.0, fault_off_delay=0.0, stop_velocity=0.0)


def test_a_zero_velocity_limit_is_refused_and_the_default_factor_is_one():
    with pytest.raises(ValueError):
        limits_table(Q_MIN, Q_MAX, np.array([2.0, 0.0, 4.0]), TAU_MAX)
    lim = limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX)
    np.testing.assert_array_equal(lim[4], V_MAX)  # the velocity row (V_LIM): the robot's limits as they are
    from rtctl.safety.kernels import SOFT_HI, SOFT_LO

    np.testing.assert_array_equal(lim[SOFT_LO], Q_MIN)  # and no margin: the soft limits are the hard ones
    np.testing.assert_array_equal(lim[SOFT_HI], Q_MAX)


def test_a_stage_built_in_code_has_a_runs_defaults_but_holds_until_reset():
    """A stage without settings behaves as a run without a [safety] table, except that it
    holds after a fault until a reset (fault_off_delay = inf) where a run switches off after 1 s."""
    from types import SimpleNamespace

    from rtctl.config import SafetyConfig
    from rtctl.safety import SafetyStage

    robot = SimpleNamespace(q_min=Q_MIN, q_max=Q_MAX, v_max=V_MAX, tau_max=TAU_MAX)
    bare, run = Rig().stage, SafetyStage.from_model(robot, SafetyConfig())
    np.testing.assert_array_equal(bare.lim, run.lim)
    np.testing.assert_array_equal(bare.fb, run.fb)  # hold stiffness and damping
    assert (bare.fallback_kind, bare.stale_ticks, bare.estop_off_delay, bare.stop_velocity) == (
        run.fallback_kind, run.stale_ticks, run.estop_off_delay, run.stop_velocity)
    assert (bare.fault_off_delay, run.fault_off_delay) == (np.inf, 1.0)


def test_a_torque_exactly_at_its_limit_passes_and_is_not_counted_as_a_clamp():
    r = Rig()
    r.command.tau_ff[:] = [TAU_MAX[0], -TAU_MAX[1], 0.0]
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, [TAU_MAX[0], -TAU_MAX[1], 0.0])
    assert r.stage.summary()["clamps"]["torque"] == [0, 0, 0]


def test_no_torque_past_a_soft_limit_is_not_counted_as_a_clamp():
    r = Rig(position_margin=0.1)
    r.state.position[:] = [0.95, -1.95, 2.95]  # past the upper, lower, upper soft limit
    r.command.tau_ff[:] = [0.0, -0.0, 0.0]
    assert r.step() == Verdict.OK
    assert r.stage.summary()["clamps"]["position"] == [0, 0, 0]
