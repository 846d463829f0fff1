"""The CAN drivers' input boundary (boundary_fuzz.py): the frames on their bus, MIT and CiA 402."""
from __future__ import annotations

import contextlib
import math
import sys
from pathlib import Path

import can
from hypothesis import strategies as st

from boundary_fuzz import DeviceBoundary, Expect
from drivers.protocols import cia402 as c
from drivers.protocols import mit
from rtctl.hal import Status

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "can"))  # lockstep_rig


def can_frames(ids):
    """Frames of any kind on ``ids`` (a strategy), any length 0..8 (and 12/64 as CAN FD)."""
    return st.builds(lambda i, data, ext, rtr, err, fd: can.Message(
        arbitration_id=i, data=data, is_extended_id=ext, is_remote_frame=rtr and not fd, is_error_frame=err,
        is_fd=fd or len(data) > 8),
        ids, st.binary(max_size=8) | st.sampled_from([bytes(12), bytes(range(64))]),
        st.booleans(), st.booleans(), st.booleans(), st.booleans())


class _Rig(DeviceBoundary):
    """A CAN driver on a python-can virtual bus with emulated drives pumped in lock-step
    (tests/can/lockstep_rig.py), the fuzz frames sent from the drives' side.

    The test's model: a drive that was silent when the last commands went out did not answer
    them, so its joint is not fresh — unless a frame this step or the step before could pass
    for its answer (``IMPOSTORS``: any frame on the drive's ids says what a drive would say);
    ``stale_limit`` such ticks in a row are the device's ERROR."""

    IMPOSTORS: tuple = ()

    @contextlib.contextmanager
    def open(self):
        rig = self.make_rig()
        self._pending = Status.OK  # the last write's status, reported with the next read (as the loop does)
        self._silent_at_write = [False] * len(rig.joints)
        self._stale_run = [0] * len(rig.joints)
        self._impostor_before = False
        try:
            rig.activate()
            yield rig
        finally:
            rig.close()
            rig.peer.shutdown()

    def inject(self, dev, step) -> Expect:
        if step[0] == "silent":
            dev.drive_list[step[1]].faults.silent = step[2]
        elif step[0] == "error":
            dev.drive_list[step[1]].set_error(step[2])
        elif step[0] != "nothing":
            self.send(dev, step)
        impostor = step[0] in self.IMPOSTORS
        quiet = not (impostor or self._impostor_before)
        self._impostor_before = impostor
        stale = [row for row, silent in enumerate(self._silent_at_write) if silent and quiet]
        self._stale_run = [run + 1 if row in stale else 0 for row, run in enumerate(self._stale_run)]
        return Expect(error=max(self._stale_run) >= dev.stale_limit, stale=stale,
                      why=f"drive(s) of row(s) {stale} silent for {self._stale_run} tick(s)")

    def tick(self, dev, k):
        read, write = dev.tick()
        status, self._pending = max(read, self._pending), write
        self._silent_at_write = [d.faults.silent for d in dev.drive_list]
        return status


class MitFrames(_Rig):
    """The ``mit_can`` driver: frames of any id, length and kind, well-formed replies with any
    values and error codes (extra, repeated), silent drives and drive errors, for Katz, CubeMars
    and Damiao replies."""

    MODELS = {"katz": mit.KATZ, "cubemars": mit.MitDriveModel(name="cubemars", reply_format=mit.ReplyFormat.CUBEMARS),
              "dm4310": mit.DRIVE_MODELS["dm4310"]}
    IMPOSTORS = ("frame", "reply")
    EXAMPLES = [  # a CAN FD frame of 64 bytes on the master id; a drive going silent; a drive error
        ("katz", [("frame", can.Message(arbitration_id=0, data=bytes(range(64)), is_fd=True, is_extended_id=False)),
                  ("silent", 1, True), ("nothing",), ("nothing",), ("nothing",), ("nothing",), ("silent", 1, False),
                  ("nothing",), ("nothing",)]),
        ("dm4310", [("reply", 0, 1e3, -1e3, 0.0, 300, 255), ("error", 1, 9), ("nothing",), ("nothing",)]),
    ]

    def __init__(self):
        self.model = mit.KATZ

    def steps(self):
        ids = st.sampled_from([0, 1, 2]) | st.integers(0, 0x7FF)
        reply = st.tuples(st.just("reply"), st.integers(0, 1), st.floats(-1e3, 1e3), st.floats(-1e3, 1e3),
                          st.floats(-1e3, 1e3), st.integers(-200, 300), st.integers(0, 255))
        step = st.one_of(st.tuples(st.just("frame"), can_frames(ids)), reply,
                         st.tuples(st.just("silent"), st.integers(0, 1), st.booleans()),
                         st.tuples(st.just("error"), st.integers(0, 1), st.integers(0, 15)), st.just(("nothing",)))
        return st.tuples(st.sampled_from(sorted(self.MODELS)), st.lists(step, min_size=1, max_size=15))

    def play(self, steps, stats):
        name, steps = steps
        self.model = self.MODELS[name]
        super().play(steps, stats)

    def make_rig(self):
        from drivers.can_joints import MitCanJointGroup
        from drivers.protocols.mit_layout import MitJoint
        from hil_sim.mit_drive import MitDrive, MitDriveBus
        from lockstep_rig import LockStep, virtual_bus

        class Rig(LockStep, MitCanJointGroup):
            def __init__(self, joints):
                super().__init__("arm", joints, virtual_bus(), reply_deadline=0.0, exchange_timeout=0.0, period=0.001)
                self._attach(lambda j, port: MitDrive(j.drive_id, port, j.model), MitDriveBus)

        return Rig([MitJoint("a", 1, self.model), MitJoint("b", 2, self.model)])

    def send(self, dev, step) -> None:
        if step[0] == "frame":
            dev.peer.send(step[1])
        else:
            _, row, p, v, e, temp, error = step
            dev.peer.send(can.Message(arbitration_id=dev.master_id, is_extended_id=False, data=mit.pack_reply(
                self.model, dev.joints[row].drive_id, p, v, e, temperature=temp, error=error)))

    def bounds(self, dev):
        """The model's ranges, widened by half a step of each field (16, 12, 12 bits): a reply
        reads as the centre of its code's interval, so the top code reads half a step above."""
        m = self.model

        def widened(lo, hi, bits, scale=1.0):
            half = 0.5 * (hi - lo) / (2 ** bits - 1)
            return ((lo - half) * scale, (hi + half) * scale)

        return {"position": widened(*m.p, 16), "velocity": widened(*m.v, 12),
                "effort": widened(*m.effort, 12, m.torque_constant)}


class Cia402Frames(_Rig):
    """The ``cia402`` driver: frames of any id, length and kind, and on the drives' own COB-IDs
    TPDOs with any statusword, position, velocity and torque, EMCYs of any code, heartbeats of
    any state, SDO answers out of turn; silent drives and drive errors."""

    CPR = 1 << 20
    IMPOSTORS = ("frame", "tpdo")
    EXAMPLES = [  # an EMCY; a drive going silent; a TPDO of extreme values
        [("emcy", 1, 0x2310, 0), ("nothing",), ("emcy", 1, 0, 0), ("nothing",)],
        [("silent", 0, True), ("nothing",), ("nothing",), ("nothing",), ("nothing",)],
        [("tpdo", 1, 0xFFFF, -2 ** 31, 2 ** 31 - 1, -2 ** 15), ("heartbeat", 2, 0x7F), ("nothing",)],
    ]

    def steps(self):
        nodes = st.integers(1, 2)
        cobs = st.one_of(st.builds(lambda base, n: base + n, st.sampled_from(
            [c.TPDO_BASE, c.TPDO_BASE + 0x100, c.EMCY_BASE, c.HEARTBEAT_BASE, c.SDO_TX_BASE]), nodes),
            st.sampled_from([c.NMT, c.SYNC]), st.integers(0, 0x7FF))
        words = st.sampled_from([c.statusword_of(s) for s in c.STATES]) | st.integers(0, 0xFFFF)
        step = st.one_of(
            st.tuples(st.just("frame"), can_frames(cobs)),
            st.tuples(st.just("tpdo"), st.integers(0, 1), words, st.integers(-2 ** 31, 2 ** 31 - 1),
                      st.integers(-2 ** 31, 2 ** 31 - 1), st.integers(-2 ** 15, 2 ** 15 - 1)),
            st.tuples(st.just("emcy"), nodes, st.integers(0, 0xFFFF), st.integers(0, 255)),
            st.tuples(st.just("heartbeat"), nodes, st.integers(0, 255)),
            st.tuples(st.just("silent"), st.integers(0, 1), st.booleans()),
            st.tuples(st.just("error"), st.integers(0, 1), st.sampled_from([0x2310, 0x5530, 0xFF00])),
            st.just(("nothing",)))
        return st.lists(step, min_size=1, max_size=15)

    def make_rig(self):
        from drivers.cia402_joints import Cia402JointGroup
        from drivers.protocols.cia402_layout import Cia402Joint
        from hil_sim.cia402_drive import Cia402Drive, Cia402DriveBus
        from lockstep_rig import LockStep, virtual_bus

        class Rig(LockStep, Cia402JointGroup):
            def __init__(self, joints):
                super().__init__("arm", joints, virtual_bus(), period=0.001, reply_deadline=0.0)
                self._attach(lambda j, port: Cia402Drive(j.node_id, port, rated_torque=j.rated_torque,
                                                         counts_per_rev=j.counts_per_rev), Cia402DriveBus)

        return Rig([Cia402Joint("a", 1, 10.0, self.CPR),
                    Cia402Joint("b", 2, 20.0, self.CPR, direction=-1.0, offset=0.5)])

    def send(self, dev, step) -> None:
        kind, send = step[0], dev.peer.send
        if kind == "frame":
            send(step[1])
        elif kind == "tpdo":  # every TPDO of the drive, with these values (STATE_FIELDS order)
            _, row, *values = step
            for pdo in dev.layout.tpdos:
                data = bytearray(pdo.length)
                pdo.pack_into(data, values)
                send(can.Message(arbitration_id=pdo.cob_id(dev.joints[row].node_id), data=data, is_extended_id=False))
        elif kind == "emcy":
            _, node, code, register = step
            send(can.Message(arbitration_id=c.EMCY_BASE + node, is_extended_id=False,
                             data=code.to_bytes(2, "little") + bytes([register]) + bytes(5)))
        else:
            send(can.Message(arbitration_id=c.HEARTBEAT_BASE + step[1], data=bytes([step[2]]), is_extended_id=False))

    def bounds(self, dev):
        counts = 2 ** 31 * 2 * math.pi / self.CPR  # rad of the largest int32 count
        return {"position": (-counts - 0.5, counts + 0.5), "velocity": (-counts, counts),
                "effort": (-32768 * 0.020, 32768 * 0.020)}  # ‰ of the larger rated torque, 20 N·m
