"""The compiled per-tick guard: its stopping path, stop and clamp, limits, impedance commands,
episodes and events through the safety stage, and no allocation per tick."""
import numpy as np
import pytest

from allocations import growth_and_peak
from rtctl.guard import Polygon, RuntimeGuard, Scene, Zone
from rtctl.guard import kernels as k
from rtctl.hal.joints import CommandMode, JointCommand, JointState
from rtctl.safety import FaultKind, GuardVerdict, SafetyStage, Verdict
from test_zones import SQUARE

DT, DECEL = 0.001, np.array([10.0, 20.0])
SCENE = Scene([Zone("box", [Polygon((0, 1), SQUARE)])], [-3.0, -3.0], [3.0, 3.0], margin=0.1)


def at(q, qd, tau=(0.0, 0.0)):
    state, command = JointState(2), JointCommand(2)
    state.position[:], state.velocity[:], command.tau_ff[:] = q, qd, tau
    return state, command


def test_the_stopping_path_is_one_period_then_a_common_braking():
    g = RuntimeGuard(SCENE, DECEL, DT, margin=0.02)
    state, command = at([-2.0, 0.0], [2.0, -1.0])
    assert g.check(0.0, state, command) == GuardVerdict.PASS  # reaches -1.7: clear
    T = max(2.0 / 10.0, 1.0 / 20.0)  # the slowest joint to stop sets the common time
    np.testing.assert_allclose(g.work[k.STOP_POINT], state.position + state.velocity * (DT + T / 2))


@pytest.mark.parametrize("q, qd, verdict", [
    ([-1.0, 0.0], [3.3, 0.0], GuardVerdict.STOP),   # stops at -0.452: inside the 0.02 band
    ([-1.0, 0.0], [2.5, 0.0], GuardVerdict.PASS),   # stops at -0.685: clear
    ([-0.55, 0.0], [-3.0, 0.0], GuardVerdict.PASS),  # close, but moving away
    ([-0.51, 0.0], [0.0, 0.0], GuardVerdict.STOP),  # at rest inside the band
    ([-0.6, 0.9], [3.0, -3.0], GuardVerdict.STOP),  # diagonal, into the corner
])
def test_stop(q, qd, verdict):
    g = RuntimeGuard(SCENE, DECEL, DT, margin=0.02)
    assert g.check(0.0, *at(q, qd)) == verdict
    if verdict == GuardVerdict.STOP:
        assert g.report[k.KIND] == k.ZONE and "zone 'box'" in g.reason and g.event()["zone"] == "box"


def test_limits_are_predicted_too():
    g = RuntimeGuard(SCENE, DECEL, DT)
    assert g.check(0.0, *at([2.5, -2.0], [3.5, 0.0])) == GuardVerdict.STOP  # stops at 3.11 > 3
    assert g.event()["zone"] == "joint 0 upper limit"
    assert g.check(0.0, *at([2.5, -2.0], [-3.5, 0.0])) == GuardVerdict.PASS


def test_clamp_pushes_out_in_the_outer_band_and_stops_in_the_inner():
    g = RuntimeGuard(SCENE, DECEL, DT, margin=0.04, action="clamp", damping=10.0, stiffness=100.0)
    # a slow approach whose stop point lies in the outer half of the band: clamped
    state, command = at([-0.543, 0.0], [0.3, 0.0], tau=[5.0, 1.0])
    assert g.check(0.0, state, command) == GuardVerdict.MODIFIED
    depth = (-0.543 + 0.3 * (DT + 0.3 / 20)) - (-0.5 - 0.04)  # how far the stop point is past the band's edge
    assert depth > 0
    # the inward torque (+5 along joint 0, the face's inward normal) is gone, the wall pushes back
    assert command.tau_ff[0] == pytest.approx(-(100.0 * depth + 10.0 * 0.3))
    assert command.tau_ff[1] == 1.0  # along the face: untouched
    assert g.event()["action"] == "clamp"
    # faster: the stop point reaches the inner half of the band → stop
    assert g.check(0.0, *at([-0.543, 0.0], [1.0, 0.0], tau=[5.0, 1.0])) == GuardVerdict.STOP


def test_impedance_targets_inside_a_zone_are_stopped_or_held():
    state, command = at([-1.0, 0.0], [0.0, 0.0])
    command.mode = CommandMode.IMPEDANCE
    command.q_des[:] = [0.0, 0.0]
    assert RuntimeGuard(SCENE, DECEL, DT).check(0.0, state, command) == GuardVerdict.STOP
    clamp = RuntimeGuard(SCENE, DECEL, DT, margin=0.04, action="clamp")
    assert clamp.check(0.0, state, command) == GuardVerdict.MODIFIED
    np.testing.assert_array_equal(command.q_des, [-1.0, 0.0])  # the drive holds where it is


def test_one_event_per_episode_through_the_stage():
    g = RuntimeGuard(SCENE, DECEL, DT, margin=0.04, action="clamp")
    stage = SafetyStage([-3.0, -3.0], [3.0, 3.0], [10.0, 10.0], [50.0, 50.0], guard=g)
    stage.log_events = False
    state, command = at([-0.543, 0.0], [0.3, 0.0], tau=[5.0, 0.0])
    for tick in range(5):
        command.tau_ff[:] = [5.0, 0.0]
        assert stage.check(tick * DT, tick, state, None, command) == Verdict.OK
    events = [e for e in stage.events if e["event"] == "guard"]
    assert len(events) == 1 and events[0]["zone"] == "box" and events[0]["tick"] == 0
    state.velocity[:] = [3.0, 0.0]  # now too fast: a guard fault, the fallback takes over
    assert stage.check(5 * DT, 5, state, None, command) == Verdict.FALLBACK
    assert stage.faults[0].kind == FaultKind.GUARD and "zone 'box'" in stage.faults[0].reason


def test_check_allocates_nothing():
    # many joints: a temporary array (≥ 8 n bytes) would stand out from the argument tuples numba's
    # dispatcher builds and frees on every call (as in tests/safety/test_alloc.py)
    n = 200
    scene = Scene([Zone(f"z{i}", [Polygon((i % n, (i + 1) % n), np.array(SQUARE) * 0.2 + i * 0.1)])
                   for i in range(16)], [-3.0] * n, [3.0] * n, margin=0.05)
    for action, verdict in (("stop", GuardVerdict.PASS), ("clamp", GuardVerdict.MODIFIED)):
        g = RuntimeGuard(scene, 10.0, DT, margin=0.02, action=action)
        state, command = JointState(n), JointCommand(n)
        state.position[:] = -2.0
        if verdict == GuardVerdict.MODIFIED:  # clamping every tick (an episode in progress)
            state.position[:2] = [-0.122, 0.0]
            state.velocity[:2] = [0.3, 0.0]
        assert g.check(0.0, state, command) == verdict
        growth, peak = growth_and_peak(lambda: g.check(0.0, state, command), 3000)
        assert growth <= 64 and peak < 8 * n, (action, growth, peak)


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="deceleration"):
        RuntimeGuard(SCENE, [10.0, 0.0], DT)
    with pytest.raises(ValueError, match="action"):
        RuntimeGuard(SCENE, DECEL, DT, action="ignore")
    with pytest.raises(ValueError, match="guard margin > 0"):
        RuntimeGuard(SCENE, DECEL, DT, action="clamp")
