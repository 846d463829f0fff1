"""The cia402 driver's lifecycle and bookkeeping where its common tests did not look (mutation
survivors of the full cia402_driver run, issue 27 part 3; same in-process rig as
test_cia402_driver.py): the link it opens and reopens, what close does when the drives cannot be
told, what a fresh activation counts as stale, frames the bus carries besides the awaited TPDOs,
the counters against the frames on the wire, and slcan's acknowledgements."""
import time

import can
import pytest

from drivers.cia402_joints import Cia402JointGroup
from drivers.can_bus import BusOptions
from drivers.protocols import cia402 as c
from lockstep_rig import rigs
from rtctl.hal import Status
from test_cia402_driver import JOINTS, Rig

HEARTBEAT = (c.HEARTBEAT_BASE + 1, c.HEARTBEAT_BASE + 2)


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
def echo_rig():
    yield from rigs(EchoRig)


@pytest.fixture
def noisy_rig():
    yield from rigs(NoisyRig)


def test_activation_opens_no_second_link(rig, monkeypatch):
    r = rig()
    r.configure()
    opened = []
    real = can.Bus
    monkeypatch.setattr(can, "Bus", lambda *a, **kw: opened.append(kw) or real(*a, **kw))
    r.activate()
    assert opened == [] and r.tick() == (Status.OK, Status.OK)


def test_activation_reopens_a_link_lost_while_inactive(rig, monkeypatch):
    r = rig()
    r.activate()
    r.tick()
    r.bus.shutdown()  # the link goes away …
    assert r.tick()[1] == Status.ERROR and r.bus is None

    def still_down(*a, **kw):
        raise can.CanError("no such device")

    with monkeypatch.context() as m:  # … and is still away at deactivate
        m.setattr(can, "Bus", still_down)
        assert r.deactivate() is False and r.bus is None
    r.activate()  # back: activation opens it
    assert all(d.state == c.OPERATION_ENABLED for d in r.drive_list)
    assert r.tick() == (Status.OK, Status.OK)


def test_close_releases_the_link_even_when_the_drives_cannot_be_told(rig):
    r = rig()
    r.configure()
    bus = r.bus

    def refuse(msg, timeout=None):
        raise can.CanOperationError("transmit buffer full")

    bus.send = refuse  # NMT pre-operational cannot go out
    r.close()
    assert r.bus is None and bus._is_shutdown


def test_a_fresh_activation_counts_no_drive_as_stale(rig):
    """Activation needs every drive's answer: right after it, before the first tick, no joint has
    missed a tick."""
    r = rig()
    r.activate()
    assert r.stale_cause() is None
    assert r.diagnostics()["stale_ticks"] == {"a": 0, "b": 0}


def test_a_drive_that_goes_silent_at_deactivate_was_not_silent_before(rig):
    r = rig()
    r.activate()
    assert r.tick() == (Status.OK, Status.OK)  # both answered the last cycle
    r.drive_list[1].faults.silent = True
    assert r.deactivate() is False
    assert "0x2 (no TPDO)" in r.last_error and "silent before" not in r.last_error


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


def test_a_bus_error_at_a_ticks_send_is_a_lost_bus_that_is_reopened(rig):
    r = rig(reconnect_interval=0.0)
    r.activate()
    r.tick()
    bus, send = r.bus, r.bus.send

    def broken(msg, timeout=None):
        raise can.CanOperationError("bus-off")

    bus.send = broken
    assert r.tick()[1] == Status.ERROR
    assert r.counters["bus_errors"] == 1 and r.events[-1]["event"] == "bus_lost" and r.bus is None
    bus.send = send
    for _ in range(3):
        r.tick()
    assert r.counters["reconnects"] == 1 and r.bus is not None


def test_the_counters_are_the_frames_on_the_wire(rig):
    """SYNCs sent by the ticks, and heartbeats received since the bring-up (whose boot-up
    messages python-canopen takes), counted by a second listener on the bus."""
    r = rig()
    sniffer = can.Bus(interface="virtual", channel=r.bus_options.kwargs["channel"])
    try:
        r.configure()
        _frames(sniffer)
        r.activate()
        seen = _frames(sniffer)
        for _ in range(250):  # 0.25 s: two or three heartbeats from each drive
            r.tick()
        during_ticks = _frames(sniffer)
        assert sum(m.arbitration_id == c.SYNC for m in during_ticks) == 250 == r.counters["cycles"]
        r.deactivate()  # (its cycle takes the frames the last tick left; no heartbeat is due meanwhile)
        seen += during_ticks + _frames(sniffer)
        beats = sum(m.arbitration_id in HEARTBEAT and len(m.data) == 1 for m in seen)
        assert beats >= 4 and r.counters["heartbeats"] == beats
    finally:
        sniffer.shutdown()


def _frames(bus) -> list:
    out = []
    while (msg := bus.recv(0.0)) is not None:
        out.append(msg)
    return out


class RecordingBus:
    def __init__(self):
        self.sent = []

    def send(self, msg, timeout=None):
        self.sent.append(msg.arbitration_id)

    def recv(self, timeout=None):
        return None


def test_over_slcan_a_cycle_skips_one_acknowledgement_per_frame_it_sent():
    """slcan's adapter acknowledges every frame sent (python-can reads each as None): the
    collection must allow for as many as the cycle sent — every RPDO and the SYNC."""
    options = BusOptions({"interface": "slcan", "channel": "/dev/null", "timeout": 0.001}, 1_000_000, False,
                         ("slcan", "/dev/null", None, None), "/dev/null")
    g = Cia402JointGroup("arm", JOINTS, options)
    g.bus = RecordingBus()
    g._send_sync(0.0)
    assert g.bus.sent.count(c.SYNC) == 1
    assert g._acks_per_send == len(g.bus.sent) == 2 * len(g.layout.rpdos) + 1


def test_a_heartbeat_exactly_as_old_as_the_timeout_is_in_time_when_another_node_is_late(rig):
    """The consumer's rule — late only *past* ``heartbeat_timeout`` — holds for every node, also
    when another node's late heartbeat makes it look at all (ages below are binary fractions: exact)."""
    r = rig(heartbeat_timeout=0.25, drive_timeout=1.0)
    r.activate()  # t = 0: both nodes' timers start
    r.drive_list[0].faults.heartbeat = False  # node 1 beats no more
    before = r.counters["heartbeats"]
    r.tick(0.125)  # node 2 beats (every 0.1 s) …
    r.drive_list[1].faults.heartbeat = False
    r.tick(0.125)  # … and its beat is taken at t = 0.25
    assert r.counters["heartbeats"] > before
    r.now = 0.5  # node 1: 0.5 s without a beat; node 2: exactly 0.25 s
    assert r.read(r.now) == Status.ERROR
    assert list(r.state.fresh) == [False, True]
    assert "node(s) 0x1 " in r.events[-1]["reason"]
