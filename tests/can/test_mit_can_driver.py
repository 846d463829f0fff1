"""The mit_can driver in-process: the real driver on a python-can virtual bus, emulated drives
(hil_sim.mit_drive) on the far end, pumped right after each send, on a clock the test owns."""
import threading
import time

import can
import numpy as np
import pytest

from drivers.can_joints import MitCanJointGroup
from drivers.protocols.mit import DRIVE_MODELS, KATZ, Special, special_kind
from drivers.protocols.mit_layout import MitJoint
from hil_sim.mit_drive import MitDrive, MitDriveBus, pump
from lockstep_rig import LockStep, SlowWire, as_over_slcan, rigs, silence_second_drive, virtual_bus
from rtctl.errors import HardwareError
from rtctl.hal import CommandMode, Status

P_LSB, V_LSB, T_LSB = 25 / 65535, 130 / 4095, 36 / 4095


class Rig(LockStep, MitCanJointGroup):
    def __init__(self, joints, **kw):
        kw = {"reply_deadline": 0.0, "exchange_timeout": 0.0, "period": 0.001, **kw}
        super().__init__("arm", joints, virtual_bus(), **kw)
        self._attach(lambda j, port: MitDrive(j.drive_id, port, j.model), MitDriveBus)


@pytest.fixture
def rig():
    def make(joints=None, **kw):
        return Rig(joints or [MitJoint("a", 1, KATZ), MitJoint("b", 2, KATZ)], **kw)

    yield from rigs(make)


def test_configure_reads_the_state_without_enabling_any_drive(rig):
    r = rig()
    r.q[:] = [0.3, -0.2]
    r.qd[:] = [1.0, -2.0]
    r.configure()
    assert r.read(0.0) == Status.OK
    assert np.all(r.state.fresh)
    assert np.all(np.abs(r.state.position - r.q) <= P_LSB)
    assert np.all(np.abs(r.state.velocity - r.qd) <= V_LSB)
    assert not any(d.enabled for d in r.drive_list) and all(d.counters.specials == 1 for d in r.drive_list)


def test_torque_mode_sends_zero_gains_and_the_torque(rig):
    r = rig()
    r.activate()
    assert all(d.enabled for d in r.drive_list)
    r.command.mode = CommandMode.TORQUE
    r.command.kp[:] = 99.0  # ignored in torque mode
    r.command.tau_ff[:] = [5.0, -3.0]
    assert r.tick() == (Status.OK, Status.OK)
    for d, tau in zip(r.drive_list, (5.0, -3.0)):
        assert d.command.kp == 0.0 and d.command.kd == 0.0
        assert d.command.t == pytest.approx(tau, abs=T_LSB)
    assert r.tau == pytest.approx([5.0, -3.0], abs=T_LSB)


def test_impedance_through_a_reversed_mount_with_an_offset(rig):
    r = rig([MitJoint("a", 1, KATZ, direction=-1.0, offset=0.5)])
    r.q[:] = 0.1
    r.activate()
    c = r.command
    c.mode = CommandMode.IMPEDANCE
    c.q_des[:], c.qd_des[:], c.kp[:], c.kd[:], c.tau_ff[:] = 0.2, 0.1, 50.0, 2.0, 1.0
    r.tick()
    d = r.drive_list[0]
    assert d.command.p == pytest.approx(-(0.2 - 0.5), abs=P_LSB)  # drive frame: −(q − offset)
    assert d.command.v == pytest.approx(-0.1, abs=V_LSB)
    assert d.command.t == pytest.approx(-1.0, abs=T_LSB)
    # the torque on the joint is the joint-space law kp (q_des − q) + kd (qd_des − qd) + τ
    assert r.tau[0] == pytest.approx(50.0 * (0.2 - 0.1) + 2.0 * 0.1 + 1.0, abs=50 * P_LSB + 2 * V_LSB + T_LSB)
    r.read(r.now)
    assert r.state.position[0] == pytest.approx(0.1, abs=P_LSB)


def test_a_reversed_mount_reads_position_velocity_and_effort_in_the_joint_frame(rig):
    r = rig([MitJoint("a", 1, KATZ, direction=-1.0, offset=0.5), MitJoint("b", 2, KATZ)])
    r.q[:], r.qd[:] = [0.1, 0.1], [0.7, 0.7]
    r.activate()
    r.command.tau_ff[:] = [2.0, 2.0]
    r.tick()
    r.read(r.now)
    s = r.state
    assert s.position == pytest.approx([0.1, 0.1], abs=P_LSB)
    assert s.velocity == pytest.approx([0.7, 0.7], abs=V_LSB)  # not −0.7 on the reversed joint
    assert s.effort == pytest.approx([2.0, 2.0], abs=T_LSB)
    d = r.drive_list[0]
    assert d.port.get_position() == pytest.approx(-(0.1 - 0.5)) and d.port.get_velocity() == pytest.approx(-0.7)


class LateRig(Rig):
    """The drives answer ``delay`` s after each command, from another thread (as a real bus does)."""

    delay = 0.0

    def _after_send(self):
        threading.Timer(self.delay, pump, (self.drives, self.peer), {"now": self.now}).start()


@pytest.mark.parametrize("delay, missing", [(0.002, 0), (0.3, 1)])
def test_replies_are_awaited_for_the_reply_deadline_as_a_fraction_of_the_period(delay, missing):
    # 20 Hz, reply_deadline 0.6: a reply is awaited for 30 ms — one 2 ms late is in time, one 300 ms late is not
    r = LateRig([MitJoint("a", 1, KATZ)], reply_deadline=0.6, period=0.05, exchange_timeout=1.0)
    try:
        r.delay = 0.0
        r.activate()
        r.delay = delay
        r.write(r.now)
        assert r.counters["missing_replies"] == 0  # write() sends and returns: nothing awaited yet
        r.read(r.now)  # collects the answers, waiting until their deadline
        assert r.counters["missing_replies"] == missing
    finally:
        time.sleep(0.35)  # the late reply's timer has fired
        r.delay = 0.0
        r.close()
        time.sleep(0.05)  # and so has the answer to exit motor mode
        r.peer.shutdown()


def test_a_missing_reply_is_stale_and_the_stale_limit_is_an_error(rig):
    r = rig()
    # the reply of the silencing tick's commands is missing at the next read: stale 1, 2, 3 → ERROR
    assert silence_second_drive(r) == [Status.OK, Status.OK, Status.OK, Status.ERROR]
    assert r.counters["missing_replies"] == 3 and "drive(s) 0x2 " in r.last_error  # only the silent one
    r.drive_list[1].faults.silent = False
    r.tick()
    assert r.tick()[0] == Status.OK and np.all(r.state.fresh)


def test_a_pause_longer_than_the_drives_watchdog_is_their_stop(rig):
    r = rig(drive_timeout=0.02)
    r.activate()
    r.tick()
    r.now += 0.05  # the loop froze for 50 ms; the drives' time went on
    r.drives.service(r.now, [])
    read, write = r.tick()
    assert write == Status.DEACTIVATE
    assert not any(d.enabled for d in r.drive_list) and all(d.counters.watchdog_trips == 1 for d in r.drive_list)
    assert r.tick()[0] == Status.DEACTIVATE  # until activated again
    r.deactivate()
    r.activate()
    assert r.tick() == (Status.OK, Status.OK) and r.state.fresh.all()  # the answers to enter motor mode
    assert r.tick() == (Status.OK, Status.OK) and r.state.fresh.all() and r.counters["missing_replies"] == 0


def test_set_zero_is_refused_while_active(rig):
    r = rig()
    r.q[:] = [0.4, 0.0]
    r.configure()
    r.set_zero()
    assert r.drive_list[0].zero_offset == 0.4
    r.activate()
    with pytest.raises(HardwareError, match="not active"):
        r.set_zero()


def test_a_bus_error_is_an_error_then_reconnects_and_deactivate_always_turns_the_drives_off(rig):
    r = rig(reconnect_interval=1e-6)
    r.activate()
    r.tick()
    r.read(r.now)
    r.bus.shutdown()  # the link breaks under the driver
    assert r.write(r.now) == Status.ERROR and r.bus is None and r.counters["bus_errors"] == 1
    assert r.read(r.now) == Status.ERROR and not r.state.fresh.any()
    assert r.write(r.now) == Status.OK and r.counters["reconnects"] == 1  # reopened, drives still on
    r.bus.shutdown()
    r.write(r.now)
    r.deactivate()  # reopens once to say exit motor mode
    assert not any(d.enabled for d in r.drive_list)
    assert [e["event"] for e in r.events] == ["bus_lost", "bus_back", "bus_lost"]


def test_malformed_and_foreign_frames_are_counted_and_ignored(rig):
    r = rig()
    r.activate()
    r.peer.send(can.Message(arbitration_id=0, data=b"\x01\x02\x03", is_extended_id=False))  # truncated reply
    r.peer.send(can.Message(arbitration_id=0x123, data=b"\x00" * 8, is_extended_id=False))  # another id
    r.peer.send(can.Message(arbitration_id=0, data=bytes([0x77, 0, 0, 0, 0, 0]), is_extended_id=False))  # unknown drive
    assert r.tick() == (Status.OK, Status.OK)
    assert r.tick() == (Status.OK, Status.OK) and np.all(r.state.fresh)  # collected with the answers
    assert r.counters["malformed_replies"] == 2 and r.counters["foreign_frames"] == 1


def test_a_drive_error_code_is_reported_per_joint(rig):
    r = rig([MitJoint("a", 1, DRIVE_MODELS["dm4310"]), MitJoint("b", 2, DRIVE_MODELS["dm4310"])])
    r.activate()
    r.tick()
    r.drive_list[1].set_error(0xA)  # Damiao: state ≥ 8 in the reply's high nibble is an error
    r.tick()
    assert [r.tick()[0] for _ in range(3)] == [Status.ERROR] * 3
    assert list(r.state.fault) == [0, 0xA]
    assert [e["event"] for e in r.events].count("drive_error") == 1  # one event per episode


def test_a_failed_configure_leaves_the_bus_closed(rig):
    r = rig()
    r.drive_list[0].faults.silent = True
    with pytest.raises(HardwareError, match="0x1.*exit motor mode"):
        r.configure()
    assert r.bus is None


def test_enter_motor_mode_must_be_answered_by_every_drive(rig):
    r = rig()
    r.configure()
    r.drive_list[0].faults.silent = True
    with pytest.raises(HardwareError, match="0x1.*enter motor mode"):
        r.activate()
    assert not r.drive_list[1].enabled  # the one that answered was turned off again


def test_a_long_stale_episode_is_logged_once_even_with_a_full_event_list(rig):
    from structlog.testing import capture_logs

    r = rig()
    r.activate()
    r.tick()
    r.events.extend({"event": "bus_back"} for _ in range(100))  # the kept-events list is full
    with capture_logs() as logs:
        r.drive_list[1].faults.silent = True
        for _ in range(20):
            r.tick()
        r.drive_list[1].faults.silent = False
        for _ in range(3):
            r.tick()
        r.drive_list[1].faults.silent = True
        for _ in range(20):
            r.tick()
    stale = [e for e in logs if e["event"] == "stale"]
    assert len(stale) == 2  # one per episode, not one per tick


def test_the_stale_count_starts_afresh_at_activation(rig):
    r = rig()
    r.activate()
    r.drive_list[1].faults.silent = True  # dead from the first tick on: the limit (3) counts from here
    assert [r.tick()[0] for _ in range(4)] == [Status.OK, Status.OK, Status.OK, Status.ERROR]


def test_exit_motor_mode_is_sent_three_times_before_deactivate_gives_up(rig):
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[1].faults.drop_rate = 1.0  # it hears every exit; its answers are lost
    before = [d.counters.specials for d in r.drive_list]
    r.deactivate()  # never raises: the failure is the device's last error
    assert [d.counters.specials - b for d, b in zip(r.drive_list, before)] == [3, 3]
    assert "0x2" in r.last_error and "exit motor mode" in r.last_error


class SlowRig(SlowWire, Rig):
    pass


@pytest.fixture
def slow_rig():
    yield from rigs(lambda: SlowRig([MitJoint("a", 1, KATZ), MitJoint("b", 2, KATZ)]))


def test_a_late_reply_is_not_the_next_ticks_answer_so_the_measurement_stays_one_period_old(slow_rig):
    """A reply that missed its deadline is in the buffer when the next collection starts. Taken
    as that collection's answer, it ended the wait before the real answer, which then missed its
    own tick: from one stall on, every state was a period older than the driver says, and marked
    fresh (over socketcand the ARMA/GMV loop identified that delay and rang)."""
    r = slow_rig()
    r.activate()
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
    for where in (0.5, 0.7, 0.9):  # the joints' position when each tick's commands arrive
        r.q[:] = where
        assert r.tick() == (Status.OK, Status.OK)
        seen.append((r.state.position.round(3).tolist(), r.state.fresh.tolist()))
    # each read publishes the answers to the previous tick's commands, fresh
    assert seen == [([x, x], [True, True]) for x in (0.3, 0.5, 0.7)]
    assert r.counters["missing_replies"] == 2 and r.counters["late_replies"] == 2  # the stalled tick's, once


def test_a_reply_received_twice_is_no_later_ticks_answer_so_the_measurement_stays_one_period_old(rig):
    """A reply received twice (CAN's double reception, a replaying node): the spare copy, still
    in the buffer when the collection had every answer, was the next collection's answer and
    left the real one behind in its turn — from then on that joint's state was a period older
    than the driver says, marked fresh, and a drive that fell silent read fresh one tick more
    (found by the driver-boundary fuzzing, tests/hardening/test_driver_boundaries.py)."""
    from drivers.protocols.mit import pack_reply

    r = rig()
    r.activate()
    r.q[:] = 0.1
    r.tick()  # the drives answer these commands with 0.1 …
    r.peer.send(can.Message(arbitration_id=r.master_id, data=pack_reply(KATZ, 2, 0.1, 0.0, 0.0),
                            is_extended_id=False))  # … and drive 2's answer comes twice
    seen = []
    for where in (0.3, 0.5, 0.7):  # the joints' position when each tick's commands arrive
        r.q[:] = where
        assert r.tick() == (Status.OK, Status.OK)
        seen.append((r.state.position.round(3).tolist(), r.state.fresh.tolist()))
    # each read publishes the answers to the previous tick's commands, fresh
    assert seen == [([x, x], [True, True]) for x in (0.1, 0.3, 0.5)]
    assert r.counters["extra_replies"] == 1 and r.counters["late_replies"] == 0
    r.drive_list[1].faults.silent = True
    r.tick()  # drive 2 does not answer these commands: not fresh at the next read
    r.tick()
    assert r.state.fresh.tolist() == [True, False]


@pytest.mark.parametrize("over_slcan", [False, True], ids=["virtual", "slcan"])
def test_a_copy_received_between_a_collection_and_the_next_commands_answers_nothing(rig, over_slcan):
    """A copy of drive 2's reply that arrives after the collection's drain and before the next
    commands go out: taken as the answer to those commands, drive 2 read fresh at the old
    position although it never answered them. Every write now takes what arrived before it;
    over slcan the port's count of bytes waiting says one is there."""
    from drivers.protocols.mit import pack_reply

    r = rig()
    r.activate()
    if over_slcan:
        as_over_slcan(r)
    r.q[:] = 0.1
    r.tick()
    r.now += 0.001
    assert r.read(r.now) == Status.OK and r.state.fresh.all()  # the answers with 0.1
    r.peer.send(can.Message(arbitration_id=r.master_id, data=pack_reply(KATZ, 2, 0.1, 0.0, 0.0),
                            is_extended_id=False))  # drive 2's answer once more
    r.drive_list[1].faults.silent = True  # … and then drive 2 answers nothing
    r.q[:] = 0.3
    r.write(r.now)
    r.now += 0.001
    r.read(r.now)
    assert r.state.fresh.tolist() == [True, False] and r.state.position[0] == pytest.approx(0.3, abs=0.01)
    assert r.counters["missing_replies"] == 1 and r.counters["extra_replies"] == 1


def test_over_slcan_an_empty_port_is_not_read_before_the_commands(rig, monkeypatch):
    """An empty read over slcan waits out the serial timeout: with no byte waiting and every
    answer in, the write sends without reading."""
    r = rig()
    r.activate()
    as_over_slcan(r)
    r.tick()
    r.now += 0.001
    assert r.read(r.now) == Status.OK and r.state.fresh.all()
    reads = []
    recv = r.bus.recv
    monkeypatch.setattr(r.bus, "recv", lambda timeout=None: reads.append(timeout) or recv(timeout))
    assert r.write(r.now) == Status.OK and reads == []


def test_a_reply_later_than_the_next_commands_is_not_their_answer_so_the_measurement_stays_one_period_old(slow_rig):
    """A reply so late that it arrives after the next commands went out (the write found nothing
    to drain) was that collection's answer, and the real one was left in the buffer to answer
    the tick after: from then on every state was a period older than the driver says, marked
    fresh — and, taking a spare reply at once, the collection no longer waited for, nor missed,
    a real one (`rtctl bench can` over socketcand under load: up to 588 spare replies a run)."""
    r = slow_rig()
    r.activate()
    r.tick()
    r.hold = True
    r.tick()  # these commands' answers are held back …
    r.now += 0.001
    assert r.read(r.now) == Status.OK and not r.state.fresh.any()  # … past this read's deadline
    r.write(r.now)  # … and past this write: the next commands go out
    r.q[:] = 0.1
    pump(r.drives, r.peer, now=r.now)  # both commands' answers arrive now, the late ones first
    r.hold = False
    seen = []
    for where in (0.3, 0.5, 0.7):  # the joints' position when each tick's commands arrive
        r.q[:] = where
        assert r.tick() == (Status.OK, Status.OK)
        seen.append((r.state.position.round(3).tolist(), r.state.fresh.tolist()))
    assert seen == [([x, x], [True, True]) for x in (0.1, 0.3, 0.5)]
    assert r.counters["extra_replies"] == 2


def test_a_late_reply_to_a_command_is_not_the_answer_to_exit_motor_mode(slow_rig):
    r = slow_rig()
    r.activate()
    r.tick()
    r.hold = True
    r.tick()  # this command's replies miss the tick …
    pump(r.drives, r.peer, now=r.now)  # … and are on their way when deactivate begins
    for d in r.drive_list:
        d.faults.silent = True  # nothing more reaches the drives: exit motor mode is lost
    r.hold = False
    r.deactivate()
    assert all(d.enabled for d in r.drive_list)
    assert "did not answer exit motor mode" in r.last_error and "0x1, 0x2" in r.last_error


def test_exit_motor_mode_is_confirmed_by_the_answer_after_the_late_ones(slow_rig):
    r = slow_rig()
    r.activate()
    r.tick()
    r.hold = True
    r.tick()  # unanswered: the drives answer it first, then exit motor mode
    r.hold = False
    r.deactivate()
    assert not any(d.enabled for d in r.drive_list) and r.last_error is None
    assert [d.counters.specials for d in r.drive_list] == [3, 3]  # exit, enter, exit: once each


def test_a_reply_lost_once_costs_one_more_exit_not_a_failed_one(slow_rig):
    r = slow_rig()
    r.activate()
    r.drive_list[1].faults.drop_rate = 1.0
    r.tick()  # drive 2's reply is lost for good
    r.drive_list[1].faults.drop_rate = 0.0
    r.deactivate()
    assert not any(d.enabled for d in r.drive_list) and r.last_error is None
    assert [d.counters.specials for d in r.drive_list] == [4, 4]  # the first exit's answer was taken for the lost one


class ExitLostRig(SlowRig):
    """While ``lose_exits``, every exit motor mode frame is lost on the wire: those drives hear
    the rest, in order, and answer it."""

    lose_exits = False

    def _after_send(self):
        if self.hold:
            return
        out = []
        while (msg := self.peer.recv(0.0)) is not None:
            if not (self.lose_exits and special_kind(msg.data) is Special.EXIT_MOTOR_MODE):
                self.drives.receive(msg.arbitration_id, msg.data, self.now, out)
        for arbitration_id, payload in out:
            self.peer.send(can.Message(arbitration_id=arbitration_id, data=payload, is_extended_id=False))


@pytest.fixture
def exit_rig():
    # replies may be late by up to exchange_timeout (real time): long enough for the test's own steps
    yield from rigs(lambda model=KATZ: ExitLostRig([MitJoint("a", 1, model), MitJoint("b", 2, model)],
                                                   exchange_timeout=0.05))


def stall_the_last_two_ticks(r):
    """A tick's replies held back: its read misses them, the next write gives up on them (late
    or lost) and sends its own commands, whose replies are held back too — both are on their
    way when deactivate begins, and arrive just after its first exit frame went out."""
    r.activate()
    r.tick()
    r.hold = True
    r.tick()
    assert r.tick()[0] == Status.OK and not r.state.fresh.any() and r.counters["missing_replies"] == 2
    r.hold = False


def test_a_late_reply_given_up_on_is_not_the_answer_to_exit_motor_mode(exit_rig):
    """The defect: the reply the last write gave up on arrived after the exit frame and counted
    as the answer owed for the last commands, whose own reply then counted as the answer to exit
    motor mode — "confirmed off" while no drive had heard it."""
    r = exit_rig()
    stall_the_last_two_ticks(r)
    r.lose_exits = True
    assert r.deactivate() is False
    assert all(d.enabled and d.counters.specials == 2 for d in r.drive_list)  # configure's exit, enter
    assert "0x1, 0x2 did not answer exit motor mode" in r.last_error


def test_exit_motor_mode_is_confirmed_by_the_answer_after_replies_given_up_on(exit_rig):
    r = exit_rig()
    stall_the_last_two_ticks(r)
    assert r.deactivate() is True and r.last_error is None
    assert not any(d.enabled for d in r.drive_list)
    assert [d.counters.specials for d in r.drive_list] == [3, 3]  # one exit: its answer came third


@pytest.mark.parametrize("lost_before_s, exits", [(0.0, 2), (0.1, 1)])
def test_a_lost_reply_costs_a_second_exit_only_within_the_lateness_bound(exit_rig, lost_before_s, exits):
    # drive 2's reply lost for good: within exchange_timeout (0.05 s) it may still come, so the
    # answer to the first exit cannot be told from it — a second exit, once the bound passed;
    # lost longer ago than that, it is no longer awaited
    r = exit_rig()
    r.activate()
    r.drive_list[1].faults.drop_rate = 1.0
    r.tick()
    r.drive_list[1].faults.drop_rate = 0.0
    r.tick()  # gives up on it
    time.sleep(lost_before_s)
    assert r.deactivate() is True and not any(d.enabled for d in r.drive_list)
    assert [d.counters.specials for d in r.drive_list] == [2 + exits] * 2


def test_a_damiao_drive_answering_exit_with_its_motor_on_is_not_confirmed_off(exit_rig):
    # the Damiao reply says whether the motor is on: an answer that says on is no confirmation
    r = exit_rig(DRIVE_MODELS["dm4310"])
    r.activate()
    r.tick()
    stuck = r.drive_list[1]
    stuck._special = lambda kind, now: None  # it answers every mode frame and ignores it
    assert r.deactivate() is False
    assert not r.drive_list[0].enabled and stuck.enabled and stuck.counters.specials == 2 + 3
    assert "0x2 answered exit motor mode with the motor on" in r.last_error


def test_torque_mode_zeroes_the_targets_as_well_as_the_gains(rig):
    r = rig()
    r.activate()
    r.command.mode = CommandMode.TORQUE
    r.command.q_des[:], r.command.qd_des[:] = 1.0, 2.0  # ignored in torque mode
    r.tick()
    for d in r.drive_list:
        assert abs(d.command.p) <= P_LSB and abs(d.command.v) <= V_LSB


def test_error_frames_and_empty_frames_on_the_master_id_are_counted_and_ignored(rig):
    r = rig()
    r.activate()
    r.peer.send(can.Message(arbitration_id=0, is_error_frame=True))
    r.peer.send(can.Message(arbitration_id=0, data=b"", is_extended_id=False))
    assert r.tick() == (Status.OK, Status.OK)
    assert r.read(r.now) == Status.OK and r.state.fresh.all()  # collected with the tick's answers
    assert r.counters["error_frames"] == 1 and r.counters["foreign_frames"] == 1


@pytest.mark.parametrize("frame, counter", [
    (can.Message(arbitration_id=0, data=b"\x01\x02\x03", is_extended_id=False), "malformed_replies"),  # truncated
    (can.Message(arbitration_id=0x123, data=b"\x01" + bytes(5), is_extended_id=False), "foreign_frames"),
    (can.Message(arbitration_id=0, data=b"\x01" + bytes(5), is_error_frame=True), "error_frames"),
])
def test_a_malformed_foreign_or_error_frame_is_no_drives_answer(rig, frame, counter):
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[0].faults.silent = True
    for _ in range(3):  # such a frame each tick, while drive 1 says nothing
        r.peer.send(frame)
        r.tick()
    r.read(r.now)  # the last tick's answers
    assert r.counters["missing_replies"] == 3 and r.counters[counter] == 3


def test_drive_id_0xff_is_a_drive_like_any_other(rig):
    r = rig([MitJoint("a", 0xFF, KATZ), MitJoint("b", 2, KATZ)])
    r.activate()
    assert r.tick() == (Status.OK, Status.OK) and np.all(r.state.fresh)


def test_an_activation_on_a_broken_link_fails_as_a_bus_error(rig):
    r = rig()
    r.configure()
    r.bus.shutdown()  # the link breaks between configure and activate
    with pytest.raises(HardwareError, match="enter motor mode: bus error"):
        r.activate()  # and the exit it then sends to leave no drive enabled cannot hide that
    assert not any(d.enabled for d in r.drive_list)


@pytest.mark.parametrize("model", [KATZ, DRIVE_MODELS["ak80-9"], DRIVE_MODELS["dm4310"]], ids=lambda m: m.name)
def test_a_joint_at_rest_at_zero_reads_zero_not_half_a_step_below(rig, model):
    # the firmware truncates (x − x_min)·(2^bits − 1)/span: with symmetric ranges a still,
    # unloaded joint at 0 sends codes 2^15 − 1 and 2^11 − 1, which decode to −½ step each;
    # the interval's centre is the unbiased reading — for position, velocity and effort
    r = rig([MitJoint("a", 1, model), MitJoint("b", 2, model)])
    r.q[:], r.qd[:] = [0.0, 0.0], [0.0, 0.0]
    r.configure()
    assert r.read(0.0) == Status.OK
    for name in ("position", "velocity", "effort"):
        reading = getattr(r.state, name)
        assert np.all(np.abs(reading) < 1e-12), (name, reading)


@pytest.mark.parametrize("model", [KATZ, DRIVE_MODELS["ak80-9"], DRIVE_MODELS["dm4310"]], ids=lambda m: m.name)
def test_readings_are_within_half_a_step_either_side(rig, model):
    rng = np.random.default_rng(7)
    r = rig([MitJoint("a", 1, model), MitJoint("b", 2, model)])
    r.activate()
    for _ in range(50):
        r.q[:] = rng.uniform(*model.p, 2) * 0.99
        r.qd[:] = rng.uniform(*model.v, 2) * 0.99
        r.tick()
        assert r.read(r.now) == Status.OK
        assert np.all(np.abs(r.state.position - r.q) <= 0.5 * np.ptp(model.p) / 65535 * (1 + 1e-9))
        assert np.all(np.abs(r.state.velocity - r.qd) <= 0.5 * np.ptp(model.v) / 4095 * (1 + 1e-9))
