"""The cia402 driver's collection of a SYNC cycle's TPDOs when the bus carries other frames too
(mutation survivors of the full cia402_driver run, issue 27 part 3; same in-process rig as
test_cia402_driver.py). Error frames, frames of other nodes, malformed frames, EMCYs, heartbeats
and a TPDO that CAN repeats are counted where they belong and ignored otherwise (docs/cia402.md):
none may pass for an awaited TPDO — the cycle would end before a drive's own, which then counts
as missing — and none may hold the collection until its deadline once every TPDO is in."""
import time

import can
import pytest

from drivers.protocols import cia402 as c
from lockstep_rig import rigs
from rtctl.hal import Status
from test_cia402_driver import Rig


class NoisyRig(Rig):
    """A bus with error frames: one reaches the driver in every cycle before the drives answer."""

    def _after_send(self):
        self.peer.send(can.Message(is_error_frame=True, arbitration_id=0, data=b""))
        super()._after_send()


class EchoRig(Rig):
    """Node 1's first TPDO reaches the driver twice in every cycle (CAN repeats a frame whose
    transmitter saw an error in the last bit of its end of frame, after the receivers took it)."""

    def __init__(self, **kw):
        super().__init__(**kw)
        send, tpdo1 = self.peer.send, self.layout.tpdos[0].cob_id(1)
        self.peer.send = lambda msg, timeout=None: [send(msg) for _ in range(1 + (msg.arbitration_id == tpdo1))]


@pytest.fixture
def rig():
    yield from rigs(Rig)


@pytest.fixture
def noisy_rig():
    yield from rigs(NoisyRig)


@pytest.fixture
def echo_rig():
    yield from rigs(EchoRig)


def test_error_frames_on_the_bus_are_counted_and_no_tpdo_is_missed_for_them(noisy_rig):
    r = noisy_rig()
    r.activate()
    before = r.counters["error_frames"]
    statuses = [r.tick() for _ in range(10)]
    assert statuses == [(Status.OK, Status.OK)] * 10 and r.read(r.now) == Status.OK and all(r.state.fresh)
    assert r.counters["error_frames"] - before == 10 and r.counters["missing_replies"] == 0


def test_a_repeated_tpdo_does_not_hold_the_collection_until_its_deadline(echo_rig):
    r = echo_rig(reply_deadline=400.0)  # 0.4 s after the SYNC (period 1 ms)
    r.activate()
    r.tick()
    started = time.monotonic()
    assert r.read(r.now) == Status.OK and all(r.state.fresh)
    assert time.monotonic() - started < 0.2  # every TPDO was there: no wait (generous, 0.4 s would be the bug)


@pytest.mark.parametrize("cob_id, data", [
    (c.EMCY_BASE + 2, b"\x10\x23\x01"),  # an EMCY is 8 bytes
    (c.HEARTBEAT_BASE + 2, b"\x05\x00"),  # a heartbeat is 1
])
def test_a_malformed_emcy_or_heartbeat_is_counted_and_ignored(rig, cob_id, data):
    r = rig()
    r.activate()
    r.tick()
    beats = r.counters["heartbeats"]
    r.peer.send(can.Message(arbitration_id=cob_id, data=data, is_extended_id=False))
    statuses = [r.tick()[0] for _ in range(3)]
    assert statuses == [Status.OK] * 3 and r.counters["malformed_replies"] == 1 and list(r.state.fault) == [0, 0]
    assert r.counters["emcy"] == 0 and r.counters["heartbeats"] == beats




class ExtraFrameRig(Rig):
    """Before the drives answer each SYNC, the bus carries ``extra`` (a Message) — and, with
    ``drop``, node 2's first TPDO is lost."""

    extra = None
    drop = False

    def __init__(self, **kw):
        super().__init__(**kw)
        send, tpdo1 = self.peer.send, self.layout.tpdos[0].cob_id(2)
        self.peer.send = lambda msg, timeout=None: None if self.drop and msg.arbitration_id == tpdo1 else send(msg)

    def _after_send(self):
        if self.extra is not None:
            self.peer.send(self.extra)
        super()._after_send()


@pytest.fixture
def extra_rig():
    yield from rigs(ExtraFrameRig)


def _std(cob_id, data, **kw):
    return can.Message(arbitration_id=cob_id, data=data, is_extended_id=False, **kw)


TPDO1_NODE1 = c.TPDO_BASE + 1
EXTRA = {  # frame, the counter it belongs to
    "error frame": (can.Message(is_error_frame=True, arbitration_id=0, data=b""), "error_frames"),
    "another node's frame": (_std(0x123, b"\x01\x02"), "foreign_frames"),
    "a TPDO of the wrong length": (_std(TPDO1_NODE1, b"\x27\x06"), "malformed_replies"),
    "an extended-id frame on a TPDO's number": (can.Message(arbitration_id=TPDO1_NODE1, data=b"\xff" * 8,
                                                            is_extended_id=True), "foreign_frames"),
    "a remote frame on a TPDO's COB-ID": (_std(TPDO1_NODE1, b"", is_remote_frame=True, dlc=8), "foreign_frames"),
    "a malformed EMCY": (_std(c.EMCY_BASE + 1, b"\x10\x23"), "malformed_replies"),
    "an EMCY 'no error'": (_std(c.EMCY_BASE + 1, bytes(8)), "emcy"),
    "a heartbeat, OPERATIONAL": (_std(c.HEARTBEAT_BASE + 2, b"\x05"), "heartbeats"),
    "a malformed heartbeat": (_std(c.HEARTBEAT_BASE + 2, b"\x05\x00"), "malformed_replies"),  # (CiA 301: 1 byte)
}


@pytest.mark.parametrize("kind", list(EXTRA))
def test_a_frame_besides_the_tpdos_neither_ends_nor_holds_the_collection(extra_rig, kind):
    frame, counter = EXTRA[kind]
    r = extra_rig(reply_deadline=400.0)  # 0.4 s after the SYNC (period 1 ms)
    r.activate()
    r.extra = frame
    before = r.counters[counter]
    for _ in range(5):
        r.tick()
        started = time.monotonic()
        assert r.read(r.now) == Status.OK and all(r.state.fresh), kind
        assert time.monotonic() - started < 0.2, kind  # every TPDO was in: no wait (0.4 s: held)
    assert r.counters[counter] - before == 5 and r.counters["late_replies"] == 0  # each frame counted once


def test_a_drive_whose_first_tpdo_is_lost_is_not_fresh(extra_rig):
    r = extra_rig()
    r.activate()
    assert r.tick() == (Status.OK, Status.OK)
    r.drop = True  # node 2's TPDO1 (statusword, position, torque) lost; its TPDO2 (velocity) arrives
    r.tick()
    r.read(r.now)
    assert list(r.state.fresh) == [True, False]
