"""The cia402 driver's lifecycle and bookkeeping where its common tests did not look (mutation
survivors of the full cia402_driver run, issue 27 part 3; same in-process rig as
test_cia402_driver.py): the link it opens and reopens, what close does when the drives cannot be
told, what a fresh activation counts as stale,
the counters against the frames on the wire, slcan's acknowledgements, the heartbeat consumer at
its timeout (the frames the bus carries besides the awaited TPDOs: test_cia402_frames.py)."""
import can
import pytest

from drivers.cia402_joints import Cia402JointGroup
from drivers.can_bus import BusOptions
from drivers.protocols import cia402 as c
from lockstep_rig import rigs
from rtctl.errors import HardwareError
from rtctl.hal import CommandMode, Status
from test_cia402_driver import JOINTS, Rig

HEARTBEAT = (c.HEARTBEAT_BASE + 1, c.HEARTBEAT_BASE + 2)


@pytest.fixture
def rig():
    yield from rigs(Rig)


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


def test_a_fault_that_outlives_the_first_reset_is_reset_on_a_new_rising_edge(rig):
    """CiA 402 resets a fault on a rising edge of controlword bit 7: a drive whose fault cause
    was still there at the first edge needs the bit dropped and raised again."""
    r = rig()
    r.configure()
    d = r.drive_list[0]
    d.set_error(0x5530)
    d.update(r.now)
    edges = []
    apply = d.apply_controlword

    def cause_present_at_first_edge(cw):
        edge = cw & c.CW_FAULT_RESET and not d.controlword & c.CW_FAULT_RESET
        if edge:
            edges.append(cw)
        if edge and len(edges) == 1:
            d.controlword = cw  # heard, but the fault stays
            return
        apply(cw)

    d.apply_controlword = cause_present_at_first_edge
    r.activate()
    assert len(edges) == 2 and all(x.state == c.OPERATION_ENABLED for x in r.drive_list)


def test_a_failed_activation_says_what_failed_and_leaves_no_drive_enabled(rig):
    r = rig()
    r.configure()
    stuck = r.drive_list[1]
    stuck.apply_controlword = lambda cw: None  # answers every SYNC, follows no controlword
    with pytest.raises(HardwareError, match=r"0x2 \(SWITCH ON DISABLED\) did not reach OPERATION ENABLED"):
        r.activate()
    assert r.drive_list[0].state == c.SWITCH_ON_DISABLED  # it was enabled on the way: taken down again


def test_a_step_of_the_state_machine_waits_sixteen_sync_cycles_and_says_so(rig):
    """docs/cia402.md: each step waits at most 16 SYNC cycles (and exchange_timeout, far longer
    here): a drive that answers and never follows hears 16 *shutdown* controlwords, then
    *disable voltage*."""
    r = rig(exchange_timeout=30.0)
    r.configure()
    stuck, heard = r.drive_list[1], []
    stuck.apply_controlword = heard.append
    with pytest.raises(HardwareError, match=r"0x2 \(SWITCH ON DISABLED\) did not reach OPERATION ENABLED within "
                                            r"16 SYNC cycles"):
        r.activate()
    assert heard[:16] == [c.CW_SHUTDOWN] * 16 and heard[16:] == [c.CW_DISABLE_VOLTAGE]


def test_a_bus_error_while_the_state_machines_step_is_a_hardware_error_and_closes_the_bus(rig):
    r = rig()
    r.configure()
    send = r.bus.send

    def broken(msg, timeout=None):  # (NMT start still goes out: the first SYNC cycle fails)
        if msg.arbitration_id == c.SYNC:
            raise can.CanOperationError("bus-off")
        send(msg, timeout)

    r.bus.send = broken
    with pytest.raises(HardwareError, match="reach OPERATION ENABLED: bus error: CanOperationError"):
        r.activate()
    assert r.bus is None


def test_a_torque_past_the_pdos_range_is_sent_as_its_bound(rig):
    """Target torque 0x6071 is an INTEGER16 (‰ of rated): −32768 … 32767."""
    r = rig()
    r.activate()
    r.command.mode = CommandMode.TORQUE
    r.command.tau_ff[:] = [1e6, 1e6]  # 10⁸ ‰ of a 10 N·m drive; the reversed one gets −5·10⁷ ‰
    r.tick()
    assert [d._command[1] for d in r.drive_list] == [32767, -32768]


def test_configure_writes_longer_periods_in_whole_ms(rig):
    r = rig(heartbeat_period=1.5, drive_timeout=0.75)
    r.configure()
    for d in r.drive_list:
        assert d.node.sdo[c.HEARTBEAT_TIME].raw == 1500 and d.timeout_s == 0.75


def test_a_bus_error_while_a_tick_collects_is_a_lost_bus_at_once(rig):
    r = rig()
    r.activate()
    r.tick()

    def broken(timeout=None):
        raise can.CanOperationError("bus-off")

    r.bus.recv = broken
    assert r.read(r.now) == Status.ERROR  # the read that failed reports it, not the next write
    assert r.counters["bus_errors"] == 1 and r.events[-1]["event"] == "bus_lost" and r.bus is None


def test_a_drive_silent_before_deactivate_is_named_with_its_deadline_in_ms(rig):
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[1].faults.silent = True
    r.tick()
    r.tick()  # node 2 missed a tick
    assert r.deactivate() is False
    assert "node(s) 0x2 silent before: their RPDO deadline (20 ms) turns them off" in r.last_error


def test_emcys_from_two_drives_at_once_name_the_first_in_the_devices_order(rig):
    """As the stale and heartbeat reports list nodes in the device's order, the drive_fault event
    names the first faulted drive of that order (and carries every code)."""
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[1].set_error(0x2310)
    r.drive_list[0].set_error(0x4310)  # (sent after node 2's)
    r.tick()
    r.tick()
    (event,) = [e for e in r.events if e["event"] == "drive_fault"]
    assert event["drive"] == 1 and event["code"] == 0x4310 and event["codes"] == {"a": 0x4310, "b": 0x2310}
