"""Non-finite output or a raising controller → the fallback command in the same tick."""
import math

import numpy as np
import pytest

from safety_rig import TAU_MAX, Rig
from rtctl.hal.joints import CommandMode
from rtctl.safety import FaultKind, Verdict


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nonfinite_torque_engages_hold_in_the_same_tick(rig, bad):
    rig.state.position[:] = [0.1, 0.2, 0.3]
    assert rig.step() == Verdict.OK
    rig.state.position[:] = [0.12, 0.2, 0.3]
    rig.state.velocity[:] = [1.0, 0.0, -0.5]
    rig.command.tau_ff[:] = [1.0, bad, 1.0]
    assert rig.step() == Verdict.FALLBACK
    (f,) = rig.stage.faults
    assert f.kind == FaultKind.NONFINITE_COMMAND and f.joint == 1 and f.tick == 1
    # held where it was at the fault (this tick's measurement), with damping
    np.testing.assert_allclose(rig.command.tau_ff, [-4.0, 0.0, 2.0])
    assert np.all(np.isfinite(rig.command.tau_ff))


def test_controller_exception_engages_fallback_with_reason(rig):
    rig.command.tau_ff[:] = 3.0  # whatever the controller left half-written
    assert rig.step(controller_ok=False, error="ct: ZeroDivisionError: boom") == Verdict.FALLBACK
    (f,) = rig.stage.faults
    assert f.kind == FaultKind.CONTROLLER and f.joint == -1 and "boom" in f.reason
    np.testing.assert_allclose(rig.command.tau_ff, 0.0)  # at rest at the held position
    assert rig.step() == Verdict.FALLBACK  # latched though the controller recovered


def test_a_raising_controller_is_one_fault_whatever_it_left_in_the_command(rig):
    rig.command.tau_ff[:] = [math.nan, 1e9, 0.0]  # half-written: not checked, not counted, replaced
    assert rig.step(controller_ok=False, error="ct: boom") == Verdict.FALLBACK
    assert [f.kind for f in rig.stage.faults] == [FaultKind.CONTROLLER]
    assert rig.stage.summary()["clamps"]["torque"] == [0, 0, 0]
    rig.command.tau_ff[:] = 1e9  # while the fallback is in charge the controller's output is not bounded
    assert rig.step() == Verdict.FALLBACK
    assert rig.stage.summary()["clamps"]["torque"] == [0, 0, 0]


def test_damp_fallback_is_pure_damping():
    r = Rig(fallback="damp", damping=3.0)
    r.state.velocity[:] = [1.0, -2.0, 0.5]
    r.state.position[:] = [0.5, 0.5, 0.5]
    r.command.tau_ff[0] = math.nan
    assert r.step() == Verdict.FALLBACK
    np.testing.assert_allclose(r.command.tau_ff, [-3.0, 6.0, -1.5])


def test_hold_adds_gravity_at_the_held_position():
    calls = []

    def gravity(q):
        calls.append(q.copy())
        return np.array([1.0, -2.0, 0.5]) + q

    r = Rig(gravity=gravity, hold_stiffness=10.0, damping=1.0)
    r.state.position[:] = [0.1, 0.2, 0.3]
    r.step(controller_ok=False)
    for _ in range(5):
        r.state.position[:] += 0.01
        assert r.step() == Verdict.FALLBACK
    assert len(calls) == 1  # once, at the fault
    g = np.array([1.1, -1.8, 0.8])
    np.testing.assert_allclose(r.command.tau_ff, 10.0 * (-0.05) + g)


def test_fallback_torque_is_clamped_and_survives_a_nonfinite_state():
    r = Rig(hold_stiffness=1000.0, damping=1.0)
    r.state.position[:] = [0.0, 0.0, 0.0]
    r.step(controller_ok=False)
    r.state.position[:] = [0.5, math.nan, 0.0]
    r.state.velocity[:] = [0.0, 2.0, math.nan]
    assert r.step() == Verdict.FALLBACK
    # joint 0 saturates, joint 1 (no position) is damped, joint 2 (no velocity) gets nothing
    np.testing.assert_allclose(r.command.tau_ff, [-TAU_MAX[0], -2.0, 0.0])
    assert any(f.kind == FaultKind.NONFINITE_STATE for f in r.stage.faults)


def test_impedance_fallback_is_closed_by_the_drive():
    r = Rig(hold_stiffness=30.0, damping=2.0)
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    r.state.position[:] = [0.1, 0.2, 0.3]
    c.kp[:] = 50.0
    c.kp[2] = math.nan
    assert r.step() == Verdict.FALLBACK
    np.testing.assert_allclose(c.q_des, [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(c.qd_des, 0.0)
    np.testing.assert_array_equal(c.kp, 30.0)
    np.testing.assert_array_equal(c.kd, 2.0)
    np.testing.assert_array_equal(c.tau_ff, 0.0)
    r.stage.estop()  # category 1: damping only
    r.state.velocity[:] = 1.0
    assert r.step() == Verdict.FALLBACK
    np.testing.assert_array_equal(c.kp, 0.0)
    np.testing.assert_array_equal(c.kd, 2.0)


@pytest.mark.parametrize("joint", range(3))
@pytest.mark.parametrize("mode, field", [(CommandMode.TORQUE, "tau_ff")] + [
    (CommandMode.IMPEDANCE, f) for f in ("tau_ff", "q_des", "qd_des", "kp", "kd")])
def test_a_nonfinite_command_on_any_joint_is_caught_and_names_that_joint(joint, mode, field):
    r = Rig()
    r.command.mode = mode
    getattr(r.command, field)[joint] = math.nan
    assert r.step() == Verdict.FALLBACK
    (f,) = r.stage.faults
    assert f.kind == FaultKind.NONFINITE_COMMAND and f.joint == joint


def test_a_nonfinite_command_on_several_joints_is_one_fault_naming_the_first():
    r = Rig()
    r.command.tau_ff[1:] = [math.inf, math.nan]
    assert r.step() == Verdict.FALLBACK
    assert [(f.kind, f.joint, f.value) for f in r.stage.faults] == [(FaultKind.NONFINITE_COMMAND, 1, math.inf)]


@pytest.mark.parametrize("joint", range(3))
@pytest.mark.parametrize("field", ["position", "velocity"])
def test_a_nonfinite_measurement_on_any_joint_is_caught_and_names_that_joint(joint, field):
    r = Rig()
    getattr(r.state, field)[joint] = math.inf
    assert r.step() == Verdict.FALLBACK
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.NONFINITE_STATE, joint)]
    assert np.all(np.isfinite(r.command.tau_ff))


def test_the_damped_fallback_in_impedance_mode_carries_the_clamped_weight():
    weight = np.array([-30.0, 5.0, 1.0])  # joint 0 beyond its 10 N·m limit
    r = Rig(fallback="damp", damping=3.0, gravity=lambda q: weight)
    r.command.mode = CommandMode.IMPEDANCE
    r.state.position[:] = [0.2, 0.3, 0.4]
    r.command.tau_ff[1] = math.nan
    assert r.step() == Verdict.FALLBACK
    c = r.command
    np.testing.assert_array_equal(c.kp, 0.0)
    np.testing.assert_array_equal(c.kd, 3.0)
    np.testing.assert_array_equal(c.qd_des, 0.0)
    np.testing.assert_array_equal(c.q_des, [0.2, 0.3, 0.4])
    np.testing.assert_array_equal(c.tau_ff, [-10.0, 5.0, 1.0])


def test_the_off_command_is_zero_in_both_modes():
    from rtctl.safety import kernels as k

    lim = k_limits()
    fb = np.zeros((k.N_FALLBACK_ROWS, 3))
    fb[[k.HOLD_KP, k.HOLD_KD, k.DAMP_KD]] = 7.0
    fb[k.TAU_HOLD] = [1.0, -2.0, 3.0]
    for mode in (k.TORQUE, k.IMPEDANCE):
        q, qd = np.array([0.1, 0.2, 0.3]), np.array([1.0, -1.0, 0.5])
        q_des, qd_des, kp, kd, tau = (np.full(3, 9.0) for _ in range(5))
        k.fallback(mode, k.FB_OFF, q, qd, q_des, qd_des, kp, kd, tau, lim, fb)
        for name, a in zip(("qd_des", "kp", "kd", "tau_ff"), (qd_des, kp, kd, tau)):
            np.testing.assert_array_equal(a, 0.0, err_msg=f"mode {mode}: {name}")


def k_limits():
    from rtctl.safety.limits import limits_table
    from safety_rig import Q_MAX, Q_MIN, V_MAX

    return limits_table(Q_MIN, Q_MAX, V_MAX, TAU_MAX)


def test_a_torque_mode_fallback_writes_a_clean_command():
    r = Rig(hold_stiffness=100.0, damping=4.0)
    r.command.kp[:], r.command.kd[:], r.command.q_des[:] = 50.0, 5.0, 1.0  # stale impedance fields
    r.command.tau_ff[0] = math.inf
    assert r.step() == Verdict.FALLBACK
    for name in ("q_des", "qd_des", "kp", "kd"):
        np.testing.assert_array_equal(getattr(r.command, name), 0.0, err_msg=name)
