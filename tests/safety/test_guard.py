"""The interference guard's hook: called every tick the controllers are in charge, able to
modify the command (bounded again) or stop the robot."""
import math

import numpy as np

from safety_rig import TAU_MAX, Rig
from rtctl.safety import FaultKind, GuardVerdict, Verdict


class ScriptedGuard:
    def __init__(self, action=GuardVerdict.PASS, tau=None):
        self.action, self.tau, self.calls, self.reason = action, tau, [], ""

    def check(self, t, state, command):
        self.calls.append((t, command.tau_ff.copy()))
        if self.tau is not None:
            command.tau_ff[:] = self.tau
        if self.action == GuardVerdict.STOP:
            self.reason = "joint 1 would enter zone 'cable carrier'"
        return self.action


def test_guard_sees_the_bounded_command_every_ok_tick():
    g = ScriptedGuard()
    r = Rig(guard=g)
    r.command.tau_ff[:] = [50.0, 0.0, -50.0]
    for _ in range(3):
        assert r.step() == Verdict.OK
    assert [c[0] for c in g.calls] == [0.0, 0.001, 0.002]
    np.testing.assert_array_equal(g.calls[0][1], [10.0, 0.0, -5.0])


def test_guard_modification_is_kept_and_bounded_again():
    r = Rig(guard=ScriptedGuard(GuardVerdict.MODIFIED, tau=[1.0, 1e6, -2.0]))
    assert r.step() == Verdict.OK
    np.testing.assert_array_equal(r.command.tau_ff, [1.0, TAU_MAX[1], -2.0])


def test_guard_stop_engages_fallback_with_its_reason():
    g = ScriptedGuard(GuardVerdict.STOP)
    r = Rig(guard=g, damping=1.0, fallback="damp")
    r.state.velocity[:] = 1.0
    assert r.step() == Verdict.FALLBACK
    (f,) = r.stage.faults
    assert (f.kind, f.joint) == (FaultKind.GUARD, -1) and "cable carrier" in f.reason  # robot-wide
    np.testing.assert_array_equal(r.command.tau_ff, -1.0)
    r.step()
    assert len(g.calls) == 1  # not consulted while the fallback is in charge


def test_guard_that_raises_or_writes_nan_is_a_fault():
    class Raising:
        def check(self, t, state, command):
            raise RuntimeError("zone table corrupt")

    r = Rig(guard=Raising())
    assert r.step() == Verdict.FALLBACK
    assert r.stage.faults[0].kind == FaultKind.GUARD and "corrupt" in r.stage.faults[0].reason
    for joint in range(3):  # every joint, the first included
        tau = [0.0, 0.0, 0.0]
        tau[joint] = math.nan
        r = Rig(guard=ScriptedGuard(GuardVerdict.MODIFIED, tau=tau))
        assert r.step() == Verdict.FALLBACK
        (f,) = r.stage.faults
        assert (f.kind, f.joint) == (FaultKind.NONFINITE_COMMAND, joint) and "guard" in f.reason


def test_the_guard_kernels_return_the_stages_verdicts():
    """The compiled guard returns plain integers (numba kernels); the stage reads them as
    GuardVerdict — the two numberings are one protocol and must agree (a PASS the stage reads
    as a change would log a guard event on quiet ticks or re-bound every command)."""
    from rtctl.guard import kernels as gk

    assert (gk.PASS, gk.MODIFIED, gk.STOP) == (GuardVerdict.PASS, GuardVerdict.MODIFIED, GuardVerdict.STOP)


def test_a_guard_that_raises_is_a_robot_wide_guard_fault():
    class Raising:
        reason = ""

        def check(self, t, state, command):
            raise ValueError("zone table corrupt")

    r = Rig(guard=Raising())
    assert r.step() == Verdict.FALLBACK
    (f,) = r.stage.faults
    assert (f.kind, f.joint) == (FaultKind.GUARD, -1)
    assert f.reason == "guard raised ValueError: zone table corrupt"


def test_a_guard_episode_is_an_event_with_the_guards_fields():
    class Reporting(ScriptedGuard):
        event_due = True

        def event(self):
            return {"zone": "cable carrier", "action": "stop"}

    r = Rig(guard=Reporting(GuardVerdict.STOP))
    r.step()
    (event,) = [e for e in r.stage.events if e["event"] == "guard"]
    assert (event["zone"], event["action"]) == ("cable carrier", "stop")
    quiet = Rig(guard=Reporting(GuardVerdict.PASS))  # a pass is no episode, whatever event_due says
    quiet.step()
    assert not [e for e in quiet.stage.events if e["event"] == "guard"]
