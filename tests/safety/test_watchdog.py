"""Stale data and device status."""
import numpy as np
import pytest

from safety_rig import Rig
from rtctl.safety import FaultKind, Verdict


@pytest.mark.parametrize("n", [1, 3, 5])
def test_stale_faults_at_exactly_the_nth_consecutive_stale_tick(n):
    r = Rig(stale_ticks=n)
    r.state.fresh[1] = False
    for _ in range(n - 1):
        assert r.step() == Verdict.OK
    assert r.step() == Verdict.FALLBACK
    (f,) = r.stage.faults
    assert (f.kind, f.joint, f.value, f.tick) == (FaultKind.STALE, 1, n, n - 1)


def test_a_fresh_tick_restarts_the_count():
    r = Rig(stale_ticks=3)
    for fresh in (False, False, True, False, False, True, False, False):
        r.state.fresh[0] = fresh
        assert r.step() == Verdict.OK


def test_device_error_faults_once_for_the_device():
    r = Rig(n_devices=2)
    assert r.step() == Verdict.OK
    r.statuses[1] = 1  # ERROR on the device of joints 1 and 2
    assert r.step() == Verdict.FALLBACK
    (f,) = r.stage.faults
    assert (f.kind, f.joint, f.value) == (FaultKind.DEVICE_ERROR, 1, 1.0)
    for _ in range(3):
        assert r.step() == Verdict.FALLBACK
    assert len(r.stage.faults) == 1
    assert not r.stage.reset()  # still in ERROR
    r.statuses[1] = 0
    r.step()
    assert r.stage.reset()
    assert r.step() == Verdict.OK


def test_device_asking_to_deactivate_stops_like_an_estop():
    r = Rig(n_devices=2, estop_off_delay=0.005)
    r.state.velocity[:] = 1.0
    r.statuses[0] = 2
    verdicts = [r.step() for _ in range(8)]
    assert verdicts == [Verdict.FALLBACK] * 5 + [Verdict.DEACTIVATE] * 3
    assert r.stage.faults[0].kind == FaultKind.DEVICE_DEACTIVATE
    np.testing.assert_array_equal(r.command.tau_ff, 0.0)
