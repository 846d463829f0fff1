"""What a fault record says, checked against what the stage promises (every fault names its
device or joint and the cause; docs/operations.md for the defaults) — the survivors of the full
safety mutation run with a kernel cache per mutant (issue 27, 2026-12-04)."""
import numpy as np
import pytest

from rtctl.hal.joints import JointCommand, JointState, Status
from rtctl.safety import SafetyStage
from rtctl.safety.faults import FaultKind, device_reason
from rtctl.safety.limits import limits_table
from safety_rig import N, Q_MAX, Q_MIN, TAU_MAX, V_MAX, Rig


class Device:
    """A device as the stage sees one: a name, the driver's causes (a callable, or an exception
    to raise)."""

    def __init__(self, name, fault=None, stale=None):
        self.name, self._fault = name, fault
        if stale is not None:
            self.stale_cause = lambda: _answer(stale)

    def fault_cause(self):
        return _answer(self._fault)


def _answer(value):
    if isinstance(value, Exception):
        raise value
    return value


@pytest.mark.parametrize("status, says", [(Status.DEACTIVATE, "stopped itself"), (Status.ERROR, "failed")])
def test_a_device_fault_says_whether_the_device_stopped_itself_or_failed(status, says):
    assert device_reason(Device("arm", fault="bus can0: no ACK"), int(status)) == f"device arm {says}: bus can0: no ACK"


def test_a_driver_that_cannot_say_why_still_gives_a_reason_naming_the_device():
    reason = device_reason(Device("arm", fault=RuntimeError("driver bug")), int(Status.ERROR))
    assert reason == "device arm failed: (its cause could not be read: RuntimeError: driver bug)"


def stale_rig(device):
    stage = SafetyStage(Q_MIN, Q_MAX, V_MAX, TAU_MAX, stale_ticks=2, devices=[device])
    state, command = JointState(N), JointCommand(N)
    state.fresh[:] = [True, False, True]  # joint 1's data stops arriving
    for tick in range(2):
        stage.check(tick * 0.001, tick, state, None, command)
    (fault,) = stage.faults
    assert fault.kind == FaultKind.STALE and fault.joint == 1
    return fault.reason


@pytest.mark.parametrize("device, tail", [
    (Device("arm", stale="no TPDO from node 0x2"), "for 2 ticks (no TPDO from node 0x2)"),
    (Device("arm", stale=None), "for 2 ticks"),  # no cause known: nothing in parentheses
    (Device("arm"), "for 2 ticks"),  # a driver without stale_cause
    (Device("arm", stale=OSError("gone")), "for 2 ticks (its cause could not be read: OSError: gone)"),
])
def test_a_stale_joint_names_the_drivers_cause_when_it_has_one(device, tail):
    reason = stale_rig(device)
    assert reason == f"joint 1 of device arm: no fresh data {tail}"


def test_a_following_fault_records_the_error_as_reference_minus_position():
    """docs/operations.md: the error is the reference less the measured position; its value and
    its reason carry it with its sign."""
    rig = Rig(following_error=0.1, following_ticks=2)
    rig.state.position[:] = [0.5, 0.0, 0.0]
    reference = np.array([0.8, 0.0, 0.0])
    for _ in range(2):
        rig.step(reference=reference)
    (fault,) = rig.stage.faults
    assert fault.kind == FaultKind.FOLLOWING and fault.joint == 0
    assert fault.value == pytest.approx(0.3) and "following error 0.3 beyond ±0.1 for 2 ticks" in fault.reason


def test_the_following_window_is_ten_ticks_by_default():
    """docs/operations.md: ``following_ticks`` defaults to 10, in the stage as in ``[safety]``."""
    rig = Rig(following_error=0.1)
    reference = np.array([0.5, 0.0, 0.0])
    for tick in range(10):
        assert rig.stage.faults == [], tick
        rig.step(reference=reference)
    assert [f.kind for f in rig.stage.faults] == [FaultKind.FOLLOWING] and rig.stage.faults[0].tick == 9


def test_devices_must_be_one_per_group_of_joints():
    with pytest.raises(ValueError, match="one per group"):
        SafetyStage(Q_MIN, Q_MAX, V_MAX, TAU_MAX, device_joints=[[0], [1, 2]], devices=[Device("arm")])
    stage = SafetyStage(Q_MIN, Q_MAX, V_MAX, TAU_MAX, device_joints=[[0], [1, 2]],
                        devices=[Device("base"), Device("arm")])
    assert stage.devices[1].name == "arm"


def test_joint_0s_device_error_and_a_jointless_devices_error_are_two_faults():
    """Joint 0's faults are latched at joint 0, the robot-wide ones (no joint) apart: a device
    error of the device holding joint 0 must not hide the error of a device without joints."""
    rig = Rig(n_devices=2)
    rig.statuses[0] = int(Status.ERROR)  # the device of joint 0
    rig.stage.check(0.0, 0, rig.state, rig.statuses, rig.command, device_error="device eye failed: no frame")
    assert sorted((f.kind, f.joint) for f in rig.stage.faults) == [(FaultKind.DEVICE_ERROR, -1),
                                                                    (FaultKind.DEVICE_ERROR, 0)]


def test_a_reset_acknowledges_a_jointless_devices_error_whatever_the_joints_devices_say():
    """A device without joints reports again at its next read if it still fails; the reset itself
    acknowledges its error. The joints' device still in error keeps its own fault."""
    rig = Rig(n_devices=2)
    rig.stage.check(0.0, 0, rig.state, rig.statuses, rig.command, device_error="device eye failed: no frame")
    rig.statuses[1] = int(Status.ERROR)  # the device of joints 1 and 2 (the last joint's)
    rig.step()
    assert not rig.stage.reset()
    assert [(f.kind, f.joint) for f in rig.stage.faults] == [(FaultKind.DEVICE_ERROR, 1)]


@pytest.mark.parametrize("q_min", [np.full((1, 3), -1.0), np.float64(-1.0)])
def test_limits_need_one_lower_limit_per_joint(q_min):
    """A wrong shape is a ValueError (a (1, n) array was taken for n joints; a scalar raised IndexError)."""
    with pytest.raises(ValueError, match="one value per joint"):
        limits_table(q_min, Q_MAX, V_MAX, TAU_MAX)
