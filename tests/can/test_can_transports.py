"""Back-to-back: the same MIT exchanges on every CAN transport available (virtual in lock-step,
socketcand over loopback TCP, slcan over a pty, socketcan/vcan where the kernel has AF_CAN)."""
import time

import pytest

from drivers.protocols import mit
from drivers.protocols.mit import KATZ, Special
from rtctl.errors import ProtocolError

P_LSB = 25 / 65535
T_LSB = 36 / 4095


def decode(frames):
    """{drive id: MitReply} for frames on the master id; fails on a duplicate."""
    replies = {}
    for f in frames:
        assert f.arbitration_id == mit.DEFAULT_MASTER_ID and not f.is_extended_id
        r = mit.unpack_reply(f.data, KATZ)
        assert r.drive_id not in replies, f"two replies from drive {r.drive_id}"
        replies[r.drive_id] = r
    return replies


class TestMitBackToBack:
    def test_enter_motor_mode_is_answered(self, link):
        replies = decode(link.enter_all())
        assert sorted(replies) == link.ids
        assert all(link.drives.drives[i].enabled for i in link.ids)
        assert link.quiet()

    def test_command_gets_exactly_one_reply_with_the_drive_state(self, link):
        link.enter_all()
        for i in link.ids:  # park each joint at its own position (no torque, no motion)
            link.drives.drives[i].port.position = 0.1 * i
        frames = [(i, mit.pack_command(KATZ, 0.0, 0.0, 0.0, 0.0, 0.5 * i - 1.0)) for i in link.ids]
        replies = decode(link.exchange(frames))
        assert sorted(replies) == link.ids
        assert link.quiet()
        for i in link.ids:
            drive = link.drives.drives[i]
            assert drive.counters.commands == 1
            # the drive applied the decoded feed-forward torque (kp = kd = 0) …
            assert drive.command.t == pytest.approx(0.5 * i - 1.0, abs=T_LSB)
            # … and reported its position and that torque, each truncated once more
            assert 0 <= 0.1 * i - replies[i].position <= P_LSB
            assert replies[i].effort == pytest.approx(0.5 * i - 1.0, abs=2 * T_LSB)
            assert replies[i].velocity == pytest.approx(0.0, abs=130 / 4095)

    def test_joint_command_reply_cycles(self, link):
        link.enter_all()
        cycles = 20
        for k in range(cycles):
            frames = [(i, mit.pack_command(KATZ, 0.01 * k, 0.0, 5.0, 0.5, 0.0)) for i in link.ids]
            replies = decode(link.exchange(frames))
            assert sorted(replies) == link.ids, f"cycle {k}"
        assert link.quiet()
        assert [link.drives.drives[i].counters.commands for i in link.ids] == [cycles] * len(link.ids)
        assert [link.drives.drives[i].counters.replies for i in link.ids] == [cycles + 1] * len(link.ids)

    def test_special_frames_are_answered(self, link):
        i = link.ids[-1]
        drive = link.drives.drives[i]
        drive.port.position = 1.0
        (r,) = decode(link.exchange([(i, mit.special_frame(Special.SET_ZERO))])).values()
        assert abs(r.position) <= P_LSB and drive.zero_offset == 1.0
        link.exchange([(i, mit.special_frame(Special.ENTER_MOTOR_MODE))])
        assert drive.enabled
        assert len(link.exchange([(i, mit.special_frame(Special.EXIT_MOTOR_MODE))])) == 1
        assert not drive.enabled
        drive.set_error(3)
        assert len(link.exchange([(i, mit.special_frame(Special.CLEAR_ERROR))])) == 1
        assert drive.error_code == 0
        assert drive.counters.specials == 4 and link.quiet()

    def test_corrupted_frames_are_ignored_and_counted(self, link):
        i = link.ids[0]
        drive = link.drives.drives[i]
        link.enter_all()
        link.send(i, b"\x7f\xff\x7f\xf0\x00")  # truncated command
        link.send(i, bytes.fromhex("FF FF FF FF FF FF FF 00"))  # unknown special frame
        assert link.quiet()
        assert drive.counters.malformed == 2
        assert len(link.exchange([(i, mit.pack_command(KATZ, 0, 0, 0, 0, 0))])) == 1  # still alive

        drive.faults.corrupt_rate = 1.0  # the other direction: a malformed reply reaches the master
        (frame,) = link.exchange([(i, mit.pack_command(KATZ, 0, 0, 0, 0, 0))])
        with pytest.raises(ProtocolError):
            mit.reply_drive_id(frame.data, KATZ)
        assert drive.counters.corrupted == 1

    def test_drive_watchdog_turns_the_motor_off(self, link):
        i = link.ids[0]
        drive = link.drives.drives[i]
        drive.timeout_s = 0.020
        link.enter_all()
        deadline = time.monotonic() + 5.0  # bounds a failure only; the drive trips 20 ms after
        while drive.enabled and time.monotonic() < deadline:
            link.quiet(0.01)  # no command: the drive's watchdog must fire (lock-step: on the next pump)
        assert not drive.enabled and drive.counters.watchdog_trips == 1 and drive.torque == 0.0
        assert all(link.drives.drives[j].enabled for j in link.ids[1:])  # the others keep their long timeout
