"""Bring-up of CiA 402 drives through python-canopen: what the ``cia402`` driver does at
``configure`` — NMT and SDO — before its own cyclic exchange takes the bus over
(:mod:`drivers.cia402_joints`).

For every drive, in this order (each step names the drive and the object when it fails):

1. NMT PRE-OPERATIONAL: a drive left running by a crashed master stops its PDOs (and, leaving
   OPERATIONAL while enabled, disables itself); controlword 0x6040 ← 0 (disable voltage).
2. Identity: device type 0x1000 is profile 402; 0x6502 lists cyclic synchronous torque.
3. Scaling: rated torque 0x6076 and encoder resolution 0x608F are those of the configuration
   (a drive that scales differently would turn every torque by the ratio: it is refused).
4. Settings: mode 0x6060 ← 10 (CST); max torque 0x6072 (‰) ← the joint's torque limit; the
   heartbeat 0x1017; the PDO set of the EDS with transmission type 1 (python-canopen's
   ``PdoMap.save``), RPDO1's event timer 0x1400 sub 5 as the deadline of our commands.
5. NMT OPERATIONAL: the PDOs run (on SYNC only: nothing moves until the master sends one).

The objects used here besides the PDO set are :data:`drivers.protocols.cia402.BRING_UP_OBJECTS`:
an EDS without one of them, or whose PDO set python-canopen reads otherwise than the driver, is
refused when the configuration is read (exit 2), not found missing half-way through this.

SDO needs a receive thread: python-canopen's Network runs python-can's Notifier on the bus
during this bring-up only (:func:`sdo_session`); it is stopped before the loop starts, so
the loop's process runs no thread of its own while the robot moves.
"""
from __future__ import annotations

import contextlib
import math

import canopen
from canopen.objectdictionary import ObjectDictionaryError
from canopen.sdo import SdoAbortedError, SdoCommunicationError

from drivers.protocols import cia402 as c
from rtctl.errors import HardwareError


class MasterNetwork(canopen.Network):
    """python-canopen's Network on the driver's own bus; ``after_send`` runs after every frame
    the library sends (an in-process simulator answers there)."""

    NOTIFIER_CYCLE = 0.01  # the receive thread notices a stop within 10 ms

    def __init__(self, bus, after_send):
        super().__init__(bus)
        self._after_send = after_send

    def send_message(self, can_id: int, data, remote: bool = False) -> None:
        super().send_message(can_id, data, remote)
        self._after_send()


@contextlib.contextmanager
def sdo_session(network: MasterNetwork):
    """python-can's Notifier on the network's bus for the duration (SDO answers reach the
    waiting client through it); stopped, and the bus left to the caller, at the end."""
    network.connect()  # the bus is already open: this only starts the Notifier
    try:
        yield
    finally:
        notifier, network.notifier = network.notifier, None
        notifier.stop(1.0)


def configure_drive(node, joint, *, heartbeat_ms: int, deadline_ms: int, max_torque: float, label: str) -> None:
    """Steps 1–4 above for one drive (``node``: a canopen RemoteNode on a running session)."""
    where = f"drive {node.id:#x} ({joint.name}) on {label}"
    try:
        node.nmt.state = "PRE-OPERATIONAL"
        _write(node, c.CONTROLWORD, c.CW_DISABLE_VOLTAGE)
        device_type = _read(node, c.DEVICE_TYPE)
        if device_type & 0xFFFF != c.PROFILE_402:
            raise HardwareError(f"{where}: device type {device_type:#010x} is not a CiA 402 drive")
        if not _read(node, c.SUPPORTED_MODES) & c.CST_SUPPORTED:
            raise HardwareError(f"{where}: it does not support cyclic synchronous torque (0x6502)")
        rated = _read(node, c.RATED_TORQUE)
        if rated != joint.rated_torque_mnm:
            raise HardwareError(f"{where}: rated torque 0x6076 is {rated / 1000:g} N·m, the configuration says "
                                f"{joint.rated_torque:g} N·m (rated_torque)")
        increments, revolutions = _read(node, c.ENCODER_RESOLUTION, 1), _read(node, c.ENCODER_RESOLUTION, 2)
        if revolutions == 0 or increments != joint.counts_per_rev * revolutions:
            raise HardwareError(f"{where}: encoder resolution 0x608F is {increments}/{revolutions} increments "
                                f"per revolution, the configuration says {joint.counts_per_rev} (counts_per_rev)")
        _write(node, c.MODES_OF_OPERATION, c.CST)
        permille = 0xFFFF if not math.isfinite(max_torque) else min(0xFFFF, math.ceil(1000 * max_torque / joint.rated_torque))
        _write(node, c.MAX_TORQUE, permille)
        _write(node, c.HEARTBEAT_TIME, heartbeat_ms)
        node.pdo.read(from_od=True)  # the EDS's PDO set …
        for pdo in (*node.rpdo.map.values(), *node.tpdo.map.values()):
            pdo.trans_type = 1  # … on every SYNC
            pdo.cob_id = pdo.predefined_cob_id
        node.rpdo.map[1].event_timer = deadline_ms  # an RPDO's event timer is its deadline
        node.pdo.save()
    except HardwareError:
        raise
    except SdoAbortedError as e:
        raise HardwareError(f"{where}: SDO refused: {e}") from e
    except SdoCommunicationError as e:
        raise HardwareError(f"{where}: no SDO answer ({e}): power, node id, bitrate, termination?") from e
    except ObjectDictionaryError as e:  # an answer of the wrong size for its object
        raise HardwareError(f"{where}: a malformed SDO answer ({e})") from e


def _read(node, index: int, subindex: int | None = None) -> int:
    entry = node.sdo[index] if subindex is None else node.sdo[index][subindex]
    return entry.raw


def _write(node, index: int, value: int) -> None:
    node.sdo[index].raw = value
