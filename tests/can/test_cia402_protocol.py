"""The CiA 402 layer both ends share (drivers.protocols.cia402): the drive's state machine
against python-canopen's transition table and the standard's numbering, the statusword both
ways, the master's walk to OPERATION ENABLED from every state, a fault in every state of the
emulated drive, and the PDO codec against python-canopen's own PDO maps of the shipped EDS."""
import can
import canopen
import pytest
from canopen.emcy import EMCY_STRUCT
from canopen.objectdictionary import datatypes
from canopen.profiles.p402 import OperationMode, State402

from drivers.protocols import cia402 as c
from hil_sim.cia402_drive import Cia402Drive
from hil_sim.mit_drive import InertiaJoint
from rtctl import busload

# CiA 402-2 Figure 23: the numbered transitions a controlword commands, written out here
NUMBERED = {
    (c.SWITCH_ON_DISABLED, c.READY): 2, (c.READY, c.SWITCHED_ON): 3, (c.SWITCHED_ON, c.OPERATION_ENABLED): 4,
    (c.OPERATION_ENABLED, c.SWITCHED_ON): 5, (c.SWITCHED_ON, c.READY): 6, (c.READY, c.SWITCH_ON_DISABLED): 7,
    (c.OPERATION_ENABLED, c.READY): 8, (c.OPERATION_ENABLED, c.SWITCH_ON_DISABLED): 9,
    (c.SWITCHED_ON, c.SWITCH_ON_DISABLED): 10, (c.OPERATION_ENABLED, c.QUICK_STOP): 11,
    (c.QUICK_STOP, c.SWITCH_ON_DISABLED): 12, (c.FAULT, c.SWITCH_ON_DISABLED): 15,
    (c.QUICK_STOP, c.OPERATION_ENABLED): 16,
}
DEVICE_STATES = (c.SWITCH_ON_DISABLED, c.READY, c.SWITCHED_ON, c.OPERATION_ENABLED, c.QUICK_STOP, c.FAULT)


@pytest.mark.parametrize(("edge", "number"), NUMBERED.items(), ids=lambda x: str(x))
def test_every_commanded_transition_follows_python_canopens_table(edge, number):
    # the controlword python-canopen's master sends for this edge takes our drive along it
    controlword = State402.TRANSITIONTABLE[edge]
    assert c.device_transition(edge[0], controlword, 0x00) == (edge[1], number)


def test_every_transition_number_of_the_graph_is_covered():
    taken = set(NUMBERED.values()) | {n for _, n in c.AUTOMATIC.values()}
    assert taken | {0, 13} == set(range(17))  # 0: power-on, 13: a fault (both the drive's own)


def test_automatic_transitions_and_quick_stop_from_the_lower_states():
    assert c.AUTOMATIC == {c.NOT_READY: (c.SWITCH_ON_DISABLED, 1), c.FAULT_REACTION: (c.FAULT, 14)}
    assert c.device_transition(c.READY, c.CW_QUICK_STOP, 0) == (c.SWITCH_ON_DISABLED, 7)
    assert c.device_transition(c.SWITCHED_ON, c.CW_QUICK_STOP, 0) == (c.SWITCH_ON_DISABLED, 10)
    # "switch on + enable operation" from READY TO SWITCH ON: 3 and 4 in one step
    assert c.device_transition(c.READY, c.CW_ENABLE_OPERATION, 0) == (c.OPERATION_ENABLED, 4)


def command_of(cw):
    """CiA 402-2 Table 26 by its bits (7 fault reset, 3 enable operation, 2 quick stop (low
    active), 1 enable voltage, 0 switch on): the device-control command, None for none."""
    if cw & 0x80:
        return None  # a fault reset: a command of the FAULT state only
    if not cw & 0b0010:
        return c.CW_DISABLE_VOLTAGE
    if not cw & 0b0100:
        return c.CW_QUICK_STOP
    if not cw & 0b0001:
        return c.CW_SHUTDOWN
    return c.CW_ENABLE_OPERATION if cw & 0b1000 else c.CW_SWITCH_ON


@pytest.mark.parametrize("state", [s for s in DEVICE_STATES if s != c.FAULT])
def test_every_controlword_acts_as_the_command_its_bits_encode(state):
    for cw in range(0x100):  # bits 4-6 (mode specific) never change the command
        command = command_of(cw)
        expected = (state, None) if command is None else c.device_transition(state, command, 0)
        assert c.device_transition(state, cw, 0) == expected, hex(cw)


# (state, controlword) pairs that move the drive: python-canopen's table and the three above
APPLIES = {(frm, cw) for (frm, _), cw in State402.TRANSITIONTABLE.items()} | {
    (c.READY, c.CW_QUICK_STOP), (c.SWITCHED_ON, c.CW_QUICK_STOP), (c.READY, c.CW_ENABLE_OPERATION)}


@pytest.mark.parametrize("state", DEVICE_STATES)
def test_commands_that_do_not_apply_leave_the_state(state):
    for cw in (c.CW_SHUTDOWN, c.CW_SWITCH_ON, c.CW_ENABLE_OPERATION, c.CW_DISABLE_VOLTAGE, c.CW_QUICK_STOP,
               c.CW_FAULT_RESET | c.CW_ENABLE_OPERATION):
        if (state, cw) not in APPLIES:
            assert c.device_transition(state, cw, cw) == (state, None), hex(cw)
    # a fault reset needs the rising edge of bit 7
    assert c.device_transition(c.FAULT, c.CW_FAULT_RESET, c.CW_FAULT_RESET) == (c.FAULT, None)


@pytest.mark.parametrize("state", c.STATES)
def test_statusword_round_trip_through_python_canopens_masks(state):
    word = c.statusword_of(state)
    assert c.state_of(word) == state
    assert bool(word & c.SW_VOLTAGE_ENABLED) == (state not in (c.NOT_READY, c.SWITCH_ON_DISABLED, c.FAULT))
    assert c.is_operation_enabled(word) == (state == c.OPERATION_ENABLED)
    assert c.is_fault(word) == (state == c.FAULT)
    # bit 9 remote: the controlword is obeyed; bit 12 in CST: the target torque is followed
    assert word & 0x0200 and bool(word & 0x1000) == (state == c.OPERATION_ENABLED)


@pytest.mark.parametrize("start", c.STATES)
def test_the_master_walks_every_state_to_operation_enabled(start):
    state, previous = start, c.CW_DISABLE_VOLTAGE
    for step in range(8):
        state = c.AUTOMATIC.get(state, (state, None))[0]
        if state == c.OPERATION_ENABLED:
            break
        cw = c.controlword_towards_operation(c.state_of(c.statusword_of(state)), previous)
        before, (state, _) = state, c.device_transition(state, cw, previous)
        # every step is python-canopen's controlword for its edge (or, in FAULT, bit 7 low for the edge)
        assert cw == State402.TRANSITIONTABLE.get((before, state), 0x00), (before, state, hex(cw))
        previous = cw
    assert state == c.OPERATION_ENABLED and step <= 5, (start, step)


def drive_in(state):
    """An emulated drive brought to ``state`` through its controlword, as a master would."""
    d = Cia402Drive(1, InertiaJoint(), rated_torque=5.0)
    paths = {c.SWITCH_ON_DISABLED: (), c.READY: (c.CW_SHUTDOWN,), c.SWITCHED_ON: (c.CW_SHUTDOWN, c.CW_SWITCH_ON),
             c.OPERATION_ENABLED: (c.CW_SHUTDOWN, c.CW_SWITCH_ON, c.CW_ENABLE_OPERATION),
             c.QUICK_STOP: (c.CW_SHUTDOWN, c.CW_SWITCH_ON, c.CW_ENABLE_OPERATION, c.CW_QUICK_STOP)}
    for cw in paths[state]:
        d.apply_controlword(cw)
    assert d.state == state
    return d


@pytest.mark.parametrize("state", (c.SWITCH_ON_DISABLED, c.READY, c.SWITCHED_ON, c.OPERATION_ENABLED, c.QUICK_STOP))
def test_a_fault_in_each_state_is_an_emcy_and_torque_off(state):
    d = drive_in(state)
    d.torque_permille = 400
    d._apply_torque()
    d.network.outbox.clear()
    d.set_error(0x3210)  # DC link over-voltage
    assert d.state == c.FAULT_REACTION and d.torque == 0.0 and d.port.tau == 0.0
    d.update(0.0)
    assert d.state == c.FAULT and d.transitions[-2:] == [13, 14]
    ((cob, payload),) = d.network.outbox
    assert cob == c.EMCY_BASE + 1 and EMCY_STRUCT.unpack(payload)[:2] == (0x3210, 0x01)
    d.apply_controlword(c.CW_ENABLE_OPERATION)  # nothing but a fault reset leaves FAULT
    assert d.state == c.FAULT and d.error_code == 0x3210


def test_a_second_fault_while_faulted_is_not_a_new_emcy():
    d = drive_in(c.OPERATION_ENABLED)
    d.set_error(0x3210)
    d.update(0.0)
    d.set_error(0x4310)
    assert d.error_code == 0x3210 and d.counters.emcys == 1


def shipped_node():
    """python-canopen's own reading of the shipped EDS's PDO maps (no bus needed)."""
    node = canopen.RemoteNode(5, canopen.import_od(str(c.EDS), 5))
    canopen.Network().add_node(node)
    node.pdo.read(from_od=True)
    return node


def test_the_pdo_layout_is_python_canopens_reading_of_the_eds():
    node, layout = shipped_node(), c.PdoLayout.from_eds()
    for ours, maps in ((layout.rpdos, node.rpdo.map), (layout.tpdos, node.tpdo.map)):
        theirs = [m for m in maps.values() if m.enabled and len(m)]
        assert [p.cob_id(5) for p in ours] == [m.cob_id for m in theirs]
        for pdo, m in zip(ours, theirs):
            assert [(v.index, v.offset, v.length) for v in m] == [
                (i, 8 * off, 8 * size) for i, off, size in _fields(pdo)]
    assert busload.PROTOCOLS["cia402"].per_joint == layout.frame_lengths == (4, 8, 4)


def test_a_pdo_layout_cannot_be_changed_in_place():
    """One layout serves every drive on the bus, and each PDO's codec is built from its slots once."""
    import dataclasses

    layout = c.PdoLayout.from_eds()
    pdo = layout.tpdos[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        pdo.slots = pdo.slots[::-1]
    with pytest.raises(dataclasses.FrozenInstanceError):
        layout.tpdos = layout.tpdos[:1]


def _fields(pdo):
    index = {name: i for i, name in {**c.COMMAND_FIELDS, **c.STATE_FIELDS}.items()}
    out, offset = [], 0
    for name, char in zip(pdo.fields, pdo.struct.format[1:]):
        size = {"h": 2, "H": 2, "i": 4, "I": 4, "b": 1, "B": 1}[char]
        out.append((index[name], offset, size))
        offset += size
    return out


@pytest.mark.parametrize("values", [(0x1237, -123456, 987654, -250), (0x0208, 2**31 - 1, -(2**31), 32767)])
def test_tpdo_codec_matches_python_canopens_pdo_variables(values):
    node, layout = shipped_node(), c.PdoLayout.from_eds()
    names = {c.STATUSWORD: "Statusword", c.POSITION: "Position actual value", c.VELOCITY: "Velocity actual value",
             c.TORQUE: "Torque actual value"}
    by_field = dict(zip(c.STATE_FIELDS.values(), values))
    for pdo, m in zip(layout.tpdos, (node.tpdo[1], node.tpdo[2])):
        for index, name in names.items():
            if c.STATE_FIELDS[index] in pdo.fields:
                m[name].raw = by_field[c.STATE_FIELDS[index]]
        buf = bytearray(pdo.length)
        pdo.pack_into(buf, list(values))
        assert bytes(buf) == bytes(m.data)
        back = [None] * 4
        pdo.unpack_into(bytes(m.data), back)
        assert all(back[s] == values[s] for s in pdo.slots)


def test_a_pdo_set_the_driver_cannot_use_is_refused():
    od = canopen.import_od(str(c.EDS), 0)
    od[c.TPDO_MAP + 1][1].default = 0x60610008  # modes display instead of velocity
    with pytest.raises(ValueError, match="PDO mapping 0x1a01: object 0x6061 is not one"):
        c.PdoLayout.from_od(od)
    od = canopen.import_od(str(c.EDS), 0)
    od[c.TPDO_MAP + 1][0].default = 0  # velocity not mapped anywhere
    with pytest.raises(ValueError, match="0x606c"):
        c.PdoLayout.from_od(od)
    for entry, match in ((0x60410010, "mapping 0x1a01: object 0x6041 is mapped twice"),
                         (0x606C0010, "mapping 0x1a01: 16 bits for 0x606c, a 32-bit object"), (0x606C0021, "33 bits for 0x606c")):
        od = canopen.import_od(str(c.EDS), 0)
        od[c.TPDO_MAP + 1][1].default = entry
        with pytest.raises(ValueError, match=match):
            c.PdoLayout.from_od(od)
    od = canopen.import_od(str(c.EDS), 0)
    del od[c.TPDO_MAP + 1]  # TPDO2's communication parameter without its mapping: no PDO
    with pytest.raises(ValueError, match="0x606c"):
        c.PdoLayout.from_od(od)
    # an 8-bit statusword, position and velocity in TPDO1 (torque in TPDO2): 9 bytes
    od = canopen.import_od(str(c.EDS), 0)
    od[c.STATUSWORD].data_type = datatypes.UNSIGNED8
    od[c.TPDO_MAP][1].default, od[c.TPDO_MAP][3].default = 0x60410008, 0x606C0020
    od[c.TPDO_MAP + 1][1].default = 0x60770010
    with pytest.raises(ValueError, match="longer than 8 bytes"):
        c.PdoLayout.from_od(od)


def eds_variant(tmp_path, *edits):
    text = c.EDS.read_text()
    for old, new in edits:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "variant.eds"
    path.write_text(text)
    return path


def test_the_four_predefined_pdos_are_read_and_no_other(tmp_path):
    # TPDO2's objects in TPDO4 (COB-ID 0x480 + id)
    path = eds_variant(tmp_path, ("1801", "1803"), ("1A01", "1A03"), ("$NODEID+0x280", "$NODEID+0x480"))
    node = canopen.RemoteNode(5, canopen.import_od(str(path), 5))
    canopen.Network().add_node(node)
    node.pdo.read(from_od=True)
    theirs = [(k, m.cob_id) for k, m in node.tpdo.map.items() if m.enabled and len(m)]
    assert [(p.number, p.cob_id(5)) for p in c.PdoLayout.from_eds(path).tpdos] == theirs == [(1, 0x185), (4, 0x485)]
    # in TPDO5, outside the predefined connection set, or in a disabled TPDO2: velocity is missing
    for edits in ((("1801", "1804"), ("1A01", "1A04")), (("$NODEID+0x280", "0x80000280"),)):
        with pytest.raises(ValueError, match="0x606c"):
            c.PdoLayout.from_eds(eds_variant(tmp_path, *edits))
    # a disabled TPDO2 before it is skipped, not the end of the search
    path = eds_variant(tmp_path, ("1801", "1803"), ("1A01", "1A03"), ("$NODEID+0x280", "$NODEID+0x480"))
    od = canopen.import_od(str(path), 0)
    for record in (c.TPDO_COMM + 1, c.TPDO_MAP + 1):
        od.add_object(canopen.import_od(str(c.EDS), 0)[record])
    od[c.TPDO_COMM + 1][1].default |= 0x8000_0000
    assert [p.number for p in c.PdoLayout.from_od(od).tpdos] == [1, 4]


def test_cob_ids_states_and_modes_are_python_canopens(tmp_path):
    network = canopen.Network()
    network.connect(interface="virtual", channel=f"cia402-{tmp_path.name}", receive_own_messages=False)
    spy = can.Bus(interface="virtual", channel=f"cia402-{tmp_path.name}")
    try:
        node = network.add_node(canopen.RemoteNode(5, canopen.import_od(str(c.EDS), 5)))
        # what its master listens to: SDO answers, heartbeats, EMCYs of node 5
        assert {c.SDO_TX_BASE + 5, c.HEARTBEAT_BASE + 5, c.EMCY_BASE + 5} <= set(network.subscribers)
        assert (node.sdo.rx_cobid, node.sdo.tx_cobid) == (c.SDO_RX_BASE + 5, c.SDO_TX_BASE + 5)
        network.sync.transmit()
        node.nmt.send_command(0x01)  # start remote node
        sent = [spy.recv(1.0) for _ in range(2)]
        assert [m.arbitration_id for m in sent] == [c.SYNC, c.NMT] and bytes(sent[1].data) == b"\x01\x05"
    finally:
        network.disconnect()
        spy.shutdown()
    names = (c.NMT_OPERATIONAL, c.NMT_PRE_OPERATIONAL, c.NMT_STOPPED, c.NMT_BOOTUP)
    assert [canopen.nmt.NMT_STATES[k] for k in names] == ["OPERATIONAL", "PRE-OPERATIONAL", "STOPPED", "INITIALISING"]
    assert c.CST == OperationMode.CYCLIC_SYNCHRONOUS_TORQUE
    assert c.CST_SUPPORTED == OperationMode.SUPPORTED["CYCLIC SYNCHRONOUS TORQUE"]


# CiA 301 / CiA 402-2 names of the objects the driver and the emulated drive exchange
STANDARD_OBJECTS = [  # (index, name): a list, so that two constants with one index both show
    (c.DEVICE_TYPE, "Device type"), (c.ERROR_REGISTER, "Error register"), (c.HEARTBEAT_TIME, "Producer heartbeat time"),
    (c.ERROR_CODE, "Error code"), (c.CONTROLWORD, "Controlword"), (c.STATUSWORD, "Statusword"),
    (c.MODES_OF_OPERATION, "Modes of operation"), (c.MODES_DISPLAY, "Modes of operation display"),
    (c.POSITION, "Position actual value"), (c.VELOCITY, "Velocity actual value"), (c.TARGET_TORQUE, "Target torque"),
    (c.MAX_TORQUE, "Max torque"), (c.RATED_TORQUE, "Motor rated torque"), (c.TORQUE, "Torque actual value"),
    (c.ENCODER_RESOLUTION, "Position encoder resolution"), (c.SUPPORTED_MODES, "Supported drive modes"),
    (c.RPDO_COMM, "RPDO1 communication parameter"), (c.RPDO_MAP, "RPDO1 mapping parameter"),
    (c.TPDO_COMM, "TPDO1 communication parameter"), (c.TPDO_MAP, "TPDO1 mapping parameter"),
]


def test_object_indices_name_the_standards_objects():
    od = canopen.import_od(str(c.EDS), 1)
    assert [(index, od[index].name) for index, _ in STANDARD_OBJECTS] == STANDARD_OBJECTS
    assert od[c.RPDO_COMM][c.EVENT_TIMER].name == "Event timer"


def test_emcy_frames():
    # CiA 301: 0x8250 "RPDO timeout", error register 0x11 (generic + communication)
    assert c.emcy_code(bytes.fromhex("50 82 11 00 00 00 00 00")) == c.EMCY_RPDO_TIMEOUT
    assert c.emcy_code(EMCY_STRUCT.pack(0x8250, 0x11, b"")) == 0x8250
    assert c.emcy_code(b"\x50\x82\x11") is None
    assert c.emcy_description(c.EMCY_RPDO_TIMEOUT) == "Monitoring"
