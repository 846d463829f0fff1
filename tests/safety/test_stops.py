"""E-stop (category 1), fault stop delays, reset semantics, events, and the verdict sequence:
a fault never leaves a drive enabled without something in charge of it."""
import math

import numpy as np
import pytest
import structlog
from hypothesis import given, settings, strategies as st

from safety_rig import TAU_MAX, Rig
from rtctl.safety import FaultKind, Verdict


def test_estop_damps_then_deactivates_after_the_delay():
    r = Rig(estop_off_delay=0.003, damping=2.0)
    r.state.velocity[:] = [1.0, -1.0, 0.5]
    assert r.step() == Verdict.OK
    r.stage.estop("button")
    verdicts = []
    for _ in range(6):
        verdicts.append(r.step())
        if verdicts[-1] == Verdict.FALLBACK:
            np.testing.assert_allclose(r.command.tau_ff, -2.0 * r.state.velocity)
    # latched at t = 0 (the last check's time): ticks at t = 1, 2 ms damp, t = 3 ms switches off
    assert verdicts == [Verdict.FALLBACK] * 2 + [Verdict.DEACTIVATE] * 4
    np.testing.assert_array_equal(r.command.tau_ff, 0.0)
    assert r.stage.faults[0].kind == FaultKind.ESTOP and r.stage.faults[0].reason == "button"
    assert [e["event"] for e in r.stage.events] == ["fault", "deactivate"]


def test_estop_deactivates_as_soon_as_the_robot_is_still():
    r = Rig(estop_off_delay=10.0, stop_velocity=0.05)
    r.state.velocity[:] = 0.2
    r.step()
    r.stage.estop()
    assert r.step() == Verdict.FALLBACK
    r.state.velocity[:] = 0.04
    assert r.step() == Verdict.DEACTIVATE


def test_a_stop_goes_on_while_the_speed_is_exactly_the_stop_velocity():
    r = Rig(estop_off_delay=10.0, stop_velocity=0.25)  # exact in binary
    r.state.velocity[:] = [0.25, -0.25, 0.0]
    r.stage.estop()
    assert [r.step() for _ in range(3)] == [Verdict.FALLBACK] * 3  # "still" is strictly slower
    r.state.velocity[:] = np.nextafter(0.25, 0.0)
    assert r.step() == Verdict.DEACTIVATE


def test_estop_with_zero_delay_is_category_0():
    r = Rig(estop_off_delay=0.0)
    r.state.velocity[:] = 1.0
    r.stage.estop()
    assert r.step() == Verdict.DEACTIVATE


def test_a_normal_stop_damps_like_an_estop_but_latches_nothing():
    r = Rig(estop_off_delay=0.003, damping=2.0)
    r.state.velocity[:] = [1.0, -1.0, 0.5]
    r.step()
    with structlog.testing.capture_logs() as logs:
        r.stage.stop("duration reached")
        r.stage.stop("signal SIGTERM")  # the first reason stands
        verdicts = [r.step() for _ in range(5)]
    np.testing.assert_array_equal(r.command.tau_ff, 0.0)
    assert verdicts == [Verdict.FALLBACK] * 2 + [Verdict.DEACTIVATE] * 3  # the same timing as an e-stop
    assert not r.stage.faulted and r.stage.faults == []
    assert [(e["event"], e["log_level"]) for e in logs] == [("stop", "info"), ("deactivate", "info")]
    summary = r.stage.summary()
    assert summary["faulted"] is False and summary["stop"] == {"reason": "duration reached", "t": 0.0}
    assert not r.stage.reset()  # the run is ending: nothing re-arms it
    assert r.step() == Verdict.DEACTIVATE


def test_a_normal_stop_carries_the_weight_where_the_arm_is_when_it_begins():
    # the damping stop's feed-forward is gravity at the stop's position, not at the start's
    r = Rig(estop_off_delay=1.0, damping=2.0, gravity=lambda q: 10.0 * q)
    r.state.position[:] = [0.1, 0.2, 0.3]
    r.step()
    r.state.position[:] = [0.4, -0.5, 0.6]
    r.state.velocity[:] = [1.0, -1.0, 0.5]  # still moving: the stop damps before it switches off
    r.step()
    r.stage.stop("duration reached")
    assert r.step() == Verdict.FALLBACK
    np.testing.assert_allclose(r.command.tau_ff, [4.0, -5.0, 6.0] - 2.0 * r.state.velocity)


def test_a_fault_during_a_normal_stop_is_still_a_fault():
    r = Rig(estop_off_delay=1.0)
    r.state.velocity[:] = 0.5
    r.stage.stop("stop requested")
    r.state.position[0] = 1.5  # past q_max during the stop
    with structlog.testing.capture_logs() as logs:
        assert r.step() == Verdict.FALLBACK
    assert r.stage.faulted and r.stage.faults[0].kind == FaultKind.POSITION
    assert logs[0]["event"] == "fault" and logs[0]["log_level"] == "warning"


def test_ordinary_fault_holds_until_fault_off_delay():
    r = Rig(fault_off_delay=0.002)
    r.command.tau_ff[0] = math.nan
    assert [r.step() for _ in range(4)] == [Verdict.FALLBACK] * 2 + [Verdict.DEACTIVATE] * 2
    r = Rig()  # default: hold with drives on until reset
    r.command.tau_ff[0] = math.nan
    assert {r.step() for _ in range(1000)} == {Verdict.FALLBACK}


def test_reset_clears_only_faults_whose_cause_is_gone():
    r = Rig()
    r.state.position[0] = 1.2  # past q_max = 1
    r.state.velocity[:] = 0.5  # still moving: the e-stop damps (a still robot would switch off at once)
    r.stage.estop()
    assert r.step() == Verdict.FALLBACK
    assert {f.kind for f in r.stage.faults} == {FaultKind.ESTOP, FaultKind.POSITION}
    assert not r.stage.reset()  # the e-stop is acknowledged, the joint is still out of range
    assert [f.kind for f in r.stage.faults] == [FaultKind.POSITION]
    assert r.step() == Verdict.FALLBACK
    r.state.position[0] = 0.9
    r.state.velocity[:] = 0.0
    assert r.step() == Verdict.FALLBACK  # back in range, but latched
    assert r.stage.reset()
    assert not r.stage.faults and not r.stage.faulted
    r.command.tau_ff[:] = 1.0
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, 1.0)
    r.state.position[0] = 1.3  # the same fault again is recorded again
    assert r.step() == Verdict.FALLBACK and len(r.stage.faults) == 1


@pytest.mark.parametrize("joint", [0, 2])
def test_a_fault_kept_by_a_partial_reset_is_not_recorded_again(joint):
    r = Rig()
    r.state.position[joint] = 3.5  # past every joint's q_max
    r.state.velocity[:] = 0.5
    r.stage.estop()
    r.step()
    assert not r.stage.reset()  # the e-stop is acknowledged, the joint is still out of range
    for _ in range(3):
        assert r.step() == Verdict.FALLBACK
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.POSITION, joint)]


def test_deactivate_persists_until_a_successful_reset():
    r = Rig(estop_off_delay=0.0)
    r.state.fresh[2] = False
    r.stage.estop()
    assert [r.step() for _ in range(5)] == [Verdict.DEACTIVATE] * 5
    assert not r.stage.reset()  # joint 2's data still stale
    assert r.step() == Verdict.DEACTIVATE
    r.state.fresh[2] = True
    r.step()
    assert r.stage.reset()
    assert r.step() == Verdict.OK


def test_events_are_logged_and_passed_to_the_callback():
    seen = []
    r = Rig(on_event=seen.append)
    r.state.velocity[:] = 1.0
    with structlog.testing.capture_logs() as logs:
        r.stage.estop("socket")
        r.step()
        r.stage.reset()
    assert [e["event"] for e in seen] == ["fault", "reset"]
    assert seen[0]["kind"] == "estop" and seen[0]["reason"] == "socket"
    assert [e["event"] for e in logs] == ["fault", "reset"]
    assert r.stage.summary()["events"] == seen


def test_a_raising_event_callback_is_logged_and_the_stop_goes_on():
    def broken(event):
        raise RuntimeError("disk full")

    r = Rig(on_event=broken, estop_off_delay=0.0)
    with structlog.testing.capture_logs() as logs:
        r.stage.estop("socket")
        assert r.step() == Verdict.DEACTIVATE
    assert [e["event"] for e in r.stage.events] == ["fault", "deactivate"]
    assert [e["error"] for e in logs if e["event"] == "on_event_failed"] == ["RuntimeError: disk full"] * 2


# -- the verdict sequence under random events -------------------------------------------
actions = st.lists(st.sampled_from(["tick", "tick", "tick", "nan", "raise", "fast", "far", "stale",
                                    "device", "estop", "reset", "recover"]), min_size=1, max_size=60)


@settings(max_examples=60, deadline=None)
@given(actions, st.sampled_from(["hold", "damp"]), st.sampled_from([0.0, 0.004, math.inf]))
def test_no_drive_is_left_enabled_without_a_controller(seq, fallback, fault_off_delay):
    r = Rig(n_devices=2, fallback=fallback, fault_off_delay=fault_off_delay, estop_off_delay=0.002,
            stale_ticks=2, hold_stiffness=50.0, damping=3.0)
    rng = np.random.default_rng(len(seq))
    deactivated = False
    for a in seq:
        ok = True
        if a == "nan":
            r.command.tau_ff[1] = math.nan
        elif a == "raise":
            ok = False
        elif a == "fast":
            r.state.velocity[2] = 9.0
        elif a == "far":
            r.state.position[0] = 1.5
        elif a == "stale":
            r.state.fresh[1] = False
        elif a == "device":
            r.statuses[1] = 1
        elif a == "estop":
            r.stage.estop()
        elif a == "recover":
            r.state.position[:] = 0.0
            r.state.velocity[:] = 0.0
            r.state.fresh[:] = True
            r.statuses[:] = 0
        elif a == "reset":
            if r.stage.reset():
                deactivated = False
            continue
        if a != "nan":
            r.command.tau_ff[:] = rng.uniform(-30, 30, 3)  # what a controller would write
        before = r.command.tau_ff.copy()
        v = r.step(controller_ok=ok)
        assert (v == Verdict.OK) == (not r.stage.faults)  # OK only with nothing latched
        if deactivated:
            assert v == Verdict.DEACTIVATE  # stays off until a reset succeeds
        tau = r.command.tau_ff
        assert np.all(np.isfinite(tau)) and np.all(np.abs(tau) <= TAU_MAX)
        if v == Verdict.DEACTIVATE:
            deactivated = True
            np.testing.assert_array_equal(tau, 0.0)
        elif v == Verdict.FALLBACK:  # the controller's numbers are gone: the fallback law is in charge
            q, qd = r.state.position, r.state.velocity
            stopping = any(f.kind in (FaultKind.ESTOP, FaultKind.DEVICE_DEACTIVATE) for f in r.stage.faults)
            if fallback == "damp" or stopping:
                law = -3.0 * qd
            else:
                law = 50.0 * (r.stage.fb[3] - q) - 3.0 * qd  # row 3: the held position
            np.testing.assert_allclose(tau, np.clip(law, -TAU_MAX, TAU_MAX))
        else:
            np.testing.assert_allclose(tau, np.clip(before, -TAU_MAX, TAU_MAX))


def test_the_fault_off_delay_counts_from_the_fault_not_from_the_start():
    r = Rig(fault_off_delay=5 / 1024)
    r.dt = 1 / 1024  # exact in binary: the times below are exact
    for _ in range(10):
        assert r.step() == Verdict.OK
    r.command.tau_ff[0] = math.nan  # fault at tick 10
    verdicts = [r.step() for _ in range(8)]
    assert verdicts == [Verdict.FALLBACK] * 5 + [Verdict.DEACTIVATE] * 3  # off at tick 15
    assert [e.get("reason") for e in r.stage.events if e["event"] == "deactivate"] == ["fault_off_delay"]


def test_the_estop_delay_counts_from_the_estop_not_from_the_start():
    r = Rig(estop_off_delay=5 / 1024)
    r.dt = 1 / 1024  # exact in binary: the times below are exact
    r.state.velocity[:] = 0.5  # still moving: the delay, not the stillness, ends the stop
    for _ in range(10):
        assert r.step() == Verdict.OK
    r.stage.estop()  # latched at t = 9/1024 (the last check's time)
    verdicts = [r.step() for _ in range(8)]
    assert verdicts == [Verdict.FALLBACK] * 4 + [Verdict.DEACTIVATE] * 4  # off at tick 14 = 9 + 5


def test_the_default_estop_delay_is_a_fifth_of_a_second():
    r = Rig()
    r.dt = 1 / 1024
    r.state.velocity[:] = 0.5  # still moving: the delay, not the stillness, ends the stop
    r.step()
    r.stage.estop()  # latched at t = 0 (the last check's time)
    verdicts = [r.step() for _ in range(210)]
    assert verdicts.index(Verdict.DEACTIVATE) + 1 == math.ceil(0.2 * 1024)  # the first tick at t ≥ 0.2 s
    assert [e.get("reason") for e in r.stage.events if e["event"] == "deactivate"] == ["stopped"]


def test_each_fault_kind_is_a_bit_of_its_own():
    """The kinds are OR-ed into one latched word per joint: two sharing a bit would alias."""
    bits = [int(kind) for kind in FaultKind.__members__.values()]
    assert all(b > 0 and b & (b - 1) == 0 for b in bits) and len(set(bits)) == len(bits) == 11


def test_a_recorded_fault_cannot_be_changed():
    """Faults are the run's record (summary, events, the control socket): nothing rewrites one."""
    import dataclasses

    r = Rig()
    r.stage.estop()
    r.step()
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.stage.faults[0].joint = 0


def test_robot_wide_faults_have_no_joint():
    class Raising:
        reason = ""

        def check(self, t, state, command):
            raise RuntimeError("zone table corrupt")

    r = Rig(guard=Raising())
    assert r.step() == Verdict.FALLBACK
    r.stage.estop("button")
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.GUARD, -1), (FaultKind.ESTOP, -1)]


def test_faults_on_different_joints_in_different_ticks_are_each_recorded():
    r = Rig()
    r.state.position[0] = 1.5
    assert r.step() == Verdict.FALLBACK
    r.state.position[2] = -3.5
    r.step()
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.POSITION, 0), (FaultKind.POSITION, 2)]


def test_after_a_reset_the_same_fault_latches_again():
    r = Rig()
    r.state.position[1] = 2.5
    assert r.step() == Verdict.FALLBACK
    r.state.position[1] = 0.0
    assert r.stage.reset() and r.step() == Verdict.OK
    r.state.position[1] = 2.5
    assert r.step() == Verdict.FALLBACK
    assert len(r.stage.faults) == 1 and r.stage.faults[0].tick == 2


def test_a_partial_reset_keeps_what_remains_and_still_latches_new_faults():
    r = Rig()
    r.state.position[:] = [1.5, 0.0, 0.0]
    r.state.velocity[:] = [0.0, 0.0, 9.0]
    r.step()
    r.state.position[0] = 0.0  # joint 0 is back, joint 2 is still too fast
    assert not r.stage.reset()
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.VELOCITY, 2)]
    r.state.position[0] = 1.5  # joint 0 leaves its range again: a new record
    r.step()
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.VELOCITY, 2), (FaultKind.POSITION, 0)]


@pytest.mark.parametrize("q, qd, value", [(math.nan, 0.0, math.nan), (0.1, math.inf, math.inf),
                                           (-math.inf, math.nan, -math.inf)])
def test_a_nonfinite_state_fault_records_the_bad_value(q, qd, value):
    r = Rig()
    r.state.position[1], r.state.velocity[1] = q, qd
    r.step()
    (f,) = r.stage.faults
    assert f.kind == FaultKind.NONFINITE_STATE and f.joint == 1
    assert f.value == value or (math.isnan(value) and math.isnan(f.value))


@pytest.mark.parametrize("q, qd", [(0.1, math.nan), (math.inf, 0.0)])
def test_a_nonfinite_state_fault_stays_while_either_value_is_not_finite(q, qd):
    r = Rig()
    r.state.position[1] = math.nan
    assert r.step() == Verdict.FALLBACK
    r.state.position[1], r.state.velocity[1] = q, qd  # half repaired
    assert not r.stage.reset()
    assert [(f.kind, f.joint) for f in r.stage.faults] == [(FaultKind.NONFINITE_STATE, 1)]
    r.state.position[1], r.state.velocity[1] = 0.1, 0.0
    assert r.stage.reset() and not r.stage.faults


def test_a_gravity_model_that_raises_is_reported_and_the_hold_goes_on_without_it():
    def broken(q):
        raise RuntimeError("model not loaded")

    r = Rig(gravity=broken, hold_stiffness=100.0, damping=0.0)
    r.state.position[0] = 1.2  # past q_max: a fault, the hold snapshots the position
    assert r.step() == Verdict.FALLBACK
    (event,) = [e for e in r.stage.events if e["event"] == "gravity_failed"]
    assert event["reason"] == "RuntimeError: model not loaded"
    r.state.position[0] = 1.1
    assert r.step() == Verdict.FALLBACK
    assert r.command.tau_ff[0] == pytest.approx(100.0 * (1.2 - 1.1))  # the spring alone, no gravity term


def test_an_estop_before_the_first_tick_is_recorded_at_tick_0():
    r = Rig()
    r.stage.estop()
    (f,) = r.stage.faults
    assert (f.kind, f.tick, f.t) == (FaultKind.ESTOP, 0, 0.0)


def test_a_nonfinite_command_fault_is_cleared_by_the_reset():
    r = Rig()
    r.command.tau_ff[2] = math.nan
    assert r.step() == Verdict.FALLBACK
    assert r.stage.reset() and not r.stage.faults


def test_a_nonfinite_command_fault_clears_even_while_its_device_still_reports_an_error():
    r = Rig()
    r.command.tau_ff[2] = math.nan
    assert r.step() == Verdict.FALLBACK
    r.statuses[0] = 1  # then the device (all three joints) reports an error, and goes on reporting it
    r.step()
    assert not r.stage.reset()
    assert [f.kind for f in r.stage.faults] == [FaultKind.DEVICE_ERROR]


def test_events_are_capped_and_the_rest_counted():
    from rtctl.safety.stage import _MAX_EVENTS

    r = Rig()
    r.stage.log_events = False
    for i in range(_MAX_EVENTS + 3):
        r.stage._event("probe", "info", i=i)
    assert len(r.stage.events) == _MAX_EVENTS == 1000 and r.stage.events_dropped == 3
    assert r.stage.events[-1]["i"] == _MAX_EVENTS - 1
