"""check() allocates nothing per tick, with the controllers in charge and in the fallback."""
import numpy as np

from allocations import growth_and_peak
from rtctl.hal.joints import CommandMode, JointCommand, JointState
from rtctl.safety import SafetyStage, Verdict


def _peak_and_growth(fn, calls=3000):
    fn()  # compiled paths loaded
    return growth_and_peak(fn, calls)


def test_check_allocates_nothing():
    # many joints: a temporary array (≥ 8 n bytes), or a fault scan on a tick without a fault
    # (np.flatnonzero's empty index array and its bookkeeping: ~630 bytes), stands out from the
    # argument tuples numba's dispatcher builds and frees on every call (48–96 bytes measured)
    n = 200
    stage = SafetyStage(np.full(n, -2.0), np.full(n, 2.0), np.full(n, 3.0), np.full(n, 10.0), position_margin=0.1,
                        following_error=0.5)
    state, command = JointState(n), JointCommand(n)
    state.position[:] = np.linspace(-1.95, 1.95, n)  # some in the soft band
    reference = state.position + 0.1  # checked: inside the following-error window
    statuses = np.zeros(1, dtype=np.int64)
    rng = np.random.default_rng(0)
    command.tau_ff[:] = rng.uniform(-20, 20, n)
    for mode in (CommandMode.TORQUE, CommandMode.IMPEDANCE):
        command.mode = mode
        growth, peak = _peak_and_growth(lambda: stage.check(0.0, 0, state, statuses, command, True, None, reference))
        assert stage.check(0.0, 0, state, statuses, command, True, None, reference) == Verdict.OK
        assert growth <= 64 and peak < 2 * n, (mode, growth, peak)
    stage.check(0.0, 0, state, statuses, command, False, "boom")
    growth, peak = _peak_and_growth(lambda: stage.check(0.0, 0, state, statuses, command))
    assert stage.check(0.0, 0, state, statuses, command) == Verdict.FALLBACK
    assert growth <= 64 and peak < 2 * n, (growth, peak)
