"""The MIT drive layout of a [[devices]] table (drivers.protocols.mit_layout): ids, per-joint
models and mounting, and the refusals that keep two drives' replies apart."""
import pytest

from drivers.protocols import mit
from drivers.protocols.mit_layout import MitJoint, read_master_id, read_mit_joints, reply_keys
from rtctl.errors import ConfigError
from rtctl.tomltable import Table

NAMES = ["waist", "shoulder", "elbow"]
DM = mit.DRIVE_MODELS["dm4310"]


def device(**options):
    return Table(options, "run.toml", "devices[0]")


def read(names=NAMES, **options):
    return read_mit_joints(device(**options), names)


def refused(key, match, names=NAMES, **options):
    with pytest.raises(ConfigError, match=match) as e:
        read(names, **options)
    assert e.value.key_path == key


def test_defaults_number_the_drives_from_one_on_the_katz_model():
    joints = read()
    assert [(j.name, j.drive_id, j.direction, j.offset) for j in joints] == [
        ("waist", 1, 1.0, 0.0), ("shoulder", 2, 1.0, 0.0), ("elbow", 3, 1.0, 0.0)]
    assert all(j.model == mit.KATZ for j in joints)
    assert read_master_id(device()) == 0


def test_device_defaults_apply_to_every_joint_and_a_drive_table_overrides_them():
    waist, shoulder, elbow = read(
        ids=[7, 3, 0xFF], drive_model="ak80-9", t_range=[-40.0, 40.0],
        drives={"waist": {"offset": -0.5},  # a drive table without a direction: +1
                "shoulder": {"t_range": [-190.0, 190.0], "direction": -1, "offset": 0.25},
                "elbow": {"direction": 1, "reply_format": "cubemars", "torque_constant": 0.1}})
    assert [j.drive_id for j in (waist, shoulder, elbow)] == [7, 3, 0xFF]
    assert waist.model.v == (-25.64, 25.64) and waist.model.t == waist.model.effort == (-40.0, 40.0)
    assert (waist.direction, waist.offset) == (1.0, -0.5)
    # the drive's own range replaces the device's; the model and the rest stay the device's
    assert shoulder.model.t == shoulder.model.effort == (-190.0, 190.0) and shoulder.model.v == (-25.64, 25.64)
    assert (shoulder.direction, shoulder.offset) == (-1.0, 0.25)
    assert elbow.model.reply_format is mit.ReplyFormat.CUBEMARS and elbow.model.torque_constant == 0.1
    assert elbow.model.t == (-40.0, 40.0) and (elbow.direction, elbow.offset) == (1.0, 0.0)


def test_master_id_spans_the_standard_can_ids():
    assert read_master_id(device(master_id=0x7FF)) == 0x7FF
    assert read_master_id(device(master_id=0)) == 0
    for bad in (-1, 0x800):
        with pytest.raises(ConfigError, match=r"devices\[0\]\.master_id"):
            read_master_id(device(master_id=bad))


@pytest.mark.parametrize(("ids", "match"), [
    ([1, 2], "an array of 3 drive ids"), ([1, 2, 3, 4], "an array of 3"), ([1, 2, True], "an array of 3"),
    ([1, 2, 3.0], "an array of 3"), (3, "an array of 3"),
    ([1, 2, 2], "distinct"), ([0, 1, 2], "distinct"), ([1, 2, 0x800], "distinct"),
    # within the standard ids, but more than a reply's byte 0 can name
    ([1, 2, 0x100], "ids ≤ 0xFF"), ([1, 2, 0x7FF], "ids ≤ 0xFF"),
])
def test_drive_ids_are_refused_naming_the_key(ids, match):
    refused("devices[0].ids", match, ids=ids)


def test_a_drive_id_may_not_be_the_master_id():
    refused("devices[0].ids", "other than master_id 0x5", ids=[1, 5, 3], master_id=5)
    refused("devices[0].ids", "distinct", ids=[0, 1, 2], master_id=5)  # 0 is no drive's id, whatever the master's
    assert [j.drive_id for j in read(ids=[1, 2, 3], master_id=4)] == [1, 2, 3]


def test_damiao_ids_fit_the_low_nibble():
    assert read(["a"], ids=[0x0F], drive_model="dm4310")[0].drive_id == 0x0F
    refused("devices[0].ids", "ids ≤ 0x0F for Damiao", ["a"], ids=[0x10], drive_model="dm4310")


def test_every_reply_a_damiao_drive_can_send_names_its_joint():
    joint = MitJoint("a", 3, DM)
    heads = {mit.pack_reply(DM, 3, 0.0, 0.0, 0.0, enabled=False)[0]}
    heads |= {mit.pack_reply(DM, 3, 0.0, 0.0, 0.0, error=state)[0] for state in range(1, 16)}
    assert set(reply_keys(joint)) == heads and len(heads) == 16
    assert reply_keys(MitJoint("b", 3, mit.KATZ)) == (mit.pack_reply(mit.KATZ, 3, 0.0, 0.0, 0.0)[0],)


def test_drives_whose_replies_look_alike_are_refused():
    # a Damiao drive 1 in state 1 answers with byte 0 = 0x11, as a Katz drive 0x11 does
    refused("devices[0].ids", "both answer with byte 0 = 0x11", ["a", "b"], ids=[1, 0x11],
            drives={"a": {"drive_model": "dm4310"}})
    refused("devices[0].ids", "both answer with byte 0 = 0x11", ["a", "b"], ids=[0x11, 1],
            drives={"b": {"drive_model": "dm4310"}})
    assert len(read(["a", "b"], ids=[1, 0x12], drives={"a": {"drive_model": "dm4310"}})) == 2


@pytest.mark.parametrize("direction", [0, 2, -2])
def test_a_mounting_direction_is_plus_or_minus_one(direction):
    refused("devices[0].drives.shoulder.direction", r"1 or -1|[≤≥]", drives={"shoulder": {"direction": direction}})


def test_errors_name_where_the_bad_value_is_written():
    refused("devices[0].t_range", "min < max", t_range=[1.0, -1.0])
    refused("devices[0].drives.elbow.t_range", "min < max", drives={"elbow": {"t_range": [1.0, -1.0]}})
    refused("devices[0].drives.elbow.kp", "unknown key", drives={"elbow": {"kp": 3.0}})
    refused("devices[0].drives.wrist", "unknown key", drives={"wrist": {"direction": -1}})


def test_a_joint_cannot_be_changed_in_place():
    """The driver reads direction and offset every tick: a joint is fixed once the device is built."""
    import dataclasses

    with pytest.raises(dataclasses.FrozenInstanceError):
        read()[0].direction = -1.0
