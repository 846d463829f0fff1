"""The serial leg board driver against the board firmware on a pty (in-process), and on
pyserial's loop:// (where it hears only its own commands)."""
import threading
import time

import numpy as np
import pytest

from drivers.leg_board import SerialLegBoard
from hil_sim.leg_plant import LegParams, LegPlant
from hil_sim.leg_serial import LegBoardServer
from rtctl.errors import HardwareError
from rtctl.hal import JointCommand, Status
from rtctl.safety import FaultKind, SafetyStage, Verdict
from rtctl.safety.faults import device_reason
from stalls import VmStall

PERIOD = 0.002


class ProxiedBoard(LegBoardServer):
    """The board firmware behind a proxy that can resend the board's last sensor frame instead of
    each new one (``replay``: the same sequence number again), or drop our commands (``deaf``)."""

    replay = False
    deaf = False
    last_frame = b""

    def _commands(self, count, now):
        if not self.deaf:
            super()._commands(count, now)

    def _reply(self):
        if self.replay and self.last_frame:
            self.pty.out += self.last_frame
            return
        before = len(self.pty.out)
        super()._reply()
        self.last_frame = bytes(self.pty.out[before:]) or self.last_frame


def _serve(period, realtime_factor=0.0, watchdog_s=0.05):
    plant = LegPlant(LegParams(angle_noise=0.0, load_noise=0.0))
    events = []
    server = ProxiedBoard(plant, period, realtime_factor=realtime_factor, emit=events.append, watchdog_s=watchdog_s)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    return server, thread, plant, events


# The lock-step tests step the plant per command, not by the clock; what does run on the clock —
# the board's watchdog and the driver's waits — gets 30 s, so a stall of this shared machine (one
# of a whole second was seen: the board woke 996 ms after a command) is no watchdog lock or
# timed-out write. The free-running test below keeps the board's 50 ms watchdog it is about.
STALL_PROOF = 30.0


@pytest.fixture
def board_on_pty():
    server, thread, plant, events = _serve(PERIOD, watchdog_s=STALL_PROOF)
    board = SerialLegBoard("board", ["hip", "knee", "ankle"], server.path, PERIOD, reply_deadline=5.0,
                           exchange_timeout=STALL_PROOF, write_timeout=STALL_PROOF)
    yield board, server, plant, events
    board.exchange_timeout = 0.05  # a board the test silenced never confirms the lock: not 3 × 30 s
    board.close()
    server.shutdown()
    thread.join(5)


@pytest.fixture
def free_running_board():
    period = 0.01
    server, thread, plant, events = _serve(period, realtime_factor=1.0)
    board = SerialLegBoard("board", ["hip", "knee", "ankle"], server.path, period, reply_deadline=0.9)
    yield board, server
    board.close()
    server.shutdown()
    thread.join(5)


def test_the_driver_exchanges_frames_with_the_board(board_on_pty):
    board, server, plant, events = board_on_pty
    board.configure()
    board.activate()
    for k in range(50):
        assert board.read(k * PERIOD) == Status.OK
        board.actions[:] = (3, 2)  # knee released, ankle increase
        assert board.write(k * PERIOD) == Status.OK
    assert board.read(1.0) == Status.OK and board.state.fresh.all()
    # the board's measurement of the step that answered our last command, to the codec's 1 mrad
    assert np.allclose(board.channels, plant.channels, atol=1e-3)
    assert np.allclose(board.state.position, plant.q, atol=1e-3)
    assert tuple(plant.actions) == (3, 2)
    assert board.decoder.counters["crc_errors"] == 0 and board.decoder.counters["lost_frames"] == 0
    board.deactivate()
    assert tuple(plant.actions) == (0, 0)  # both joints locked


def test_a_silent_board_leaves_the_joints_stale(board_on_pty):
    board, server, plant, events = board_on_pty
    board.configure()
    board.activate()
    assert board.read(0.0) == Status.OK and board.state.fresh.all()  # the frame configure waited for
    board.reply_timeout = 0.02
    server.silent = True
    board.write(0.0)
    assert board.read(0.0) == Status.OK and not board.state.fresh.any()  # the safety stage counts these


def test_deactivate_fails_when_the_board_never_reports_the_joints_locked(board_on_pty):
    board, server, plant, events = board_on_pty
    board.configure()
    board.activate()
    board.exchange_timeout = 0.05
    server.silent = True  # it hears the lock commands and applies them, but says nothing
    sent = board.counters["commands"]
    assert board.deactivate() is False
    assert board.counters["commands"] - sent == 3 and "did not report both joints locked" in board.last_error


def test_loop_url_hears_only_its_own_commands():
    board = SerialLegBoard("board", ["hip", "knee", "ankle"], "loop://", PERIOD, exchange_timeout=0.05)
    with pytest.raises(HardwareError, match="no sensor frame"):
        board.configure()
    assert board.decoder.counters["frames"] == 0  # its own 7-byte command echoed is no sensor frame


def test_a_port_that_does_not_take_the_command_frame_in_time_is_a_hardware_error_naming_it():
    """pyserial's loop:// refuses a write that its baud rate cannot send within the write
    timeout: 7 bytes at 300 baud take 0.23 s, more than 0.1 s. The error names the device, the
    port and the bound, and the port is closed again."""
    board = SerialLegBoard("board", ["hip", "knee", "ankle"], "loop://", PERIOD, baudrate=300, write_timeout=0.1)
    with pytest.raises(HardwareError, match=r"^board: the port loop:// did not take a command frame within 0.1 s"):
        board.configure()
    assert board.port is None


def test_a_line_that_goes_away_is_the_devices_error_naming_the_port(board_on_pty):
    board, server, plant, events = board_on_pty
    board.configure()
    board.activate()
    server.shutdown()  # the board's end of the pty closes: the host's write fails (EIO)
    waited = time.monotonic() + 10.0
    while server.pty.fd != -1 and time.monotonic() < waited:
        time.sleep(0.01)
    assert board.write(0.0) is Status.ERROR
    assert board.last_error.startswith(f"write: HardwareError: board: writing to {server.path} failed"), board.last_error


def test_a_board_that_repeats_its_last_frame_goes_stale_and_the_safety_stage_faults(board_on_pty):
    """Defect 3 of issue 25: a proxy resent one sensor frame (same sequence number) 1311 times —
    no stale fault, and the lost-frame counter read 334,305 (255 per repeat). A repeated frame is
    no new data: the joints are not fresh, the stage's stale_ticks fault names the device and
    the repeats, and nothing is counted lost."""
    board, server, plant, events = board_on_pty
    stage = SafetyStage(-np.pi * np.ones(3), np.pi * np.ones(3), 50 * np.ones(3), 100 * np.ones(3), stale_ticks=3,
                        devices=[board], joint_names=board.joint_names)
    command, statuses = JointCommand(3), np.zeros(1, dtype=np.int64)
    board.configure()
    board.activate()

    def tick(k):
        statuses[0] = board.read(k * PERIOD)
        verdict = stage.check(k * PERIOD, k, board.state, statuses, command)
        statuses[0] = max(statuses[0], board.write(k * PERIOD))
        return verdict

    assert [tick(k) for k in range(20)] == [Verdict.OK] * 20
    server.replay = True
    verdicts = [tick(k) for k in range(20, 60)]
    assert Verdict.OK not in verdicts[4:]  # 3 stale ticks after the last new frame (read one tick later)
    fault = stage.faults[0]
    assert fault.kind == FaultKind.STALE and fault.tick <= 24, stage.faults
    assert "of device board: no fresh data for 3 ticks" in fault.reason and "repeated" in fault.reason, fault.reason
    c = board.decoder.counters
    assert c["repeated_frames"] >= 35 and c["lost_frames"] == 0 and c["frames"] <= 22, c


@pytest.mark.flaky(reruns=2, only_rerun=["VmStall"])
def test_the_boards_watchdog_status_while_running_is_an_error_naming_it(free_running_board):
    """Defect 4 of issue 25: for 4.6 s the board reported that its watchdog had locked both
    joints (no command reached it), and the run exited 0. The status is checked every tick while
    active: the lock is the device's ERROR, its reason naming the board and the watchdog."""
    board, server = free_running_board
    board.configure()
    board.activate()
    t = 0.0
    for _ in range(10):
        t += board.period
        ok = board.read(t) == Status.OK and board.write(t) == Status.OK
        if not ok and server.counters["watchdog_trips"]:  # commanded every 10 ms, yet 50 ms without one
            raise VmStall(f"the board's watchdog locked while we commanded it: {board.last_error}")
        assert ok, board.last_error
    server.deaf = True  # our commands stop reaching the board; its frames go on
    statuses = []
    for _ in range(40):  # 0.4 s: the watchdog locks after 50 ms
        t += board.period
        statuses.append(board.read(t))
        board.write(t)
    assert Status.ERROR in statuses and statuses[-1] == Status.ERROR, statuses
    assert server.locked and server.counters["watchdog_trips"] == 1
    assert device_reason(board, Status.ERROR).startswith("device board failed: the board's watchdog locked both joints")
