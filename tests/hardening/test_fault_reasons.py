"""A fault says why (issue 25, defect 7a): for every device type, made to fail the way it fails
in the field, the safety stage's fault reason names the device by its configured name and the
cause as its driver saw it — not ``device 0 status 1``. Joint devices go through the safety
stage as the daemon builds it (``devices=``); a device without joints through the daemon's tick.

A new device type gets this test by adding a case to ``CASES``: a function that returns the
device (configured and active) and a ``tick(k)`` that makes it fail at some point."""
from __future__ import annotations

import sys
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from drivers.can_joints import MitCanJointGroup
from drivers.cia402_joints import Cia402JointGroup
from drivers.leg_board import SerialLegBoard
from drivers.protocols.cia402_layout import Cia402Joint
from drivers.protocols.mit import DRIVE_MODELS
from drivers.protocols.mit_layout import MitJoint
from hil_sim.cia402_drive import Cia402Drive, Cia402DriveBus
from hil_sim.leg_plant import LegParams, LegPlant
from hil_sim.leg_serial import LegBoardServer
from hil_sim.mit_drive import MitDrive, MitDriveBus
from rtctl.hal import JointCommand, Status
from rtctl.safety import SafetyStage
from runtime_helpers import ROOT

sys.path.insert(0, str(ROOT / "tests" / "can"))
from lockstep_rig import LockStep, virtual_bus  # noqa: E402

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

DM4310 = DRIVE_MODELS["dm4310"]


class MitRig(LockStep, MitCanJointGroup):
    def __init__(self, **kw):
        super().__init__("shoulder_bus", [MitJoint("a", 1, DM4310), MitJoint("b", 2, DM4310)], virtual_bus(),
                         reply_deadline=0.0, exchange_timeout=0.0, period=0.001, **kw)
        self._attach(lambda j, port: MitDrive(j.drive_id, port, j.model), MitDriveBus)


class Cia402Rig(LockStep, Cia402JointGroup):
    def __init__(self):
        super().__init__("wrist_bus", [Cia402Joint("a", 1, 10.0, 1 << 20), Cia402Joint("b", 2, 20.0, 1 << 20)],
                         virtual_bus(), period=0.001, reply_deadline=0.0)
        self._attach(lambda j, port: Cia402Drive(j.node_id, port, rated_torque=j.rated_torque,
                                                 counts_per_rev=j.counts_per_rev), Cia402DriveBus)


def _rig_ticks(rig, fail_at, fail):
    """``tick(k)``: the rig's read and write (a write's status counts in the next tick, as in the loop)."""
    pending = [Status.OK]

    def tick(k):
        if k == fail_at:
            fail()
        rig.now += 0.001
        read = rig.read(rig.now)
        status = max(read, pending[0])
        pending[0] = rig.write(rig.now)
        return status

    return tick


def mit_drive_error(cleanup):
    r = MitRig()
    cleanup.append(lambda: (r.close(), r.peer.shutdown()))
    r.activate()
    return r, _rig_ticks(r, 5, lambda: r.drive_list[1].set_error(0xA)), ("drive error codes", "'b': 10")


def mit_bus_lost(cleanup):
    r = MitRig(reconnect_timeout=0.0)
    cleanup.append(lambda: (r.close(), r.peer.shutdown()))
    r.activate()
    return r, _rig_ticks(r, 5, lambda: r.bus.shutdown()), ("bus ",)


def mit_drives_off(cleanup):
    r = MitRig(drive_timeout=0.02)
    cleanup.append(lambda: (r.close(), r.peer.shutdown()))
    r.activate()

    def freeze():  # the loop froze for 50 ms: the drives' watchdogs turned their motors off
        r.now += 0.05
    return r, _rig_ticks(r, 5, freeze), ("stopped itself", "no command for 5", "watchdog")


def cia402_emcy(cleanup):
    r = Cia402Rig()
    cleanup.append(lambda: (r.close(), r.peer.shutdown()))
    r.activate()
    return r, _rig_ticks(r, 5, lambda: r.drive_list[1].set_error(0x2310)), ("node 0x2 (b): EMCY 0x2310",)


class _DeafBoard(LegBoardServer):
    deaf = False

    def _commands(self, count, now):
        if not self.deaf:
            super()._commands(count, now)


def _leg_board(cleanup, realtime_factor):
    period = 0.01
    server = _DeafBoard(LegPlant(LegParams(angle_noise=0.0, load_noise=0.0)), period,
                        realtime_factor=realtime_factor, emit=lambda e: None, watchdog_s=0.05)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    board = SerialLegBoard("left_leg", ["hip", "knee", "ankle"], server.path, period, reply_deadline=0.9)
    cleanup.append(lambda: (board.close(), server.shutdown(), thread.join(5)))
    board.configure()
    board.activate()
    return board, server


def _board_ticks(board, fail_at, fail):
    def tick(k):
        if k == fail_at:
            fail()
        status = board.read(k * board.period)
        board.write(k * board.period)
        return status
    return tick


def leg_board_watchdog(cleanup):
    board, server = _leg_board(cleanup, realtime_factor=1.0)
    return board, _board_ticks(board, 5, lambda: setattr(server, "deaf", True)), ("watchdog locked both joints",)


def leg_board_port_lost(cleanup):
    board, server = _leg_board(cleanup, realtime_factor=0.0)
    return board, _board_ticks(board, 5, server.shutdown), ("writing to /dev/pts/", "Input/output error")  # pty closed


CASES = {  # device type, how it fails → the case
    "mit_can, a drive's error code": mit_drive_error,
    "mit_can, the bus lost": mit_bus_lost,
    "mit_can, the drives' watchdog (DEACTIVATE)": mit_drives_off,
    "cia402, an EMCY": cia402_emcy,
    "leg_board, the board's watchdog": leg_board_watchdog,
    "leg_board, the port gone": leg_board_port_lost,
}


@pytest.mark.parametrize("case", CASES)
def test_a_joint_devices_fault_names_the_device_and_the_cause(case):
    cleanup = []
    try:
        dev, tick, causes = CASES[case](cleanup)
        n = dev.n
        stage = SafetyStage(-10 * np.ones(n), 10 * np.ones(n), 100 * np.ones(n), 100 * np.ones(n), stale_ticks=50,
                            devices=[dev], joint_names=dev.joint_names)
        command, statuses = JointCommand(n), np.zeros(1, dtype=np.int64)
        for k in range(40):
            statuses[0] = tick(k)
            stage.check(k * 0.001, k, dev.state, statuses, command)
            if stage.faults:
                break
    finally:
        for undo in reversed(cleanup):
            undo()
    assert stage.faults, f"{case}: no fault in 40 ticks ({dev.last_error})"
    reason = stage.faults[0].reason
    assert reason.startswith(f"device {dev.name} "), reason  # the configured name, not an index
    for cause in causes:
        assert cause in reason, reason


def test_a_device_without_joints_that_fails_is_a_device_error_naming_it_and_the_cause(tmp_path):
    """The shipped vision configuration in-process: 0.1 s into the run its camera (a
    framegrabber over the shared-buffer protocol) reports FAULT, as after refusing settings."""
    from drivers.protocols.framegrabber import FAULT, S_ERROR, S_STATE
    from rtctl.config import load_config
    from rtctl.daemon import Daemon
    from rtctl.runtime import build

    cfg = load_config(ROOT / "configs" / "puma560_vision_sim.toml", sim=True)
    runtime = build(cfg)
    camera = runtime.io["camera"]
    step = camera.camera.step

    def step_then_fault(t_ns):
        step(t_ns)
        if t_ns >= 100_000_000:
            camera.memory.status[S_STATE], camera.memory.status[S_ERROR] = FAULT, 1

    camera.camera.step = step_then_fault
    args = SimpleNamespace(telemetry=None, socket=str(tmp_path / "s.sock"), enforce_rt=False, duration=0.5,
                           summary=None, log_level="error", realtime_factor=0.0)
    d = Daemon(cfg, runtime, args)
    assert d.run() == 3
    fault = d.safety.faults[0]
    assert fault.kind.name == "DEVICE_ERROR" and 0.1 <= fault.t <= 0.102, fault
    assert fault.reason == "device camera failed: read: ProtocolError: the device reports FAULT (1 settings refused)"
