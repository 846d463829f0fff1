"""The cia402 driver against CiA 301/402 where its common tests do not look (same in-process
rig as test_cia402_driver.py): EMCY codes 0x00xx mean "error reset or no error" (CiA 301,
table of emergency error codes); a heartbeat that says the node is not OPERATIONAL is a
heartbeat fault even while its PDOs still come, and the consumer's timer restarts when the
device is activated (CiA 301 §7.2.8.3.2.3: monitoring starts with the heartbeat it next
receives); a drive in FAULT has its power stage off (CiA 402 state machine), so disabling it
succeeds without a fault reset."""
import can
import numpy as np
import pytest

from drivers.protocols import cia402 as c
from lockstep_rig import rigs
from rtctl.hal import Status
from test_cia402_driver import Rig


@pytest.fixture
def rig():
    yield from rigs(Rig)


def _events(r, name):
    return [e for e in r.events if e["event"] == name]


@pytest.mark.parametrize("code", [0x0001, 0x0042, 0x00FF])
def test_an_emcy_in_the_no_error_range_is_not_a_drive_fault(rig, code):
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[1].node.emcy.send(code, 0x00)
    statuses = [r.tick()[0] for _ in range(3)]
    assert statuses == [Status.OK] * 3 and list(r.state.fault) == [0, 0] and not _events(r, "drive_fault")
    assert r.counters["emcy"] == 1  # it did arrive


def test_a_heartbeat_saying_pre_operational_is_a_heartbeat_fault_while_the_pdos_go_on(rig):
    r = rig()
    r.activate()
    for _ in range(5):
        assert r.tick() == (Status.OK, Status.OK)
    # node 1 announces PRE-OPERATIONAL (0x7F) — a restart, an NMT command from elsewhere; its PDOs keep coming
    r.peer.send(can.Message(arbitration_id=c.HEARTBEAT_BASE + 1, data=[0x7F], is_extended_id=False))
    statuses = [r.tick()[0] for _ in range(3)]
    assert Status.ERROR in statuses[:2]
    (event,) = _events(r, "heartbeat")
    assert "0x1" in event["reason"] and "0x2" not in event["reason"]
    assert not r.state.fresh[0] and r.state.fresh[1]
    assert not _events(r, "stale")


def test_a_heartbeat_that_resumes_right_after_activation_is_within_the_timeout(rig):
    r = rig()
    r.configure()
    drive = r.drive_list[0]
    drive.faults.heartbeat = False  # off while the device is inactive (a drive power-cycled, say) …
    r.advance(1.0)  # … for longer than the 0.3 s timeout
    r.activate()
    drive.faults.heartbeat = True  # … and beating again, every 0.1 s, from activation on
    statuses = [r.tick()[0] for _ in range(400)]
    assert statuses == [Status.OK] * 400, (statuses.index(Status.ERROR), r.last_error)
    assert not _events(r, "heartbeat")


def test_deactivate_after_a_drive_fault_confirms_with_the_drive_left_in_fault(rig):
    r = rig()
    r.activate()
    r.tick()
    drive = r.drive_list[0]
    drive.set_error(0x2310)  # overcurrent: FAULT REACTION ACTIVE → FAULT, power stage off
    for _ in range(3):
        r.tick()
    assert drive.state == c.FAULT and r.state.fault[0] == 0x2310
    assert r.deactivate() is True, r.last_error
    assert drive.state == c.FAULT and drive.torque == 0.0  # not reset behind the operator's back
    assert r.drive_list[1].state == c.SWITCH_ON_DISABLED
