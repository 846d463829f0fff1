"""Back-to-back: the emulated CiA 402 drives (hil_sim.cia402_drive) against a python-canopen
master and raw frames of the shared codec, on every CAN transport available (virtual in
lock-step, socketcand over loopback TCP, socketcan/vcan where the kernel has AF_CAN)."""
import contextlib
import time

import canopen
import pytest

from drivers.cia402_bringup import MasterNetwork, sdo_session
from drivers.protocols import cia402 as c

LAYOUT = c.PdoLayout.from_eds()
SW, POS, VEL, TRQ = range(4)


@contextlib.contextmanager
def canopen_master(link):
    """python-canopen RemoteNodes for the link's drives, with SDO working (its Notifier runs)."""
    network = MasterNetwork(link.bus, link.pump)
    nodes = {}
    for i in link.ids:
        nodes[i] = network.add_node(canopen.RemoteNode(i, canopen.import_od(str(c.EDS), i)))
    with sdo_session(network):
        yield network, nodes


def start(link):
    """NMT start (OPERATIONAL) to every drive; their boot-up messages, queued since power-on, go first."""
    for i in link.ids:
        link.send(c.NMT, bytes((1, i)))
    boot = link.collect(len(link.ids))
    assert sorted((f.arbitration_id, bytes(f.data)) for f in boot) == [(c.HEARTBEAT_BASE + i, b"\0") for i in link.ids]
    # the boot-ups were queued at power-on: over a real transport they can arrive before the
    # server has handled the NMT starts sent just now
    deadline = time.monotonic() + 10.0
    while not all(d.nmt_state == "OPERATIONAL" for d in link.drives.drives.values()):
        assert time.monotonic() < deadline, {i: d.nmt_state for i, d in link.drives.drives.items()}
        time.sleep(0.005)


def sync_cycle(link, commands, others=None):
    """RPDOs (``{id: (controlword, torque ‰)}``) then one SYNC; the TPDOs as ``{id: [sw, pos, vel, tq]}``
    (each TPDO exactly once: a duplicate fails). ``others``: a list that takes as many other
    frames as it has places (an EMCY sent with a transition), else there must be none."""
    for i, command in commands.items():
        for pdo in LAYOUT.rpdos:
            buf = bytearray(pdo.length)
            pdo.pack_into(buf, list(command))
            link.send(pdo.cob_id(i), buf)
    link.send(c.SYNC, b"")
    extra = 0 if others is None else len(others)
    frames = link.collect(len(link.ids) * len(LAYOUT.tpdos) + extra)
    by_cob = {p.cob_id(i): (i, p) for i in link.ids for p in LAYOUT.tpdos}
    out, seen = {i: [None] * 4 for i in link.ids}, set()
    if others is not None:
        others[:] = [f for f in frames if f.arbitration_id not in by_cob]
        frames = [f for f in frames if f.arbitration_id in by_cob]
    for f in frames:
        assert f.arbitration_id not in seen, f"two frames on {f.arbitration_id:#x} for one SYNC"
        seen.add(f.arbitration_id)
        i, pdo = by_cob[f.arbitration_id]
        assert len(f.data) == pdo.length
        pdo.unpack_into(f.data, out[i])
    assert seen == set(by_cob), "a TPDO is missing"
    return out


def enable_all(link):
    for cw in (c.CW_SHUTDOWN, c.CW_SWITCH_ON, c.CW_ENABLE_OPERATION):
        states = sync_cycle(link, {i: (cw, 0) for i in link.ids})
    assert all(c.state_of(s[SW]) == c.OPERATION_ENABLED for s in states.values())


class TestCia402BackToBack:
    def test_sdo_and_nmt_through_python_canopen(self, cia402_link):
        link = cia402_link
        with canopen_master(link) as (network, nodes):
            node = nodes[2]
            assert node.sdo[c.DEVICE_TYPE].raw & 0xFFFF == c.PROFILE_402
            assert node.sdo[c.RATED_TORQUE].raw == 10_000  # the stand-in's 10 N·m, in mN·m
            node.sdo[c.MODES_OF_OPERATION].raw = c.CST
            assert node.sdo[c.MODES_DISPLAY].raw == c.CST  # the drive's live value
            assert link.drives.drives[2].mode == c.CST and link.drives.drives[1].mode == 0
            node.pdo.read()  # the mapping, uploaded: the EDS's
            assert [v.index for v in node.tpdo[1]] == [c.STATUSWORD, c.POSITION, c.TORQUE]
            node.sdo[c.HEARTBEAT_TIME].raw = 20  # ms
            node.nmt.state = "OPERATIONAL"
            beats = []
            node.nmt.add_heartbeat_callback(beats.append)
            deadline = time.monotonic() + 2.0  # bounds a failure only: a beat every 20 ms
            while len(beats) < 3 and time.monotonic() < deadline:
                time.sleep(0.01)  # (the Notifier reads the bus here: no recv of ours)
                link.pump()  # (lock-step: the drives' heartbeat is due on their next service)
        assert beats[-3:] == [c.NMT_OPERATIONAL] * 3 and link.drives.drives[2].nmt_state == "OPERATIONAL"
        assert link.drives.drives[1].nmt_state == "PRE-OPERATIONAL"

    def test_the_state_machine_and_the_torque_on_sync(self, cia402_link):
        link = cia402_link
        start(link)
        for i in link.ids:
            link.drives.drives[i].port.position = 0.25 * i
        first = sync_cycle(link, {i: (c.CW_DISABLE_VOLTAGE, 0) for i in link.ids})
        assert all(c.state_of(s[SW]) == c.SWITCH_ON_DISABLED for s in first.values())
        cpr = (1 << 20) / (2 * 3.141592653589793)
        assert [first[i][POS] for i in link.ids] == [round(0.25 * i * cpr) for i in link.ids]
        enable_all(link)
        # an RPDO alone changes nothing: it applies at the next SYNC
        pdo = LAYOUT.rpdos[0]
        buf = bytearray(pdo.length)
        pdo.pack_into(buf, [c.CW_ENABLE_OPERATION, 500])
        link.send(pdo.cob_id(1), buf)
        assert link.quiet() and link.drives.drives[1].torque == 0.0
        states = sync_cycle(link, {i: (c.CW_ENABLE_OPERATION, 100 * i) for i in link.ids})
        for i in link.ids:  # ‰ of the 10 N·m rated torque, applied and reported
            assert link.drives.drives[i].torque == pytest.approx(10.0 * 100 * i / 1000)
            assert states[i][TRQ] == 100 * i and states[i][SW] & c.SW_FOLLOWING
        assert link.quiet()
        assert [link.drives.drives[i].transitions for i in link.ids] == [[1, 2, 3, 4]] * 3

    def test_a_fault_is_an_emcy_and_a_reset_recovers(self, cia402_link):
        link = cia402_link
        start(link)
        sync_cycle(link, {i: (c.CW_DISABLE_VOLTAGE, 0) for i in link.ids})
        enable_all(link)
        drive = link.drives.drives[3]
        drive.set_error(0x2310)  # "continuous over current": the EMCY leaves with the next frames it sends
        others = [None]
        states = sync_cycle(link, {i: (c.CW_ENABLE_OPERATION, 300) for i in link.ids}, others)
        (emcy,) = others
        assert emcy.arbitration_id == c.EMCY_BASE + 3 and c.emcy_code(emcy.data) == 0x2310
        assert c.state_of(states[3][SW]) == c.FAULT and states[3][TRQ] == 0 and drive.torque == 0.0
        assert c.state_of(states[1][SW]) == c.OPERATION_ENABLED  # the others run on
        frames = [None]  # the EMCY "error reset", sent with the transition
        sync_cycle(link, {3: (c.CW_FAULT_RESET, 0), 1: (c.CW_DISABLE_VOLTAGE, 0), 2: (c.CW_DISABLE_VOLTAGE, 0)}, frames)
        assert [(f.arbitration_id, c.emcy_code(f.data)) for f in frames] == [(c.EMCY_BASE + 3, 0)]
        assert drive.state == c.SWITCH_ON_DISABLED and drive.error_code == 0 and drive.transitions[-1] == 15

    def test_malformed_rpdos_and_corrupted_tpdos_are_counted(self, cia402_link):
        link = cia402_link
        start(link)
        drive = link.drives.drives[1]
        link.send(LAYOUT.rpdos[0].cob_id(1), b"\x0f\x00\x10")  # one byte short
        link.send(c.NMT, b"\x01")  # an NMT command without its node id
        assert link.quiet() and drive.counters.malformed == 1 + 1
        drive.faults.corrupt_rate = 1.0
        for pdo in LAYOUT.rpdos:
            link.send(pdo.cob_id(1), bytes(pdo.length))
        link.send(c.SYNC, b"")
        frames = {f.arbitration_id: f for f in link.collect(len(link.ids) * len(LAYOUT.tpdos))}
        for pdo in LAYOUT.tpdos:
            assert len(frames[pdo.cob_id(1)].data) == pdo.length - 1
            assert len(frames[pdo.cob_id(2)].data) == pdo.length
        assert drive.counters.corrupted == len(LAYOUT.tpdos)

    def test_the_rpdo_deadline_faults_the_drive(self, cia402_link):
        link = cia402_link
        start(link)
        sync_cycle(link, {i: (c.CW_DISABLE_VOLTAGE, 0) for i in link.ids})
        for d in link.drives.drives.values():
            d.timeout_s = 10.0
        link.drives.drives[1].timeout_s = 0.020  # as 0x1400 sub 5 = 20 written by SDO
        enable_all(link)
        drive = link.drives.drives[1]
        deadline = time.monotonic() + 5.0  # bounds a failure only; the drive trips 20 ms after
        while drive.state != c.FAULT and time.monotonic() < deadline:
            link.quiet(0.01)  # no RPDO: the deadline must fire (lock-step: on the next pump)
        assert drive.state == c.FAULT and drive.error_code == c.EMCY_RPDO_TIMEOUT
        assert drive.counters.watchdog_trips == 1 and drive.torque == 0.0
        assert all(link.drives.drives[i].enabled for i in (2, 3))
