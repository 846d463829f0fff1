"""The CiA 402 layer both ends share (drivers.protocols.cia402): the drive's state machine
against python-canopen's transition table and the standard's numbering, the statusword both
ways, the master's walk to OPERATION ENABLED from every state, a fault in every state of the
emulated drive, and the PDO codec against python-canopen's own PDO maps of the shipped EDS."""
import canopen
import pytest
from canopen.emcy import EMCY_STRUCT
from canopen.profiles.p402 import State402

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


@pytest.mark.parametrize("start", c.STATES)
def test_the_master_walks_every_state_to_operation_enabled(start):
    state, previous = start, c.CW_DISABLE_VOLTAGE
    for step in range(8):
        state = c.AUTOMATIC.get(state, (state, None))[0]
        if state == c.OPERATION_ENABLED:
            break
        cw = c.controlword_towards_operation(c.state_of(c.statusword_of(state)), previous)
        state, _ = c.device_transition(state, cw, previous)
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
    with pytest.raises(ValueError, match="0x6061"):
        c.PdoLayout.from_od(od)
    od = canopen.import_od(str(c.EDS), 0)
    od[c.TPDO_MAP + 1][0].default = 0  # velocity not mapped anywhere
    with pytest.raises(ValueError, match="0x606c"):
        c.PdoLayout.from_od(od)


def test_emcy_frames():
    assert c.emcy_code(EMCY_STRUCT.pack(0x8250, 0x11, b"")) == 0x8250
    assert c.emcy_code(b"\x50\x82\x11") is None
    assert c.emcy_description(c.EMCY_RPDO_TIMEOUT) == "Monitoring"
