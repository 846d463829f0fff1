"""The frames of the ``cia402`` driver's SYNC cycle, mixed into :class:`~drivers.cia402_joints.Cia402JointGroup`:
RPDOs packed into preallocated messages, one SYNC, and every received frame routed by COB-ID
into preallocated arrays — TPDO values, EMCY codes, heartbeat times and NMT states."""
from __future__ import annotations

import time

import can
import numpy as np

from drivers.protocols import cia402 as c

TPDO, EMCY, HEARTBEAT = range(3)


class Cia402Frames:
    def _init_frames(self, joints, layout) -> None:
        n = len(joints)
        self._values = np.zeros((n, len(c.STATE_FIELDS)))  # raw statusword, position, velocity, torque
        self._rows = [self._values[r] for r in range(n)]
        self._statusword = np.zeros(n, dtype=np.int64)
        self._not_enabled = 0  # drives whose last statusword is not OPERATION ENABLED
        self._fresh = np.zeros(n, dtype=bool)  # every TPDO of the drive arrived in the last cycle
        self._got = [0] * n  # per drive: bit k set when TPDO k arrived in this cycle
        self._replies_by = 0.0  # time.monotonic() until which the TPDOs of the last SYNC are awaited
        self._all_tpdos = (1 << len(layout.tpdos)) - 1
        self._emcy = np.zeros(n, dtype=np.int64)  # active EMCY code per drive (0: none)
        self._emcy_active = False
        self._heartbeat_at = np.zeros(n)  # clock time of the last heartbeat
        self._nmt_state = np.full(n, c.NMT_OPERATIONAL, dtype=np.int64)  # from the last heartbeat
        self._nmt_bad = False  # a node's heartbeat says it is not OPERATIONAL
        self._command = [[0, 0] for _ in range(n)]  # controlword, target torque ‰ (COMMAND_FIELDS order)
        self._rpdo_msgs = [[(pdo, can.Message(arbitration_id=pdo.cob_id(j.node_id), data=bytearray(pdo.length),
                                              is_extended_id=False)) for pdo in layout.rpdos] for j in joints]
        self._sync_msg = can.Message(arbitration_id=c.SYNC, data=bytearray(), is_extended_id=False)
        self._acknowledged(sum(map(len, self._rpdo_msgs)) + 1)  # the RPDOs and the SYNC
        self._route = {}  # COB-ID → (kind, row, pdo, bit): preallocated, looked up per frame
        for row, j in enumerate(joints):
            for k, pdo in enumerate(layout.tpdos):
                self._route[pdo.cob_id(j.node_id)] = (TPDO, row, pdo, 1 << k)
            self._route[c.EMCY_BASE + j.node_id] = (EMCY, row, None, 0)
            self._route[c.HEARTBEAT_BASE + j.node_id] = (HEARTBEAT, row, None, 0)

    # -- RPDOs ------------------------------------------------------------------------------
    def _pack(self, permille) -> None:
        """Every drive's RPDOs while active: its torque ``permille[row]`` (whole numbers) with
        *enable operation* — or *disable voltage* and no torque to a drive whose last statusword
        is not OPERATION ENABLED: a drive that fell out (its panel, a quick stop) is taken down,
        not re-enabled behind the safety stage's back; only ``activate`` brings it back."""
        command, msgs, sw = self._command, self._rpdo_msgs, self._statusword
        for row in range(len(command)):
            cmd = command[row]
            if sw[row] & c.OE_MASK == c.OE_VALUE:
                cmd[0], cmd[1] = c.CW_ENABLE_OPERATION, int(permille[row])
            else:
                cmd[0], cmd[1] = c.CW_DISABLE_VOLTAGE, 0
            for pdo, msg in msgs[row]:
                pdo.pack_into(msg.data, cmd)

    def _pack_each(self, controlword) -> None:
        """Every drive's RPDOs with ``controlword(row, statusword)`` and zero torque."""
        for row, cmd in enumerate(self._command):
            cmd[0] = controlword(row, int(self._statusword[row]))
            cmd[1] = 0
            for pdo, msg in self._rpdo_msgs[row]:
                pdo.pack_into(msg.data, cmd)

    # -- one SYNC cycle -----------------------------------------------------------------------
    def _cycle(self, timeout: float) -> int:
        """One SYNC cycle at once (bring-up, state changes): send, then collect the TPDOs for up
        to ``timeout`` s; returns how many drives did not send all of theirs."""
        self._send_sync(timeout)
        return self._collect()

    def _send_sync(self, timeout: float) -> None:
        """Take what arrived since the last collection (EMCY, heartbeats, a late TPDO: TPDOs
        carry no cycle number, so one left in the buffer would pass for an answer to this SYNC),
        send the RPDOs and a SYNC; the TPDOs are awaited until ``timeout`` s from now
        (:meth:`_collect`)."""
        bus = self.bus
        if self._may_hold_frames():  # (over slcan an empty read waits out the serial timeout)
            self._drain(self._take_late)
        got = self._got
        for row in range(len(got)):
            got[row] = 0
        for msgs in self._rpdo_msgs:
            for _, msg in msgs:
                bus.send(msg)
        bus.send(self._sync_msg)
        self._last_sent = self._clock()
        self._replies_by = time.monotonic() + timeout
        self._after_send()

    def _collect(self) -> int:
        """The TPDOs of the last SYNC: what has arrived, and what arrives before its deadline
        (none left to wait for once it passed); returns how many drives did not send all."""
        got, full = self._got, self._all_tpdos
        pending = 0  # (a plain loop: no generator object per tick)
        for row in range(len(got)):
            pending += full.bit_count() - got[row].bit_count()
        self._receive(pending, max(0.0, self._replies_by - time.monotonic()), self._take, self._acks_per_send)
        fresh, values, sw = self._fresh, self._rows, self._statusword
        missing = not_enabled = 0
        for row in range(len(got)):
            ok = got[row] == full
            fresh[row] = ok
            missing += not ok
            word = int(values[row][0])
            sw[row] = word
            not_enabled += word & c.OE_MASK != c.OE_VALUE
        self._not_enabled = not_enabled
        return missing

    def _take_late(self, msg) -> int:
        """Route a frame that arrived between collections (EMCY, heartbeat, a TPDO too late for
        its cycle: its values are the newest, it answers nothing)."""
        return self._take(msg, late=True)

    def _take(self, msg, late: bool = False) -> int:
        """Route one received frame; 1 when it is a TPDO this cycle still waited for, else 0."""
        if msg.is_error_frame:
            self.counters["error_frames"] += 1
            return 0
        route = None if msg.is_extended_id or msg.is_remote_frame else self._route.get(msg.arbitration_id)
        if route is None:
            self.counters["foreign_frames"] += 1  # other nodes, SDO answers after their timeout …
            return 0
        kind, row, pdo, bit = route
        data = msg.data
        if kind == TPDO:
            if len(data) != pdo.length:
                self.counters["malformed_replies"] += 1
                return 0
            pdo.unpack_into(data, self._rows[row])  # the newest values win
            if late:
                self.counters["late_replies"] += 1
                return 0
            got = self._got[row]
            if got & bit:
                return 0
            self._got[row] = got | bit
            return 1
        if kind == EMCY:
            code = c.emcy_code(data)
            if code is None:
                self.counters["malformed_replies"] += 1
                return 0
            self.counters["emcy"] += 1
            self._emcy[row] = code if code & 0xFF00 else 0  # 0x00xx: error reset / no error
            self._emcy_active = bool(self._emcy.any())
            return 0
        if len(data) != 1:
            self.counters["malformed_replies"] += 1
            return 0
        self.counters["heartbeats"] += 1
        self._nmt_state[row] = data[0] & 0x7F
        self._nmt_bad = bool((self._nmt_state != c.NMT_OPERATIONAL).any())
        self._heartbeat_at[row] = self._clock()
        return 0
