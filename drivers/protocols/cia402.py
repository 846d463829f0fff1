"""CANopen CiA 402 in cyclic synchronous torque (CST): what both ends of the wire share — the
``cia402`` driver (:mod:`drivers.cia402_joints`) and hil_sim's emulated drive
(:mod:`hil_sim.cia402_drive`).

* **COB-IDs** (CiA 301 predefined connection set): NMT 0x000, SYNC 0x080, EMCY 0x080 + id,
  TPDO k 0x180 + 0x100 (k − 1) + id, RPDO k 0x200 + 0x100 (k − 1) + id, SDO 0x580/0x600 + id,
  heartbeat 0x700 + id.
* **The PDO set** is the default mapping of the drives' EDS (:data:`EDS`, shipped with the
  driver, or a drive's own): :meth:`PdoLayout.from_od` reads it into one :class:`Pdo` per
  mapped PDO, whose ``struct`` packs and unpacks the frame. The RPDOs carry the controlword
  0x6040 and the target torque 0x6071; the TPDOs the statusword 0x6041, position 0x6064,
  velocity 0x606C and torque 0x6077. Transmission type 1: an RPDO applies at the next SYNC,
  every TPDO goes out on every SYNC.
* **The drive's state machine** (CiA 402-2 §6.2, the "FSA"): :func:`device_transition` is
  the drive's side (controlword in, next state out, with the transition's number);
  :func:`controlword_towards_operation` the master's next command on the way to OPERATION
  ENABLED, from python-canopen's own transition table (:class:`canopen.profiles.p402.State402`),
  whose state names and statusword masks both ends use.

Units on the wire: torque in per mille of the rated torque 0x6076 (mN·m); position and
velocity in encoder increments (0x608F: increments per revolution) and increments per second.
"""
from __future__ import annotations

import operator
import struct
from dataclasses import dataclass
from pathlib import Path

import canopen
from canopen.emcy import EMCY_STRUCT, EmcyError
from canopen.objectdictionary import ODArray, ODRecord, datatypes
from canopen.profiles.p402 import State402

EDS = Path(__file__).with_name("cia402_cst.eds")

# -- COB-IDs and objects ----------------------------------------------------------------------
NMT, SYNC = 0x000, 0x080
EMCY_BASE, SDO_TX_BASE, SDO_RX_BASE, HEARTBEAT_BASE = 0x080, 0x580, 0x600, 0x700
TPDO_BASE, RPDO_BASE = 0x180, 0x200  # + 0x100 per PDO number − 1

DEVICE_TYPE, ERROR_REGISTER, HEARTBEAT_TIME = 0x1000, 0x1001, 0x1017
RPDO_COMM, RPDO_MAP, TPDO_COMM, TPDO_MAP = 0x1400, 0x1600, 0x1800, 0x1A00
EVENT_TIMER = 5  # sub-index of a PDO communication record: for an RPDO, its deadline (ms)
ERROR_CODE, CONTROLWORD, STATUSWORD = 0x603F, 0x6040, 0x6041
MODES_OF_OPERATION, MODES_DISPLAY = 0x6060, 0x6061
POSITION, VELOCITY, TARGET_TORQUE, MAX_TORQUE, RATED_TORQUE, TORQUE = 0x6064, 0x606C, 0x6071, 0x6072, 0x6076, 0x6077
ENCODER_RESOLUTION, SUPPORTED_MODES = 0x608F, 0x6502

PROFILE_402 = 402  # device type 0x1000, low 16 bits
CST = 10  # mode of operation 0x6060: cyclic synchronous torque
CST_SUPPORTED = 1 << 9  # its bit in 0x6502
NMT_OPERATIONAL, NMT_PRE_OPERATIONAL, NMT_STOPPED, NMT_BOOTUP = 5, 127, 4, 0  # heartbeat states

# -- EMCY (CiA 301 §7.2.7.1) -------------------------------------------------------------------
EMCY_RPDO_TIMEOUT = 0x8250  # the RPDO deadline expired: our commands stopped arriving
EMCY_LENGTH = EMCY_STRUCT.size


def emcy_code(data) -> int | None:
    """The error code of an EMCY frame (0 = error reset), None for a malformed frame."""
    if len(data) != EMCY_LENGTH:
        return None
    return data[0] | data[1] << 8


def emcy_description(code: int) -> str:
    return EmcyError(code, 0, b"", 0.0).get_desc() or "manufacturer specific"


# -- state machine ------------------------------------------------------------------------------
NOT_READY, SWITCH_ON_DISABLED = "NOT READY TO SWITCH ON", "SWITCH ON DISABLED"
READY, SWITCHED_ON, OPERATION_ENABLED = "READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED"
QUICK_STOP, FAULT_REACTION, FAULT = "QUICK STOP ACTIVE", "FAULT REACTION ACTIVE", "FAULT"
STATES = tuple(State402.SW_MASK)

CW_DISABLE_VOLTAGE, CW_QUICK_STOP, CW_SHUTDOWN = 0x00, 0x02, 0x06
CW_SWITCH_ON, CW_ENABLE_OPERATION, CW_FAULT_RESET = 0x07, 0x0F, 0x80

# statusword bits 0-3, 5, 6 of each state (its SW_MASK value); bit 4 "voltage enabled" where the
# power stage is on; bit 9 "remote" (controlled by the controlword); bit 12 in CST: following the target
SW_VOLTAGE_ENABLED, SW_REMOTE, SW_FOLLOWING = 0x0010, 0x0200, 0x1000
_POWERED = (READY, SWITCHED_ON, OPERATION_ENABLED, QUICK_STOP, FAULT_REACTION)
OE_MASK, OE_VALUE = State402.SW_MASK[OPERATION_ENABLED]
FAULT_MASK, FAULT_VALUE = State402.SW_MASK[FAULT]


def statusword_of(state: str) -> int:
    """The statusword a drive in ``state`` reports."""
    word = State402.SW_MASK[state][1] | SW_REMOTE
    if state in _POWERED:
        word |= SW_VOLTAGE_ENABLED
    if state == OPERATION_ENABLED:
        word |= SW_FOLLOWING
    return word


def state_of(statusword: int) -> str:
    """The state a statusword reports (python-canopen's masks); 'UNKNOWN' for none."""
    for state, (mask, value) in State402.SW_MASK.items():
        if statusword & mask == value:
            return state
    return "UNKNOWN"


def is_operation_enabled(statusword: int) -> bool:
    return statusword & OE_MASK == OE_VALUE


def is_fault(statusword: int) -> bool:
    return statusword & FAULT_MASK == FAULT_VALUE


def _command(cw: int) -> str | None:
    """Decode a controlword's device-control command (CiA 402-2 Table 26; bit 7 must be 0)."""
    if cw & 0x82 == 0x00:
        return "disable voltage"
    if cw & 0x86 == 0x02:
        return "quick stop"
    if cw & 0x87 == 0x06:
        return "shutdown"
    if cw & 0x8F == 0x07:
        return "switch on"  # also "disable operation" from OPERATION ENABLED
    if cw & 0x8F == 0x0F:
        return "enable operation"  # also "switch on + enable operation" from READY TO SWITCH ON
    return None


# (state, command) → (next state, transition number of CiA 402-2 Figure 23)
_TRANSITIONS = {
    (SWITCH_ON_DISABLED, "shutdown"): (READY, 2),
    (READY, "switch on"): (SWITCHED_ON, 3),
    (READY, "enable operation"): (OPERATION_ENABLED, 4),  # 3 then 4 in one step
    (READY, "disable voltage"): (SWITCH_ON_DISABLED, 7),
    (READY, "quick stop"): (SWITCH_ON_DISABLED, 7),
    (SWITCHED_ON, "enable operation"): (OPERATION_ENABLED, 4),
    (SWITCHED_ON, "shutdown"): (READY, 6),
    (SWITCHED_ON, "disable voltage"): (SWITCH_ON_DISABLED, 10),
    (SWITCHED_ON, "quick stop"): (SWITCH_ON_DISABLED, 10),
    (OPERATION_ENABLED, "switch on"): (SWITCHED_ON, 5),
    (OPERATION_ENABLED, "shutdown"): (READY, 8),
    (OPERATION_ENABLED, "disable voltage"): (SWITCH_ON_DISABLED, 9),
    (OPERATION_ENABLED, "quick stop"): (QUICK_STOP, 11),
    (QUICK_STOP, "disable voltage"): (SWITCH_ON_DISABLED, 12),
    (QUICK_STOP, "enable operation"): (OPERATION_ENABLED, 16),
}
AUTOMATIC = {NOT_READY: (SWITCH_ON_DISABLED, 1), FAULT_REACTION: (FAULT, 14)}


def device_transition(state: str, controlword: int, previous: int) -> tuple[str, int | None]:
    """The drive's side of the FSA: the state after ``controlword`` (``previous`` is the
    controlword before it, for the fault reset's rising edge) and the transition's number, or
    ``(state, None)`` when the command does not apply in ``state``. Automatic transitions (0,
    1, 13, 14) are the drive's own (:data:`AUTOMATIC`)."""
    if state == FAULT:
        if controlword & CW_FAULT_RESET and not previous & CW_FAULT_RESET:
            return SWITCH_ON_DISABLED, 15
        return state, None
    nxt = _TRANSITIONS.get((state, _command(controlword)))
    return nxt if nxt is not None else (state, None)


def controlword_towards_operation(state: str, previous: int) -> int:
    """The master's next controlword on the way from ``state`` to OPERATION ENABLED
    (python-canopen's transition table; a fault is reset on a rising edge of bit 7)."""
    if state == OPERATION_ENABLED:
        return CW_ENABLE_OPERATION
    if state == FAULT:
        return CW_DISABLE_VOLTAGE if previous & CW_FAULT_RESET else CW_FAULT_RESET
    table = State402.TRANSITIONTABLE
    nxt = OPERATION_ENABLED if (state, OPERATION_ENABLED) in table else State402.next_state_indirect(state)
    return table.get((state, nxt), CW_DISABLE_VOLTAGE)


# -- the PDO set --------------------------------------------------------------------------------
COMMAND_FIELDS = {CONTROLWORD: "controlword", TARGET_TORQUE: "target_torque"}  # RPDO contents
STATE_FIELDS = {STATUSWORD: "statusword", POSITION: "position", VELOCITY: "velocity", TORQUE: "torque"}  # TPDO
_STRUCT_CHAR = {datatypes.INTEGER8: "b", datatypes.UNSIGNED8: "B", datatypes.INTEGER16: "h",
                datatypes.UNSIGNED16: "H", datatypes.INTEGER32: "i", datatypes.UNSIGNED32: "I"}


@dataclass(frozen=True)
class Pdo:
    """One mapped PDO: ``slots[i]`` is the position, in :data:`COMMAND_FIELDS` (RPDO) or
    :data:`STATE_FIELDS` (TPDO) order, of the frame's i-th value."""

    number: int  # 1 …
    cob_base: int  # its COB-ID is cob_base + node id
    fields: tuple[str, ...]
    slots: tuple[int, ...]
    struct: struct.Struct  # little-endian, one item per field

    def __post_init__(self):
        object.__setattr__(self, "_pick", operator.itemgetter(*self.slots) if len(self.slots) > 1
                           else (lambda values, s=self.slots[0]: (values[s],)))

    @property
    def length(self) -> int:
        return self.struct.size

    def cob_id(self, node_id: int) -> int:
        return self.cob_base + node_id

    def pack_into(self, buf, values) -> None:
        """Write the frame into ``buf`` from ``values`` (indexed by slot)."""
        self.struct.pack_into(buf, 0, *self._pick(values))

    def unpack_into(self, data, values) -> None:
        """Decode a frame of exactly :attr:`length` bytes into ``values`` (indexed by slot)."""
        decoded = self.struct.unpack_from(data)
        slots = self.slots
        for i in range(len(slots)):
            values[slots[i]] = decoded[i]


@dataclass(frozen=True)
class PdoLayout:
    rpdos: tuple[Pdo, ...]
    tpdos: tuple[Pdo, ...]

    @classmethod
    def from_eds(cls, path=EDS) -> "PdoLayout":
        return cls.from_od(canopen.import_od(str(path), 0))

    @classmethod
    def from_od(cls, od) -> "PdoLayout":
        """The default mapping of an object dictionary's RPDOs and TPDOs (ValueError when it
        lacks an object the driver needs, maps one twice, or maps one it does not know)."""
        rpdos = _mapped(od, RPDO_COMM, RPDO_MAP, RPDO_BASE, COMMAND_FIELDS)
        tpdos = _mapped(od, TPDO_COMM, TPDO_MAP, TPDO_BASE, STATE_FIELDS)
        return cls(rpdos, tpdos)

    @property
    def frame_lengths(self) -> tuple[int, ...]:
        """Data bytes of the PDOs one drive costs per SYNC (its RPDOs, then its TPDOs)."""
        return tuple(p.length for p in (*self.rpdos, *self.tpdos))


def _mapped(od, comm, mapping, cob_base, known: dict) -> tuple[Pdo, ...]:
    pdos, seen = [], set()
    for k in range(4):  # the predefined connection set's four PDOs per direction
        if comm + k not in od or mapping + k not in od:
            continue
        if od[comm + k][1].default & 0x8000_0000:
            continue  # not valid (disabled) by default
        m = od[mapping + k]
        fields, slots, fmt = [], [], "<"
        for sub in range(1, m[0].default + 1):
            entry = m[sub].default
            index, bits = entry >> 16, entry & 0xFF
            name = known.get(index)
            if name is None:
                raise ValueError(f"PDO mapping {mapping + k:#06x}: object {index:#06x} is not one the cia402 driver "
                                 f"exchanges ({', '.join(f'{i:#06x}' for i in known)})")
            if index in seen:
                raise ValueError(f"PDO mapping {mapping + k:#06x}: object {index:#06x} is mapped twice")
            char = _STRUCT_CHAR[od[index].data_type]
            if bits != 8 * struct.calcsize("<" + char):
                raise ValueError(f"PDO mapping {mapping + k:#06x}: {bits} bits for {index:#06x}, a "
                                 f"{8 * struct.calcsize('<' + char)}-bit object")
            seen.add(index)
            fields.append(name)
            slots.append(list(known).index(index))
            fmt += char
        if fields:
            pdos.append(Pdo(k + 1, cob_base + 0x100 * k, tuple(fields), tuple(slots), struct.Struct(fmt)))
    missing = [f"{i:#06x} ({n})" for i, n in known.items() if i not in seen]
    if missing:
        raise ValueError(f"PDO mappings {mapping:#06x}…: {', '.join(missing)} not mapped")
    if any(p.length > 8 for p in pdos):
        raise ValueError("a PDO longer than 8 bytes")
    return tuple(pdos)


# what a master reads and writes at bring-up besides the PDO set (drivers/cia402_bringup.py): integers all
BRING_UP_OBJECTS = ((CONTROLWORD, 0), (DEVICE_TYPE, 0), (SUPPORTED_MODES, 0), (RATED_TORQUE, 0),
                    (ENCODER_RESOLUTION, 1), (ENCODER_RESOLUTION, 2), (MODES_OF_OPERATION, 0), (MAX_TORQUE, 0),
                    (HEARTBEAT_TIME, 0), (RPDO_COMM, EVENT_TIMER))


def check_bring_up(path, layout: PdoLayout, node_id: int = 1) -> None:
    """What the bring-up takes from the EDS at ``path`` besides ``layout`` (its PDO set), checked
    offline (ValueError naming what is wrong): every object of :data:`BRING_UP_OBJECTS` is there
    as an integer, and python-canopen's own reading of the PDO set — which the bring-up saves into
    the drives — is ``layout``, so the drives send the frames the driver decodes."""
    od = canopen.import_od(str(path), node_id)
    for index, sub in BRING_UP_OBJECTS:
        obj = od.get(index)
        if isinstance(obj, (ODRecord, ODArray)):
            obj = obj.get(sub) if sub in obj else None
        if obj is None or obj.data_type not in datatypes.INTEGER_TYPES:
            raise ValueError(f"object {index:#06x} sub {sub}: missing, or not an integer (the bring-up sets it)")
    node = canopen.RemoteNode(node_id, od)
    canopen.Network().add_node(node)  # (python-canopen subscribes the PDOs it reads to a network)
    try:
        node.pdo.read(from_od=True)
    except Exception as e:
        raise ValueError(f"python-canopen cannot read its PDO set ({type(e).__name__}: {e})") from None
    for m in (*node.rpdo.map.values(), *node.tpdo.map.values()):  # the records the bring-up writes (pdo.save)
        for record in (m.com_record.od, m.map_array.od):
            for sub in record:
                if record[sub].data_type not in datatypes.INTEGER_TYPES:
                    raise ValueError(f"object {record.index:#06x} sub {sub}: not an integer (CiA 301: every entry "
                                     f"of a PDO's communication and mapping records is; the bring-up writes them)")
    theirs = {(kind, number): [(v.index, v.length) for v in m.map]
              for kind, maps in (("RPDO", node.rpdo.map), ("TPDO", node.tpdo.map))
              for number, m in maps.items() if m.enabled and len(m.map)}
    index_of = {name: index for index, name in {**COMMAND_FIELDS, **STATE_FIELDS}.items()}
    ours = {(kind, p.number): [(index_of[f], 8 * struct.calcsize("<" + char))
                               for f, char in zip(p.fields, p.struct.format.lstrip("<"))]
            for kind, pdos in (("RPDO", layout.rpdos), ("TPDO", layout.tpdos)) for p in pdos}
    if theirs != ours:
        raise ValueError(f"python-canopen reads the PDO set as {_describe(theirs)}, the driver as {_describe(ours)}")


def _describe(pdos: dict) -> str:
    return "; ".join(f"{kind}{n}: " + ", ".join(f"{i:#06x}/{bits}" for i, bits in m)
                     for (kind, n), m in sorted(pdos.items()))
