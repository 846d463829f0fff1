"""The CiA 402 driver's other input boundary (boundary_fuzz.py): the contents of its EDS."""
from __future__ import annotations

import configparser
import sys
import tempfile
from pathlib import Path

from hypothesis import strategies as st

from drivers.cia402_joints import Cia402JointGroup
from drivers.protocols.cia402 import COMMAND_FIELDS, EDS, STATE_FIELDS
from drivers.protocols.cia402_layout import Cia402Joint, read_eds
from hil_sim.cia402_drive import Cia402Drive, Cia402DriveBus
from rtctl.errors import ConfigError, HardwareError
from rtctl.hal import Status
from rtctl.tomltable import Table

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "can"))
from lockstep_rig import LockStep, virtual_bus  # noqa: E402


def _shipped() -> configparser.RawConfigParser:
    parser = configparser.RawConfigParser()
    parser.optionxform = str
    parser.read(EDS)
    return parser


class EdsContents:
    """The ``cia402`` driver's EDS (``eds`` in a device table): the shipped one with any value
    in any key of its PDO, identity and drive objects, sections dropped, garbage lines. It is
    refused as the configuration's ``eds`` key (exit 2), or it gives a PDO set the driver can
    use, with which the driver brings emulated drives up: they refuse (a HardwareError naming the
    drive: the drive's own objects are the truth) or the frames they send are the frames the
    driver decodes. Nothing else escapes — no exception of python-canopen's at configure."""

    SECTIONS = [s for s in _shipped().sections() if s[:1] in "16"]
    EXAMPLES = [[("garbage", "")], [("drop", "1A00sub2")], [("set", "1801sub1", "DefaultValue", "0x80000280")],
                [("drop", "1400sub2")], [("drop", "6076")]]  # (these two: KeyError at configure, before the fix)

    def steps(self):
        keys = st.sampled_from(["DefaultValue", "DataType", "SubNumber", "ObjectType", "AccessType", "PDOMapping",
                                "ParameterValue", "LowLimit", "HighLimit"])
        values = st.one_of(st.integers(-2 ** 40, 2 ** 40).map(str), st.integers(0, 2 ** 40).map(hex),
                           st.sampled_from(["", "0x", "garbage", "$NODEID+0x180", "0x60410010", "0x60640020",
                                            "0x60770010", "0x606C0020", "0x60400010", "0x60710010", "0x0007", "0",
                                            "0x80000180", "$NODEID+0x80000280"]))
        mutation = st.one_of(st.tuples(st.just("set"), st.sampled_from(self.SECTIONS), keys, values),
                             st.tuples(st.just("drop"), st.sampled_from(self.SECTIONS)),
                             st.tuples(st.just("garbage"), st.text(max_size=30)))
        return st.lists(mutation, min_size=1, max_size=4)

    def play(self, mutations, stats) -> None:
        parser = _shipped()
        tail = ""
        for m in mutations:
            if m[0] == "set":
                if parser.has_section(m[1]):
                    parser.set(m[1], m[2], m[3])
            elif m[0] == "drop":
                parser.remove_section(m[1])
            else:
                tail += "\n" + m[1]
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "drive.eds"
            with path.open("w") as f:
                parser.write(f)
                f.write(tail)
            table = Table({"eds": "drive.eds"}, Path(tmp) / "run.toml", "devices[0]")
            try:
                _, layout = read_eds(table)
            except ConfigError as e:
                assert e.key_path == "devices[0].eds", e
                stats["refused"] = stats.get("refused", 0) + 1
                return
            stats["accepted"] = stats.get("accepted", 0) + 1
            for pdos, fields in ((layout.rpdos, COMMAND_FIELDS), (layout.tpdos, STATE_FIELDS)):
                mapped = [f for p in pdos for f in p.fields]
                assert sorted(mapped) == sorted(fields.values()), mapped
                for p in pdos:
                    assert 0 < p.length <= 8 and p.struct.size == p.length
            _bring_up(path, layout, stats)


def _bring_up(path, layout, stats) -> None:
    """Two drives (node ids 1 and 127, emulated with the shipped EDS) brought up by the driver
    with this EDS: it refuses them (HardwareError naming a drive), or the SYNC cycles that
    follow decode every TPDO the drives send as configured (all fresh, OPERATION ENABLED)."""
    class Rig(LockStep, Cia402JointGroup):
        def __init__(self, joints):
            super().__init__("arm", joints, virtual_bus(), eds=path, layout=layout, period=0.001, reply_deadline=0.0)
            self._attach(lambda j, port: Cia402Drive(j.node_id, port, rated_torque=j.rated_torque,
                                                     counts_per_rev=j.counts_per_rev), Cia402DriveBus)

    rig = Rig([Cia402Joint("a", 1, 10.0, 1 << 20), Cia402Joint("b", 127, 20.0, 1 << 20)])
    try:
        try:
            rig.activate()
        except HardwareError as e:
            assert "drive 0x1 " in str(e) or "drive 0x7f " in str(e) or "drive(s) 0x" in str(e), e
            stats["refused by the drives"] = stats.get("refused by the drives", 0) + 1
            return
        rig.tick()
        assert rig.tick() == (Status.OK, Status.OK) and rig.state.fresh.all(), (rig.last_error, rig.counters)
    finally:
        rig.close()
        rig.peer.shutdown()
