"""The mit_can driver, the cases a full mutation run of drivers/can_joints.py found unchecked:
frames that are no drive's answer (error, foreign, extended-id, malformed — and a drive's spare
copy) neither answer another drive nor count as late or extra replies, a bus error while
collecting is a lost bus, effort scaled by the torque constant, one enter-motor-mode frame, no
stale ticks at activation, the budget at the loop rate itself, and the exit's accounting of
replies owed: given up on long ago, written off between attempts, a spare copy, a Damiao drive's
motor-on answer. What is left unchecked, and why, is in docs/mutation/can_joints.md."""
import dataclasses
from types import SimpleNamespace

import can
import pytest

from drivers.can_joints import MitCanJointGroup
from drivers.protocols.mit import KATZ, pack_reply
from drivers.protocols.mit_layout import MitJoint
from hil_sim.mit_drive import MitDrive, MitDriveBus, pump
from lockstep_rig import LockStep, SlowWire, as_over_slcan, rigs, virtual_bus
from rtctl.errors import BusLoadError, HardwareError
from rtctl.hal import CommandMode, Status
from rtctl.tomltable import Table

T_LSB = 36 / 4095


class Rig(LockStep, MitCanJointGroup):
    def __init__(self, joints, **kw):
        kw = {"reply_deadline": 0.0, "exchange_timeout": 0.0, "period": 0.001, **kw}
        super().__init__("arm", joints, virtual_bus(), **kw)
        self._attach(lambda j, port: MitDrive(j.drive_id, port, j.model), MitDriveBus)


class SlowRig(SlowWire, Rig):
    pass


@pytest.fixture
def rig():
    def make(joints=None, cls=Rig, **kw):
        return cls(joints or [MitJoint("a", 1, KATZ), MitJoint("b", 2, KATZ)], **kw)

    yield from rigs(make)


def junk(master_id):
    """Frames that are no drive's reply: an error frame, another id's, a reply-shaped frame with an
    extended id equal to the master id, a reply cut short."""
    reply_b = pack_reply(KATZ, 2, 0.1, 0.0, 0.0)
    return [
        can.Message(arbitration_id=master_id, data=reply_b, is_error_frame=True),
        can.Message(arbitration_id=0x123, data=reply_b, is_extended_id=False),
        can.Message(arbitration_id=master_id, data=reply_b, is_extended_id=True),
        can.Message(arbitration_id=master_id, data=reply_b[:3], is_extended_id=False),
    ]


def test_frames_that_are_no_reply_do_not_answer_for_the_last_drive(rig):
    """Drive b (the last row) silent, junk on the bus each tick: b is missing every tick (catches
    an ignored frame's row −1 read as the last row, −1 returned as 0 or 1, and an extended-id
    frame on the master id taken as a reply)."""
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[1].faults.silent = True
    for _ in range(3):
        for frame in junk(r.master_id):
            r.peer.send(frame)
        r.tick()
    r.read(r.now)
    assert r.counters["missing_replies"] == 3 and r.state.fresh.tolist() == [True, False]
    assert r.counters["error_frames"] == 3 and r.counters["foreign_frames"] == 6
    assert r.counters["malformed_replies"] == 3


def test_frames_after_every_answer_that_are_no_reply_are_not_extra_replies(rig):
    """Junk received after both drives answered is counted as what it is, not as a spare reply."""
    r = rig()
    r.activate()
    r.tick()
    r.read(r.now)
    r.write(r.now)  # the drives answer at once …
    for frame in junk(r.master_id):
        r.peer.send(frame)  # … and the junk comes after
    assert r.read(r.now) == Status.OK and r.state.fresh.all()
    assert r.counters["extra_replies"] == 0 and r.counters["late_replies"] == 0
    assert (r.counters["error_frames"], r.counters["foreign_frames"], r.counters["malformed_replies"]) == (1, 2, 1)


def test_frames_before_the_next_commands_that_are_no_reply_are_not_late_replies(rig):
    """A reply was missing at the last read, so the write first takes what is there: junk is not
    a late reply."""
    r = rig()
    r.activate()
    r.drive_list[1].faults.silent = True
    r.tick()
    assert r.read(r.now) == Status.OK and r.state.fresh.tolist() == [True, False]
    for frame in junk(r.master_id):
        r.peer.send(frame)
    r.write(r.now)
    assert r.counters["late_replies"] == 0 and r.counters["foreign_frames"] == 2


def test_a_drives_spare_reply_does_not_stand_for_another_drives_answer(rig):
    """A copy of drive a's reply arrives before the real answers: it is a's answer at most, so the
    collection still waits for b's and both are fresh (catches `row >= 0 or …`)."""
    r = rig(cls=SlowRig)
    r.activate()
    r.tick()
    r.hold = True
    r.tick()  # these commands' answers are held back …
    r.peer.send(can.Message(arbitration_id=r.master_id, data=pack_reply(KATZ, 1, 0.0, 0.0, 0.0),
                            is_extended_id=False))  # … behind a spare copy of drive a's reply
    pump(r.drives, r.peer, now=r.now)
    r.hold = False
    assert r.read(r.now) == Status.OK and r.state.fresh.tolist() == [True, True]
    assert r.counters["missing_replies"] == 0


def test_a_bus_error_while_collecting_is_a_lost_bus_not_an_exception(rig):
    r = rig()
    r.activate()
    r.tick()

    def broken(timeout=None):
        raise can.CanOperationError("link down")

    r.bus.recv = broken
    assert r.read(r.now) == Status.ERROR
    assert r.counters["bus_errors"] == 1 and [e["event"] for e in r.events][-1] == "bus_lost"


def test_effort_is_the_reported_current_times_the_torque_constant(rig):
    """A drive reporting phase current with Kt = 2 N·m/A: 4 N·m of torque reads back as 2 A × 2."""
    model = dataclasses.replace(KATZ, name="kt2", torque_constant=2.0)
    r = rig([MitJoint("a", 1, model), MitJoint("b", 2, model, direction=-1.0)])
    r.activate()
    r.command.mode = CommandMode.TORQUE
    r.command.tau_ff[:] = [4.0, 4.0]
    r.tick()
    r.read(r.now)
    assert r.state.effort == pytest.approx([4.0, 4.0], abs=2 * T_LSB)


def test_activation_sends_enter_motor_mode_once(rig):
    """The docstring: activate sends enter motor mode and requires every answer — one frame, not
    a retry (only deactivate repeats its frame)."""
    r = rig()
    r.configure()
    r.drive_list[1].faults.silent = True
    with pytest.raises(HardwareError, match=r"drive\(s\) 0x2 did not answer enter motor mode .*\(1 frame\(s\)\)"):
        r.activate()


def test_an_activation_starts_with_no_stale_ticks(rig):
    """Every drive answered enter motor mode: before the first read no tick has passed without
    a reply (catches the count set to ±1 at activation)."""
    r = rig()
    r.activate()
    assert r.diagnostics()["stale_ticks"] == {"a": 0, "b": 0}
    assert r.tick()[0] == Status.OK and r.diagnostics()["stale_ticks"] == {"a": 0, "b": 0}


def test_the_budget_is_at_the_loop_rate_itself_not_rounded_down():
    """Two MIT joints (250 bits each) at 1 kHz are exactly 50 % of 1 Mbit/s: a limit of 49.99 %
    refuses them (1.0 // 0.001 is 999 Hz: 49.95 %)."""
    t = Table({"bus": {"interface": "virtual", "channel": "x", "bitrate": 1_000_000}, "bus_load_limit": 0.4999},
              "run.toml", "devices[0]")
    device = SimpleNamespace(name="arm", options=t, joints=[0, 1])
    context = SimpleNamespace(model=SimpleNamespace(joint_names=["a", "b"]), period=0.001, shared={})
    with pytest.raises(BusLoadError):
        MitCanJointGroup.from_config(device, context)


def exit_frames(drive) -> int:
    return drive.counters.specials


def test_replies_given_up_on_are_lost_once_exchange_timeout_passed_during_the_exit(rig):
    """Drive b missed two ticks just before deactivate: its answer to the first exit frame may be
    one of those late replies, but once exchange_timeout has passed since they were sent they are
    lost and b's answer to the second frame counts — two frames, not three (catches the lost
    replies not written off between attempts)."""
    r = rig(exchange_timeout=0.3)
    r.activate()
    r.tick()
    r.drive_list[1].faults.silent = True
    r.tick()
    r.tick()
    r.tick()  # b missed two ticks' commands, the owed replies given up on at each write
    r.drive_list[1].faults.silent = False
    r.read(r.now)
    before = exit_frames(r.drive_list[1])
    r.deactivate()
    assert exit_frames(r.drive_list[1]) - before <= 2


def test_a_spare_reply_does_not_make_a_late_reply_the_answer_to_exit_motor_mode(rig):
    """Drive b's reply came twice one tick; later the drives fall silent behind a held wire and
    their late replies to the last commands arrive during deactivate: neither drive answered
    exit motor mode, and the error names both (catches a spare copy counted as a reply heard
    beyond the frames sent)."""
    r = rig(cls=SlowRig)
    r.activate()
    r.tick()
    r.read(r.now)
    r.write(r.now)
    r.peer.send(can.Message(arbitration_id=r.master_id, data=pack_reply(KATZ, 2, 0.0, 0.0, 0.0),
                            is_extended_id=False))  # b's answer, received twice
    r.read(r.now)
    assert r.counters["extra_replies"] == 1
    r.hold = True
    r.write(r.now)  # the answers to these commands are held back …
    r.read(r.now)
    pump(r.drives, r.peer, now=r.now)  # … and arrive now, late; exit motor mode is never answered
    r.deactivate()  # never raises: the failure is the device's last error
    r.hold = False
    assert "drive(s) 0x1, 0x2 did not answer exit motor mode" in r.last_error


def test_a_frame_that_is_no_reply_does_not_answer_exit_for_a_drive_that_said_motor_on(rig):
    """Damiao drives: b answers exit motor mode with the motor still on, then a foreign frame
    carrying a motor-off reply arrives: b has not answered (catches the ignored frame's row −1
    read as the last row)."""
    from drivers.protocols.mit import DRIVE_MODELS

    dm = DRIVE_MODELS["dm4310"]
    r = rig([MitJoint("a", 1, dm), MitJoint("b", 2, dm)], cls=SlowRig)
    r.activate()
    r.tick()
    r.read(r.now)
    r.hold = True
    for frame in (pack_reply(dm, 1, 0.0, 0.0, 0.0, enabled=False), pack_reply(dm, 2, 0.0, 0.0, 0.0, enabled=True)):
        r.peer.send(can.Message(arbitration_id=r.master_id, data=frame, is_extended_id=False))
    r.peer.send(can.Message(arbitration_id=0x123, data=pack_reply(dm, 2, 0.0, 0.0, 0.0, enabled=False),
                            is_extended_id=False))
    r.deactivate()  # never raises: the failure is the device's last error
    r.hold = False
    assert "drive(s) 0x2 answered exit motor mode with the motor on" in r.last_error
    assert "0x1" not in r.last_error


def test_a_drive_that_first_says_motor_on_then_off_has_answered_with_the_first_frame(rig):
    """Damiao drives: b's first reply to exit motor mode says the motor is on, its next says off
    (within the same wait): every drive has answered, so no second exit frame goes out (catches
    a motor-on reply counted as one more answer awaited)."""
    from drivers.protocols.mit import DRIVE_MODELS

    dm = DRIVE_MODELS["dm4310"]
    r = rig([MitJoint("a", 1, dm), MitJoint("b", 2, dm)], cls=SlowRig)
    r.activate()
    r.tick()
    r.read(r.now)
    r.hold = True
    for drive_id, on in ((1, False), (2, True), (2, False)):
        r.peer.send(can.Message(arbitration_id=r.master_id, data=pack_reply(dm, drive_id, 0.0, 0.0, 0.0, enabled=on),
                                is_extended_id=False))
    r.deactivate()
    assert r.last_error is None or "exit motor mode" not in r.last_error
    assert pump(r.drives, r.peer, now=r.now) == 2  # one exit frame per drive on the wire
    r.hold = False


def test_over_slcan_a_late_reply_is_still_taken_before_the_next_commands(rig):
    """Over slcan (acknowledgements, and an empty read waits out the serial timeout) a late
    reply must still be taken before the next commands go out, or it answers them and every
    state after is a period old."""
    r = rig(cls=SlowRig)
    r.activate()
    as_over_slcan(r)
    r.tick()
    r.hold = True
    r.tick()  # these commands' answers are held back …
    r.hold = False
    r.now += 0.001
    assert r.read(r.now) == Status.OK and not r.state.fresh.any()  # … past this read's deadline
    r.q[:] = 0.1
    pump(r.drives, r.peer, now=r.now)  # … and arrive before this tick's write: late
    r.q[:] = 0.3
    r.write(r.now)
    seen = []
    for where in (0.5, 0.7):
        r.q[:] = where
        assert r.tick() == (Status.OK, Status.OK)
        seen.append((r.state.position.round(3).tolist(), r.state.fresh.tolist()))
    assert seen == [([x, x], [True, True]) for x in (0.3, 0.5)]
    assert r.counters["late_replies"] == 2


@pytest.mark.parametrize("later, frames", [(0.25, [2, 2]), (0.25 + 2**-20, [1, 1]), (0.35, [1, 1])],
                         ids=["at", "just-past", "long-ago"])
def test_a_reply_given_up_on_is_owed_until_more_than_exchange_timeout_passed(rig, monkeypatch, later, frames):
    """Drive b missed one tick before deactivate. exchange_timeout bounds a reply's lateness,
    inclusively: at exactly that time after the give-up b's missing reply may still come, so
    its answer to the first exit frame is taken for it and a second frame goes out (to every
    drive); any later that reply is lost (the driver's docstring) and one frame does (catches
    the owed replies forgotten at every write, which made every tick a fresh give-up).
    The driver's own clock is a fake one here (0.25 s and 100 s are exact in binary)."""
    from drivers import can_joints

    clock = [100.0]
    monkeypatch.setattr(can_joints, "time", SimpleNamespace(monotonic=lambda: clock[0]))
    r = rig(exchange_timeout=0.25)
    r.activate()
    r.tick()
    r.drive_list[1].faults.silent = True
    r.tick()
    r.read(r.now)  # b's reply is missing …
    r.drive_list[1].faults.silent = False
    r.write(r.now)  # … and given up on here, at 100 s
    clock[0] += later
    for _ in range(3):
        assert r.tick() == (Status.OK, Status.OK)
    r.read(r.now)
    before = [exit_frames(d) for d in r.drive_list]
    r.deactivate()
    assert [exit_frames(d) - b for d, b in zip(r.drive_list, before)] == frames
