"""Which MIT drive plays which joint: the layout both ends of the wire must agree on.

Read from a ``[[devices]]`` table of a run configuration by the CAN joint driver
(:mod:`drivers.can_joints`) and by ``hil-sim`` (which emulates the same drives), so the ids,
ranges and mounting of every drive are written once::

    joints = ["waist", "shoulder", "elbow"]
    ids = [1, 2, 3]               # drive CAN ids, in the order of `joints` (default 1, 2, …)
    master_id = 0                 # the id the drives reply on
    drive_model = "katz"          # and any of p_range … torque_constant (drivers.protocols.mit):
    t_range = [-40.0, 40.0]       #   the default for every joint of the device

    [devices.drives.shoulder]     # per joint: the model keys again, and the mounting
    t_range = [-190.0, 190.0]
    direction = -1                # drive position = direction · (q − offset)
    offset = 0.0                  # rad (m): the joint position of the drive's zero

A reply names its drive in byte 0 (the whole byte; Damiao: the low nibble, the drive state in
the high one): :func:`reply_keys` lists the byte values that identify each joint, and the layout
is refused when two joints' replies could not be told apart.
"""
from __future__ import annotations

from dataclasses import dataclass

from drivers.protocols.mit import DEFAULT_MASTER_ID, MitDriveModel, ReplyFormat, drive_model_from_table
from rtctl.tomltable import Table

MODEL_KEYS = ("drive_model", "p_range", "v_range", "kp_range", "kd_range", "t_range", "effort_range",
              "reply_format", "torque_constant")


@dataclass(frozen=True)
class MitJoint:
    name: str
    drive_id: int
    model: MitDriveModel
    direction: float = 1.0  # +1 or −1
    offset: float = 0.0


def reply_keys(joint: MitJoint) -> tuple[int, ...]:
    """Values of a reply's byte 0 that belong to this joint's drive."""
    if joint.model.reply_format is ReplyFormat.DAMIAO:
        return tuple(joint.drive_id | (state << 4) for state in range(16))
    return (joint.drive_id,)


def read_master_id(t: Table) -> int:
    return t.int("master_id", DEFAULT_MASTER_ID, min=0, max=0x7FF)


def read_mit_joints(t: Table, joint_names) -> tuple[MitJoint, ...]:
    """The drives of the device table ``t`` serving ``joint_names`` (in order); reads ``ids``,
    ``master_id``, the model keys and ``drives``; the caller calls ``t.done()``."""
    n = len(joint_names)
    master = read_master_id(t)
    ids = t.raw("ids", None)
    if ids is None:
        ids = list(range(1, n + 1))
    if not (isinstance(ids, list) and len(ids) == n and all(isinstance(i, int) and not isinstance(i, bool) for i in ids)):
        raise t.error("ids", f"an array of {n} drive ids (integers), one per joint, got {ids!r}")
    if len(set(ids)) != n or any(not 0 < i <= 0x7FF or i == master for i in ids):
        raise t.error("ids", f"distinct standard CAN ids 1…0x7FF other than master_id {master:#x}, got {ids}")
    defaults = {k: t.raw(k) for k in MODEL_KEYS if t.has(k)}
    drive_model_from_table(Table(dict(defaults), t.file, t.path))  # report a bad default where it is written
    per_joint = t.table("drives", None)
    joints, owner = [], {}
    for name, drive_id in zip(joint_names, ids):
        jt = per_joint.table(name, None) if per_joint is not None else None
        data = dict(defaults)
        direction, offset = 1.0, 0.0
        if jt is not None:
            direction = float(jt.int("direction", 1, min=-1, max=1))
            if direction == 0:
                raise jt.error("direction", "1 or -1")
            offset = jt.float("offset", 0.0)
            data.update({k: jt.raw(k) for k in MODEL_KEYS if jt.has(k)})
            jt.done()
        path = jt.path if jt is not None else t.path
        model = drive_model_from_table(Table(data, t.file, path))
        joint = MitJoint(name, drive_id, model, direction, offset)
        if model.reply_format is not ReplyFormat.DAMIAO and drive_id > 0xFF:
            raise t.error("ids", f"ids ≤ 0xFF: an MIT reply names its drive in one byte ({name}: {drive_id:#x})")
        if model.reply_format is ReplyFormat.DAMIAO and drive_id > 0x0F:
            raise t.error("ids", f"ids ≤ 0x0F for Damiao drives: the reply names its drive in 4 bits ({name}: {drive_id:#x})")
        for key in reply_keys(joint):
            if key in owner:
                raise t.error("ids", f"drives whose replies can be told apart; {name!r} and {owner[key]!r} "
                                     f"both answer with byte 0 = {key:#04x}")
            owner[key] = name
        joints.append(joint)
    if per_joint is not None:
        per_joint.done()
    return tuple(joints)
