"""The cia402 driver in-process (tests/can/lockstep_rig.py): the real driver on a python-can
virtual bus, emulated CiA 402 drives (hil_sim.cia402_drive) on the far end."""
import threading

import canopen
import numpy as np
import pytest

from allocations import growth_and_peak
from drivers.cia402_joints import Cia402JointGroup
from drivers.protocols import cia402 as c
from drivers.protocols.cia402_layout import Cia402Joint
from hil_sim.cia402_drive import Cia402Drive, Cia402DriveBus
from hil_sim.mit_drive import pump
from lockstep_rig import LockStep, SlowWire, as_over_slcan, rigs, silence_second_drive, virtual_bus
from rtctl.errors import HardwareError
from rtctl.hal import CommandMode, Status

CPR = 1 << 20
P_LSB = 2 * np.pi / CPR
JOINTS = [Cia402Joint("a", 1, 10.0, CPR), Cia402Joint("b", 2, 20.0, CPR, direction=-1.0, offset=0.5)]


class Rig(LockStep, Cia402JointGroup):
    def __init__(self, joints=JOINTS, drive_scale=None, **kw):
        super().__init__("arm", joints, virtual_bus(), period=0.001, **{"reply_deadline": 0.0, **kw})
        scale = drive_scale or {}
        self._attach(lambda j, port: Cia402Drive(j.node_id, port, rated_torque=scale.get(j.name, j.rated_torque),
                                                 counts_per_rev=j.counts_per_rev), Cia402DriveBus)

    def advance(self, dt):
        """Time passes for the drives without a tick (a frozen loop)."""
        self.now += dt
        self.drives.service(self.now, [])


class SlowRig(SlowWire, Rig):
    pass


@pytest.fixture
def rig():
    yield from rigs(Rig)


@pytest.fixture
def slow_rig():
    yield from rigs(SlowRig)


def test_configure_writes_the_settings_and_reads_the_state_without_enabling(rig):
    r = rig(max_torque=[25.0, np.inf])
    r.q[:] = [0.3, 0.1]
    r.configure()
    assert r.read(0.0) == Status.OK and np.all(r.state.fresh)
    assert np.all(np.abs(r.state.position - r.q) <= P_LSB)
    for d in r.drive_list:
        assert d.state == c.SWITCH_ON_DISABLED and d.nmt_state == "OPERATIONAL" and d.mode == c.CST
        assert d.timeout_s == 0.02 and d.node.sdo[c.HEARTBEAT_TIME].raw == 100
    # max torque in ‰ of rated: 25 N·m on a 10 N·m drive; no limit → the largest value
    assert [d._max_permille for d in r.drive_list] == [2500, 0xFFFF]


def test_a_malformed_sdo_answer_at_configure_is_a_hardware_error_naming_the_drive(rig):
    r = rig()
    r.drive_list[1].node.data_store[c.RATED_TORQUE] = {0: b"\x10\x27"}  # 2 bytes for an UNSIGNED32
    with pytest.raises(HardwareError, match=r"drive 0x2 \(b\).*a malformed SDO answer"):
        r.configure()
    assert r.bus is None


def test_configure_refuses_a_drive_that_scales_otherwise(rig):
    r = rig(drive_scale={"b": 25.0})
    with pytest.raises(HardwareError, match=r"drive 0x2 \(b\).*rated torque 0x6076 is 25 N·m.*20 N·m"):
        r.configure()
    assert r.bus is None


def test_configure_names_a_silent_drive(rig):
    r = rig(exchange_timeout=0.05)
    r.drive_list[1].faults.silent = True
    with pytest.raises(HardwareError, match=r"drive 0x2 \(b\).*no SDO answer"):
        r.configure()


@pytest.mark.parametrize("start", [c.READY, c.SWITCHED_ON, c.QUICK_STOP, c.FAULT])
def test_activate_reaches_operation_enabled_from_any_state(rig, start):
    r = rig()
    r.configure()
    d = r.drive_list[0]
    for cw in {c.READY: [c.CW_SHUTDOWN], c.SWITCHED_ON: [c.CW_SHUTDOWN, c.CW_SWITCH_ON],
               c.QUICK_STOP: [c.CW_SHUTDOWN, c.CW_SWITCH_ON, c.CW_ENABLE_OPERATION, c.CW_QUICK_STOP],
               c.FAULT: []}[start]:
        d.apply_controlword(cw)
    if start == c.FAULT:
        d.set_error(0x5530)
        d.update(r.now)
    assert d.state == start
    r.activate()
    assert all(x.state == c.OPERATION_ENABLED for x in r.drive_list)
    assert d.error_code == 0 and (start != c.FAULT or 15 in d.transitions)
    assert r.tick() == (Status.OK, Status.OK)


def test_torque_and_impedance_through_a_reversed_mount(rig):
    r = rig()
    r.q[:] = [0.1, 0.2]
    r.activate()
    r.command.mode = CommandMode.TORQUE
    r.command.tau_ff[:] = [2.0, -3.0]
    r.tick()
    # ‰ of the rated torque, whole numbers; the reversed drive turns the other way, on the joint the same
    assert [d.torque_permille for d in r.drive_list] == [200, 150]
    assert r.tau == pytest.approx([2.0, -3.0])
    r.tick()
    assert r.state.effort == pytest.approx([2.0, -3.0])
    c_ = r.command
    c_.mode = CommandMode.IMPEDANCE  # closed by the driver on the state of this tick's read
    c_.q_des[:], c_.qd_des[:], c_.kp[:], c_.kd[:], c_.tau_ff[:] = [0.3, 0.1], [0.0, 0.5], 50.0, 2.0, 1.0
    r.tick()
    expected = 50.0 * (c_.q_des - r.state.position) + 2.0 * (c_.qd_des - r.state.velocity) + 1.0
    assert r.tau == pytest.approx(expected, abs=0.02)  # one ‰ of 20 N·m


def test_a_silent_drive_is_stale_and_the_stale_limit_is_an_error(rig):
    r = rig()
    assert silence_second_drive(r) == [Status.OK, Status.OK, Status.OK, Status.ERROR]
    assert "node(s) 0x2 " in r.last_error and r.events[-1]["event"] == "stale"


def test_an_emcy_is_a_fault_event_with_the_drives_code(rig):
    r = rig()
    r.activate()
    r.tick()
    r.drive_list[1].set_error(0x2310)
    r.tick()  # the EMCY arrives in this tick's cycle …
    status, _ = r.tick()  # … and this read reports it
    assert status == Status.ERROR and list(r.state.fault) == [0, 0x2310]
    (event,) = [e for e in r.events if e["event"] == "drive_fault"]
    assert event["drive"] == 2 and event["code"] == 0x2310 and "Current" in event["reason"]
    assert r.tick()[0] == Status.ERROR and len([e for e in r.events if e["event"] == "drive_fault"]) == 1
    r.deactivate()
    r.activate()  # a fault reset on the way; the drive's EMCY 0x0000 clears the code
    assert r.tick() == (Status.OK, Status.OK) and list(r.state.fault) == [0, 0]


def test_a_drive_that_left_operation_enabled_gets_disable_voltage_and_no_torque(rig):
    r = rig()
    r.activate()
    r.command.tau_ff[:] = 3.0
    r.tick()
    d = r.drive_list[0]
    d.apply_controlword(c.CW_DISABLE_VOLTAGE)  # taken down by its own panel
    r.tick()  # its TPDO reports SWITCH ON DISABLED …
    statuses = [r.tick()[0] for _ in range(3)]
    assert statuses == [Status.ERROR] * 3 and r.events[-1]["event"] == "not_enabled"
    # … and from then on its RPDO carries disable voltage and no torque, the other's its torque
    assert d._command == [c.CW_DISABLE_VOLTAGE, 0] and d.state == c.SWITCH_ON_DISABLED
    assert r.drive_list[1]._command == [c.CW_ENABLE_OPERATION, -150]  # 3 N·m on 20 N·m, reversed


def test_the_heartbeat_consumer_marks_a_silent_node_stale(rig):
    r = rig()
    r.activate()
    for _ in range(350):  # 0.35 s: heartbeats every 0.1 s keep it healthy
        assert r.tick() == (Status.OK, Status.OK)
    r.drive_list[0].faults.heartbeat = False  # PDOs go on, the heartbeat stops
    statuses = [r.tick()[0] for _ in range(400)]
    assert statuses[-1] == Status.ERROR and not r.state.fresh[0] and r.state.fresh[1]
    first = statuses.index(Status.ERROR)
    assert 200 <= first <= 300, first  # 0.3 s after its last beat, which came up to 0.1 s before
    assert r.events[-1]["event"] == "heartbeat" and "0x1" in r.events[-1]["reason"]


def test_a_pause_longer_than_the_rpdo_deadline_is_the_drives_stop(rig):
    r = rig(drive_timeout=0.02)
    r.activate()
    r.tick()
    r.advance(0.05)  # the loop froze for 50 ms; the drives' time went on
    assert all(d.state == c.FAULT and d.error_code == c.EMCY_RPDO_TIMEOUT for d in r.drive_list)
    read, write = r.tick()
    assert write == Status.DEACTIVATE and r.events[-1]["event"] == "drives_off"
    assert r.tick()[0] == Status.DEACTIVATE  # until activated again
    r.deactivate()
    r.activate()
    assert r.tick() == (Status.OK, Status.OK)


def test_deactivate_leaves_every_drive_disabled_even_after_the_bus_was_lost(rig):
    r = rig()
    r.activate()
    r.tick()
    r.bus.shutdown()  # the link goes away under the driver
    assert r.tick()[1] == Status.ERROR and r.counters["bus_errors"] == 1
    r.deactivate()  # reopens once, disables
    assert all(d.state == c.SWITCH_ON_DISABLED for d in r.drive_list)
    assert not r.last_error.startswith("deactivate")  # (still the bus error: deactivate succeeded)
    r.close()
    assert all(d.nmt_state == "PRE-OPERATIONAL" for d in r.drive_list)


def test_a_drive_late_at_deactivate_is_awaited_and_one_never_seen_off_is_an_error(slow_rig):
    # (deactivate waits drive_timeout / 2 of wall time: 0.2 s, not the default 20 ms, so that a
    # loaded machine is not what decides — the drives' own time is the rig's, unaffected)
    r = slow_rig(drive_timeout=0.2)
    r.activate()
    r.tick()
    r.hold = True
    r.tick()
    r.read(r.now)  # this cycle's TPDOs are late: both drives count stale …
    r.hold = False
    r.deactivate()  # … yet they answer now, and are awaited until they report disabled
    assert all(d.state == c.SWITCH_ON_DISABLED for d in r.drive_list) and r.last_error is None
    r.activate()
    r.tick()
    r.hold = True
    r.tick()
    r.read(r.now)
    r.drive_list[1].faults.silent = True  # late, then nothing more reaches it: it stays enabled
    r.hold = False
    r.deactivate()
    assert r.drive_list[1].state == c.OPERATION_ENABLED and r.drive_list[0].state == c.SWITCH_ON_DISABLED
    assert r.last_error.startswith("deactivate") and "0x2 (no TPDO)" in r.last_error
    assert "0x1" not in r.last_error.split("did not")[0] and "silent before" in r.last_error


def test_corrupted_tpdos_are_counted_and_ignored(rig):
    r = rig()
    r.activate()
    r.tick()
    d = r.drive_list[0]
    d.faults.corrupt_rate = 0.1
    statuses = [r.tick()[0] for _ in range(200)]
    assert r.counters["malformed_replies"] == d.counters.corrupted > 20
    # a joint is fresh only when all its TPDOs came whole (0.81 of the ticks): 3 misses in a row
    # are rare (0.7 %)
    assert statuses.count(Status.ERROR) <= 5 and np.all(np.isfinite(r.state.position))


def test_a_tick_allocates_nothing_that_stays(rig):
    r = rig()
    r.activate()
    r.command.tau_ff[:] = [1.0, -1.0]
    for _ in range(200):
        r.tick()
    # pools filled once under tracing (measured: 31 kB in the first 0.3 s, then 0)
    growth, peak = growth_and_peak(r.tick, 1500, warmup=300)
    # python-can's Messages (and the emulated drives' frames) come and go within each tick
    assert growth <= 1024 and peak < 16 * 1024, (growth, peak)


def test_write_sends_the_sync_and_returns_and_the_next_read_collects_the_tpdos(slow_rig):
    """A paced loop: the TPDOs arrive while the loop sleeps; write() does not wait for them (two
    buses' round trips would add up in one tick), the next read() takes them."""
    r = slow_rig(reply_deadline=0.9)
    r.activate()
    r.tick()
    r.read(r.now)  # the tick's TPDOs taken
    r.hold = True
    r.command.tau_ff[:] = [2.0, -4.0]
    r.q[:] = [0.2, -0.1]
    assert r.write(r.now) == Status.OK
    assert r.counters["missing_replies"] == 0  # nothing awaited yet
    pump(r.drives, r.peer, now=r.now)  # the wire delivers: the drives apply the torque and answer
    assert r.tau == pytest.approx([2.0, -4.0])
    r.now += 0.001
    assert r.read(r.now) == Status.OK and r.state.fresh.all()
    assert np.abs(r.state.position - r.q).max() <= P_LSB
    assert r.counters["missing_replies"] == 0 and r.counters["late_replies"] == 0


def test_in_lock_step_read_waits_for_the_tpdos_until_the_deadline(slow_rig):
    """A read right after the write (realtime_factor = 0) waits for TPDOs still on the wire …"""
    r = slow_rig(reply_deadline=1000.0)  # 1 s: the answer, 20 ms late, comes well within it
    r.activate()
    r.tick()
    r.read(r.now)  # the tick's TPDOs taken
    r.hold = True
    r.q[:] = [0.3, 0.4]
    assert r.write(r.now) == Status.OK
    late = threading.Timer(0.02, pump, (r.drives, r.peer), {"now": r.now})
    late.start()
    try:
        assert r.read(r.now) == Status.OK and r.state.fresh.all()
    finally:
        late.join()
    assert np.abs(r.state.position - r.q).max() <= P_LSB and r.counters["missing_replies"] == 0


@pytest.mark.parametrize("over_slcan", [False, True])
def test_tpdos_missing_at_the_deadline_are_missing_and_count_late_when_they_come(slow_rig, over_slcan):
    """… and not beyond it: what has not come is missing (stale), and taken as late when it comes
    (over slcan too, where the write reads only what the serial port says is waiting)."""
    r = slow_rig(reply_deadline=0.5)
    r.activate()
    if over_slcan:
        as_over_slcan(r)
    r.tick()
    r.read(r.now)  # the tick's TPDOs taken
    r.hold = True
    assert r.write(r.now) == Status.OK
    assert r.read(r.now) == Status.OK and not r.state.fresh.any()
    assert r.counters["missing_replies"] == 2
    pump(r.drives, r.peer, now=r.now)
    r.write(r.now)  # takes them before its SYNC
    assert r.counters["late_replies"] == 4  # two TPDOs per drive


def test_over_slcan_an_empty_port_is_not_read_before_the_sync(rig, monkeypatch):
    """An empty read over slcan waits out the serial timeout: with no byte waiting, the tick's
    write sends its RPDOs and SYNC without reading."""
    r = rig()
    r.activate()
    as_over_slcan(r)
    r.tick()
    assert r.read(r.now) == Status.OK and r.state.fresh.all()
    reads = []
    recv = r.bus.recv
    monkeypatch.setattr(r.bus, "recv", lambda timeout=None: reads.append(timeout) or recv(timeout))
    assert r.write(r.now) == Status.OK and reads == []


def test_bring_up_asks_no_drive_for_torque_before_the_first_command(rig):
    """Issue 27 part 3 (a cia402_driver sample survivor): until a controller writes a command,
    every RPDO the driver sends — the bring-up's controlwords included — carries target torque 0."""
    r = rig()
    r.configure()
    r.activate()
    assert all(d.state == c.OPERATION_ENABLED for d in r.drive_list)
    assert [d.torque_permille for d in r.drive_list] == [0, 0] and [d.torque for d in r.drive_list] == [0.0, 0.0]


def test_the_objects_the_bring_up_touches_are_the_ones_the_offline_check_covers(rig, monkeypatch):
    """`rtctl check` vets an EDS offline for what the bring-up will read and write
    (c.BRING_UP_OBJECTS, besides the PDO set); so that list must be the bring-up's own SDO
    traffic, sub-index and all. Recorded at the emulated drives' object dictionaries."""
    touched = set()
    get_data, set_data = canopen.LocalNode.get_data, canopen.LocalNode.set_data

    def recording_get(node, index, subindex, *args, **kw):
        touched.add((index, subindex))
        return get_data(node, index, subindex, *args, **kw)

    def recording_set(node, index, subindex, *args, **kw):
        touched.add((index, subindex))
        return set_data(node, index, subindex, *args, **kw)

    monkeypatch.setattr(canopen.LocalNode, "get_data", recording_get)
    monkeypatch.setattr(canopen.LocalNode, "set_data", recording_set)
    rig().configure()
    pdo_records = {i for i, _ in touched if 0x1400 <= i <= 0x1BFF}  # the PDO set: pdo.save()
    assert pdo_records == {0x1400, 0x1600, 0x1800, 0x1801, 0x1A00, 0x1A01}
    outside = {(i, s) for i, s in touched if i not in pdo_records}
    assert outside == {(0x6040, 0), (0x1000, 0), (0x6502, 0), (0x6076, 0), (0x608F, 1), (0x608F, 2),
                       (0x6060, 0), (0x6072, 0), (0x1017, 0)}
    assert (0x1400, 5) in touched  # RPDO1's event timer: the drives' deadline
    assert set(c.BRING_UP_OBJECTS) == outside | {(0x1400, 5)}
