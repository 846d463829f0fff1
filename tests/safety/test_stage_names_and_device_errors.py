"""What a fault record says about where it comes from, and what a check assumes by default
(mutation survivors of the full safety run, issue 27 part 3): a device's own error belongs to
no joint (``Fault.joint`` is −1 when the fault is not a joint's); the joint names given to the
stage — one per joint — name the joint in a fault's reason; without news of the controllers,
they ran."""
import numpy as np
import pytest

from rtctl.safety import SafetyStage
from rtctl.safety.faults import FaultKind
from safety_rig import Q_MAX, Q_MIN, TAU_MAX, V_MAX, Rig


def test_a_device_error_is_a_fault_of_no_joint():
    rig = Rig()
    rig.stage.check(0.0, 0, rig.state, rig.statuses, rig.command, device_error="arm: drive 0x1 over-temperature")
    (fault,) = rig.stage.faults
    assert fault.kind == FaultKind.DEVICE_ERROR and fault.joint == -1
    assert fault.reason == "arm: drive 0x1 over-temperature"


def test_joint_names_name_the_joint_in_a_fault():
    rig = Rig(joint_names=["base", "shoulder", "elbow"])
    rig.state.position[:] = [0.0, Q_MAX[1] + 0.5, 0.0]  # joint 1 past its hard limit
    rig.step()
    (fault,) = rig.stage.faults
    assert fault.kind == FaultKind.POSITION and fault.joint == 1 and "joint 1 (shoulder)" in fault.reason


@pytest.mark.parametrize("names", [["base", "shoulder"], ["base", "shoulder", "elbow", "wrist"]])
def test_joint_names_are_one_per_joint(names):
    with pytest.raises(ValueError, match="joint_names"):
        SafetyStage(Q_MIN, Q_MAX, V_MAX, TAU_MAX, joint_names=names)


def test_a_check_without_controller_news_assumes_the_controllers_ran():
    """``controller_ok`` defaults to True: a caller that has no controller to report on (a hold, a
    test bench) gets the state's verdict, not a controller fault."""
    rig = Rig()
    verdict = rig.stage.check(0.0, 0, rig.state, rig.statuses, rig.command)
    assert verdict == rig.step() and rig.stage.faults == []


@pytest.mark.parametrize("key", ["hold_stiffness", "damping"])
def test_the_fallback_gains_cannot_be_tuned_negative(key):
    """A negative stiffness or damping pushes away from the hold: refused as in ``[safety]``."""
    from rtctl.control.tunable import read_value
    from rtctl.errors import ConfigError

    tunable = Rig().stage.tunables()[key]
    read_value(tunable, "safety", key, 0.0)
    with pytest.raises(ConfigError):
        read_value(tunable, "safety", key, -0.5)
