"""The CiA 402 drive layout of a [[devices]] table (drivers.protocols.cia402_layout): node ids,
the drives' scaling, mounting and EDS, and the refusals naming the key."""
import configparser
import dataclasses
import math
import shutil

import pytest

from drivers.protocols import cia402 as c
from drivers.protocols.cia402_layout import Cia402Joint, read_cia402_joints, read_eds
from rtctl.errors import ConfigError
from rtctl.tomltable import Table

NAMES = ["waist", "shoulder", "elbow"]


def device(file="run.toml", **options):
    return Table(options, file, "devices[0]")


def read(names=NAMES, **options):
    return read_cia402_joints(device(**options), names)


def _shipped_eds() -> configparser.RawConfigParser:
    """The shipped EDS as plain INI sections, keys case-kept (to edit it or read it independently)."""
    parser = configparser.RawConfigParser()
    parser.optionxform = str
    parser.read(c.EDS)
    return parser


def refused(key, match, names=NAMES, **options):
    with pytest.raises(ConfigError, match=match) as e:
        read(names, **options)
    assert e.value.key_path == key


def test_defaults_number_the_nodes_from_one_at_2_to_the_20_counts():
    joints = read(rated_torque=40.0)
    assert [(j.name, j.node_id, j.rated_torque, j.counts_per_rev, j.direction, j.offset) for j in joints] == [
        (n, k + 1, 40.0, 1 << 20, 1.0, 0.0) for k, n in enumerate(NAMES)]


def test_a_drive_table_overrides_the_scale_and_sets_the_mounting():
    waist, shoulder, elbow = read(
        ids=[1, 127, 64], rated_torque=40.0, counts_per_rev=4096,
        drives={"shoulder": {"rated_torque": 90.0, "direction": -1, "offset": 0.5},
                "elbow": {"counts_per_rev": 2**31 - 1, "direction": 1}})
    assert [j.node_id for j in (waist, shoulder, elbow)] == [1, 127, 64]
    assert (waist.rated_torque, waist.counts_per_rev, waist.direction, waist.offset) == (40.0, 4096, 1.0, 0.0)
    assert (shoulder.rated_torque, shoulder.counts_per_rev, shoulder.direction, shoulder.offset) == (90.0, 4096, -1.0, 0.5)
    assert (elbow.rated_torque, elbow.counts_per_rev, elbow.direction, elbow.offset) == (40.0, 2**31 - 1, 1.0, 0.0)


def test_the_rated_torque_is_whole_milli_newton_metres():
    # 0x6076 counts mN·m: what the driver writes and checks is the configured value rounded
    (j,) = read(["a"], rated_torque=12.3456)
    assert j.rated_torque == 12.346 and j.rated_torque_mnm == 12346
    for smallest in (0.001, 0.0005002):  # anything that rounds to 1 mN·m
        (j,) = read(["a"], rated_torque=smallest)
        assert (j.rated_torque, j.rated_torque_mnm) == (0.001, 1)
    assert read(["a"], rated_torque=4_000_000.0)[0].rated_torque_mnm == 4_000_000_000
    for bad in (0.0004, 0.0005, 4_000_001.0):  # 0.0005 rounds to 0 mN·m (half to even)
        refused("devices[0].rated_torque", None, ["a"], rated_torque=bad)
    for bad in (0.0, -1.0):  # a sign error is named as one, not as a torque too small
        refused("devices[0].rated_torque", "a positive number", ["a"], rated_torque=bad)


def test_one_revolution_is_counts_per_rev_increments():
    j = Cia402Joint("a", 1, 1.0, 1 << 20)
    assert (j.direction, j.offset) == (1.0, 0.0)  # built without a mounting: the drive's zero and sense
    with pytest.raises(dataclasses.FrozenInstanceError):  # the driver reads its scale and mounting once
        j.offset = 0.5
    assert j.counts_per_rad * 2 * math.pi == pytest.approx(1 << 20, rel=1e-12)
    assert [read(["a"], rated_torque=1.0, counts_per_rev=n)[0].counts_per_rev for n in (1, 2**31 - 1)] == [1, 2**31 - 1]
    for bad in (0, 2**31, 1.5):
        refused("devices[0].counts_per_rev", None, ["a"], rated_torque=1.0, counts_per_rev=bad)


@pytest.mark.parametrize(("ids", "match"), [
    ([1, 2], "an array of 3 node ids"), ([1, 2, 3, 4], "an array of 3"), ([1, 2, True], "an array of 3"),
    ([1, 2, 3.0], "an array of 3"), (3, "an array of 3"),
    ([1, 2, 2], "distinct"), ([0, 1, 2], "1…127"), ([1, 2, 128], "1…127"),
])
def test_node_ids_are_refused_naming_the_key(ids, match):
    refused("devices[0].ids", match, ids=ids, rated_torque=1.0)


def test_a_missing_rated_torque_is_named_where_it_belongs():
    refused("devices[0].rated_torque", "'waist'", drives={})
    refused("devices[0].drives.shoulder.rated_torque", "'shoulder'",
            drives={"waist": {"rated_torque": 1.0}, "shoulder": {"direction": -1}})
    joints = read(drives={n: {"rated_torque": k + 1.0} for k, n in enumerate(NAMES)})
    assert [(j.rated_torque, j.direction, j.offset) for j in joints] == [(1.0, 1.0, 0.0), (2.0, 1.0, 0.0), (3.0, 1.0, 0.0)]


@pytest.mark.parametrize("direction", [0, 2, -2])
def test_a_mounting_direction_is_plus_or_minus_one(direction):
    refused("devices[0].drives.waist.direction", r"1 or -1|[≤≥]", rated_torque=1.0,
            drives={"waist": {"direction": direction}})


def test_unknown_keys_and_joints_in_the_drive_tables_are_refused():
    refused("devices[0].drives.waist.kp", "unknown key", rated_torque=1.0, drives={"waist": {"kp": 3.0}})
    refused("devices[0].drives.wrist", "unknown key", rated_torque=1.0, drives={"wrist": {"direction": -1}})


def test_the_eds_is_the_shipped_one_or_a_file_next_to_the_configuration(tmp_path):
    path, layout = read_eds(device())
    assert path == c.EDS and layout.frame_lengths == (4, 8, 4)
    (tmp_path / "drives").mkdir()
    own = tmp_path / "drives" / "x.eds"
    shutil.copy(c.EDS, own)
    path, layout = read_eds(device(tmp_path / "run.toml", eds="drives/x.eds"))
    assert path == own.resolve() and [p.fields for p in layout.tpdos] == [("statusword", "position", "torque"),
                                                                          ("velocity",)]


def test_a_missing_or_unusable_eds_is_refused(tmp_path):
    for name, match in (("no/such.eds", "no such file"), ("bad.eds", "CST set")):
        (tmp_path / "bad.eds").write_text(c.EDS.read_text().replace("DefaultValue=0x606C0020", "DefaultValue=0x60610008"))
        with pytest.raises(ConfigError, match=match) as e:
            read_eds(device(tmp_path / "run.toml", eds=name))
        assert e.value.key_path == "devices[0].eds"


@pytest.mark.parametrize("section, key, value, named", [
    ("1400sub2", None, None, "cannot read its PDO set"),  # RPDO1's transmission type: the bring-up sets it to 1
    ("1400sub5", None, None, "0x1400 sub 5"),  # RPDO1's event timer: the bring-up sets the drives' deadline there
    ("6076", None, None, "0x6076"),  # the rated torque the bring-up checks
    ("1600sub0", "DataType", "0", "0x1600 sub 0"),  # a mapping count of no type: canopen's TypeError in pdo.save()
    ("1400sub5", "DataType", "0x0008", "0x1400 sub 5"),  # the RPDO deadline as a REAL32
], ids=["transmission type", "rpdo deadline", "rated torque", "map count type", "deadline type"])
def test_an_eds_without_an_object_the_bring_up_sets_is_refused_at_configuration_not_a_keyerror_at_configure(
        tmp_path, section, key, value, named):
    """Found by the driver-boundary fuzzing (tests/hardening/test_driver_boundaries.py): such an
    EDS passed `rtctl check` (its PDO set was usable), then python-canopen raised KeyError
    in the middle of the drives' bring-up — after the bus had been opened and the
    drives sent to PRE-OPERATIONAL — instead of exit 2 naming the key. So did a PDO record
    entry that is not an integer (a TypeError from python-canopen when the bring-up saved it)."""
    parser = _shipped_eds()
    if key is None:
        parser.remove_section(section)
    else:
        parser.set(section, key, value)
    with (tmp_path / "x.eds").open("w") as f:
        parser.write(f)
    with pytest.raises(ConfigError, match=named) as e:
        read_eds(device(tmp_path / "run.toml", eds="x.eds"))
    assert e.value.key_path == "devices[0].eds"


def _eds_with_tpdo3(tmp_path, cob_id: str, count: str):
    """The shipped EDS plus a TPDO3: a copy of TPDO2's records with this COB-ID and mapping count."""
    parser = _shipped_eds()
    for section in [s for s in parser.sections() if s.startswith(("1801", "1A01"))]:
        copy = section.replace("1801", "1802").replace("1A01", "1A02")
        parser.add_section(copy)
        for key, value in parser.items(section):
            parser.set(copy, key, value.replace("TPDO2", "TPDO3"))
    parser.set("1802sub1", "DefaultValue", cob_id)
    parser.set("1A02sub0", "DefaultValue", count)
    listed = int(parser.get("OptionalObjects", "SupportedObjects"))
    parser.set("OptionalObjects", str(listed + 1), "0x1802")
    parser.set("OptionalObjects", str(listed + 2), "0x1A02")
    parser.set("OptionalObjects", "SupportedObjects", str(listed + 2))
    with (tmp_path / "x.eds").open("w") as f:
        parser.write(f)
    return tmp_path / "x.eds"


@pytest.mark.parametrize("cob_id, count", [("0x80000380", "4"), ("$NODEID+0x380", "0")],
                         ids=["disabled with a mapping", "enabled without one"])
def test_a_pdo_that_sends_nothing_is_no_disagreement_with_python_canopen(tmp_path, cob_id, count):
    """A TPDO that is disabled (COB-ID bit 31, CiA 301) or maps nothing carries no frame: the
    driver's layout leaves it out and so must the check of python-canopen's reading."""
    path, layout = read_eds(device(_eds_with_tpdo3(tmp_path, cob_id, count).parent / "run.toml", eds="x.eds"))
    assert [p.number for p in layout.tpdos] == [1, 2]
    c.check_bring_up(path, layout)


def _mapping(parser, record: int) -> list[tuple[int, int]]:
    """A mapping record's entries as (object index, bits), read from the EDS text itself."""
    n = int(parser.get(f"{record:X}sub0", "DefaultValue"), 0)
    entries = [int(parser.get(f"{record:X}sub{k}", "DefaultValue"), 0) for k in range(1, n + 1)]
    return [(e >> 16, e & 0xFF) for e in entries]


def test_a_layout_that_is_not_python_canopens_reading_is_refused_naming_both(tmp_path):
    """check_bring_up against a layout of another EDS (TPDO2's objects in TPDO4): the message
    lists both readings as `KINDn: index/bits, …` joined by `; `."""
    moved = tmp_path / "moved.eds"
    moved.write_text(c.EDS.read_text().replace("1801", "1803").replace("1A01", "1A03")
                     .replace("$NODEID+0x280", "$NODEID+0x480"))
    parser = _shipped_eds()

    def listed(pdos):
        return "; ".join(f"{kind}{n}: " + ", ".join(f"{i:#06x}/{bits}" for i, bits in _mapping(parser, record))
                         for kind, n, record in pdos)

    shipped = listed([("RPDO", 1, 0x1600), ("TPDO", 1, 0x1A00), ("TPDO", 2, 0x1A01)])
    driver = listed([("RPDO", 1, 0x1600), ("TPDO", 1, 0x1A00), ("TPDO", 4, 0x1A01)])
    with pytest.raises(ValueError) as e:
        c.check_bring_up(c.EDS, c.PdoLayout.from_eds(moved))
    assert str(e.value) == f"python-canopen reads the PDO set as {shipped}, the driver as {driver}"
