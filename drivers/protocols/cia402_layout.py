"""Which CiA 402 drive plays which joint: the layout both ends of the wire must agree on.

Read from a ``[[devices]]`` table of a run configuration by the ``cia402`` driver
(:mod:`drivers.cia402_joints`) and by ``hil-sim`` (which emulates the same drives)::

    joints = ["waist", "shoulder", "elbow"]
    ids = [1, 2, 3]               # CANopen node ids 1…127, in the order of `joints` (default 1, 2, …)
    eds = "drives/x.eds"          # the drives' EDS, relative to the file (default: the one shipped)
    rated_torque = 40.0           # N·m: the drives' rated torque 0x6076, unit of the torque PDOs (‰)
    counts_per_rev = 1048576      # encoder increments per joint revolution (0x608F)

    [devices.drives.shoulder]     # per joint: rated_torque and counts_per_rev again, and the mounting
    rated_torque = 90.0
    direction = -1                # drive position = direction · (q − offset)
    offset = 0.0                  # rad: the joint position of the drive's zero

The driver checks ``rated_torque`` and ``counts_per_rev`` against what each drive reports at
``configure`` (SDO): a drive whose scaling differs from the configuration is refused.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from drivers.protocols.cia402 import EDS, PdoLayout, check_bring_up
from rtctl.tomltable import Table

SCALE_KEYS = ("rated_torque", "counts_per_rev")
DEFAULT_COUNTS_PER_REV = 1 << 20


@dataclass(frozen=True)
class Cia402Joint:
    name: str
    node_id: int
    rated_torque: float  # N·m, a whole number of mN·m (0x6076)
    counts_per_rev: int  # encoder increments per joint revolution
    direction: float = 1.0  # +1 or −1
    offset: float = 0.0

    @property
    def rated_torque_mnm(self) -> int:
        return round(self.rated_torque * 1000)

    @property
    def counts_per_rad(self) -> float:
        return self.counts_per_rev / (2 * math.pi)


def read_eds(t: Table) -> tuple[Path, PdoLayout]:
    """The drives' EDS (``eds``, relative to the configuration) and its PDO set."""
    name = t.str("eds", "")
    path = (t.file.parent / name).resolve() if name else EDS
    if not path.is_file():
        raise t.error("eds", f"an EDS file of the drives, got {name!r} (no such file: {path})")
    try:
        layout = PdoLayout.from_eds(path)
        check_bring_up(path, layout)
    except Exception as e:  # a malformed EDS, a PDO set the driver cannot use, an object the bring-up needs missing
        raise t.error("eds", f"an EDS whose default PDO mapping is a CST set, with the objects the bring-up "
                             f"sets ({type(e).__name__}: {e})") from None
    return path, layout


def _scale(t: Table, defaults: dict) -> dict:
    out = dict(defaults)
    if t.has("rated_torque"):
        rated = t.float("rated_torque", positive=True, max=4_000_000.0)
        if round(rated * 1000) < 1:
            raise t.error("rated_torque", "at least 0.001 N·m (0x6076 counts mN·m)")
        out["rated_torque"] = round(rated * 1000) / 1000
    if t.has("counts_per_rev"):
        out["counts_per_rev"] = t.int("counts_per_rev", min=1, max=2**31 - 1)
    return out


def read_cia402_joints(t: Table, joint_names) -> tuple[Cia402Joint, ...]:
    """The drives of the device table ``t`` serving ``joint_names`` (in order); reads ``ids``,
    the scale keys and ``drives``; the caller calls ``t.done()``."""
    n = len(joint_names)
    ids = t.raw("ids", None)
    if ids is None:
        ids = list(range(1, n + 1))
    if not (isinstance(ids, list) and len(ids) == n and all(isinstance(i, int) and not isinstance(i, bool) for i in ids)):
        raise t.error("ids", f"an array of {n} node ids (integers), one per joint, got {ids!r}")
    if len(set(ids)) != n or any(not 1 <= i <= 127 for i in ids):
        raise t.error("ids", f"distinct CANopen node ids 1…127, got {ids}")
    defaults = _scale(t, {"counts_per_rev": DEFAULT_COUNTS_PER_REV})
    per_joint = t.table("drives", None)
    joints = []
    for name, node_id in zip(joint_names, ids):
        jt = per_joint.table(name, None) if per_joint is not None else None
        scale, direction, offset = defaults, 1.0, 0.0
        if jt is not None:
            scale = _scale(jt, defaults)
            direction = float(jt.int("direction", 1, min=-1, max=1))
            if direction == 0:
                raise jt.error("direction", "1 or -1")
            offset = jt.float("offset", 0.0)
            jt.done()
        if "rated_torque" not in scale:
            raise (jt or t).error("rated_torque", f"the rated torque (N·m) of {name!r}'s drive (0x6076), here or "
                                                  f"in the device table")
        joints.append(Cia402Joint(name, node_id, scale["rated_torque"], scale["counts_per_rev"], direction, offset))
    if per_joint is not None:
        per_joint.done()
    return tuple(joints)
