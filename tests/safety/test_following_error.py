"""The following-error window: |q_ref − q| over ``following_error`` for ``following_ticks``
consecutive ticks, while the controllers are in charge of a reference, is a fault."""
import numpy as np
import pytest

from safety_rig import Rig
from rtctl.safety import FaultKind, Verdict
from rtctl.safety.limits import limits_table

WINDOW, TICKS = 0.05, 4


@pytest.fixture
def rig():
    return Rig(following_error=WINDOW, following_ticks=TICKS, hold_stiffness=100.0, damping=4.0)


def _ref(*errors):
    """A reference that many radians ahead of the rig's state (all zero)."""
    return np.array(errors, dtype=float)


def test_the_following_ticks_th_tick_outside_the_window_faults_and_holds_there(rig):
    ref = _ref(0.0, -0.0501, 0.0)
    for _ in range(TICKS - 1):
        assert rig.step(reference=ref) == Verdict.OK
    assert rig.step(reference=ref) == Verdict.FALLBACK
    (f,) = rig.stage.faults
    assert (f.kind, f.joint, f.tick) == (FaultKind.FOLLOWING, 1, TICKS - 1)
    assert f.value == pytest.approx(-0.0501)  # q_ref − q, signed
    assert "following error" in f.reason and "joint 1" in f.reason
    rig.state.position[:] = [0.01, 0.0, 0.0]
    assert rig.step(reference=ref) == Verdict.FALLBACK  # held where it was, not at the reference
    assert rig.command.tau_ff[0] == pytest.approx(100.0 * -0.01)


def test_an_error_on_the_window_or_inside_it_never_faults(rig):
    for _ in range(5 * TICKS):
        assert rig.step(reference=_ref(WINDOW, -WINDOW, 0.0)) == Verdict.OK
    assert not rig.stage.faults


def test_the_count_restarts_when_the_error_comes_back_inside(rig):
    out, back = _ref(0.06, 0.0, 0.0), _ref(0.04, 0.0, 0.0)
    for _ in range(3):
        for _ in range(TICKS - 1):
            assert rig.step(reference=out) == Verdict.OK
        assert rig.step(reference=back) == Verdict.OK
    assert not rig.stage.faults


def test_ticks_without_a_reference_are_not_checked_and_restart_the_count(rig):
    out = _ref(0.0, 0.0, 1.0)
    for _ in range(TICKS - 1):
        rig.step(reference=out)
    assert rig.step() == Verdict.OK
    for _ in range(TICKS - 1):
        assert rig.step(reference=out) == Verdict.OK
    assert rig.step(reference=out) == Verdict.FALLBACK


def test_one_window_per_joint():
    r = Rig(following_error=[0.1, 0.01, 0.1], following_ticks=1)
    assert r.step(reference=_ref(0.09, 0.0, -0.09)) == Verdict.OK
    assert r.step(reference=_ref(0.0, 0.011, 0.0)) == Verdict.FALLBACK
    assert r.stage.faults[0].joint == 1


def test_off_by_default():
    r = Rig()
    for _ in range(20):
        assert r.step(reference=_ref(1.0, 1.0, 1.0)) == Verdict.OK


def test_no_check_while_stopping_or_after_a_fault(rig):
    """The reference runs on while the fallback holds or a normal stop damps: that is not a
    second fault (it would latch one reset() then has to clear)."""
    assert rig.step(controller_ok=False, error="boom") == Verdict.FALLBACK
    for _ in range(2 * TICKS):
        rig.step(reference=_ref(1.0, 1.0, 1.0))
    assert [f.kind for f in rig.stage.faults] == [FaultKind.CONTROLLER]
    stopping = Rig(following_error=WINDOW, following_ticks=TICKS)
    stopping.stage.stop("duration")
    for _ in range(2 * TICKS):
        stopping.step(reference=_ref(1.0, 1.0, 1.0))
    assert stopping.stage.faults == []


def test_reset_clears_it_and_the_count_starts_again(rig):
    """The loop holds where the robot is after a reset (the reference with it)."""
    out = _ref(0.2, 0.0, 0.0)
    for _ in range(TICKS):
        rig.step(reference=out)
    assert rig.stage.faulted and rig.stage.reset()
    for _ in range(TICKS - 1):
        assert rig.step(reference=out) == Verdict.OK
    assert rig.step(reference=out) == Verdict.FALLBACK


def test_a_nan_reference_is_not_a_following_fault(rig):
    """(The controllers' command is then not finite either: that fault is the one to report.)"""
    for _ in range(2 * TICKS):
        assert rig.step(reference=_ref(np.nan, 0.0, np.nan)) == Verdict.OK


@pytest.mark.parametrize("reference", [np.zeros(2), np.zeros(4), np.zeros((3, 1))])
def test_a_reference_of_the_wrong_shape_is_a_value_error(rig, reference):
    with pytest.raises(ValueError, match="one position per joint"):
        rig.step(reference=reference)


@pytest.mark.parametrize("window", [0.0, -0.1, [0.1, 0.0, 0.1], np.nan])
def test_a_window_that_is_not_positive_is_refused(window):
    with pytest.raises(ValueError, match="following_error must be > 0"):
        limits_table([-1.0] * 3, [1.0] * 3, [1.0] * 3, [1.0] * 3, following_error=window)
