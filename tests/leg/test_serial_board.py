"""The serial leg board driver against the board firmware on a pty (in-process), and on
pyserial's loop:// (where it hears only its own commands)."""
import threading

import numpy as np
import pytest

from drivers.leg_board import SerialLegBoard
from hil_sim.leg_plant import LegParams, LegPlant
from hil_sim.leg_serial import LegBoardServer
from rtctl.errors import HardwareError
from rtctl.hal import Status

PERIOD = 0.002


@pytest.fixture
def board_on_pty():
    plant = LegPlant(LegParams(angle_noise=0.0, load_noise=0.0))
    events = []
    server = LegBoardServer(plant, PERIOD, emit=events.append, watchdog_s=0.05)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    board = SerialLegBoard("board", ["hip", "knee", "ankle"], server.path, PERIOD, reply_deadline=5.0)
    yield board, server, plant, events
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
