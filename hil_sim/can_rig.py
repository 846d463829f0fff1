"""Emulated drives mounted on the simulated plant: what the embedded CAN simulator and
``hil-sim`` put at the far end of the wire, built from the same drive layout the driver reads
(:mod:`drivers.protocols.mit_layout`, :mod:`drivers.protocols.cia402_layout`)."""
from __future__ import annotations

import dataclasses
import math

from drivers.protocols.cia402 import EDS
from drivers.protocols.mit import DRIVE_MODELS
from drivers.protocols.mit_layout import MitJoint
from hil_sim.cia402_drive import Cia402Drive
from hil_sim.mit_drive import MappedJointPort, MitDrive

KATZ = DRIVE_MODELS["katz"]


def emulated_drives(joints, indices, plant, *, timeout_s: float = 0.020, master_id: int = 0) -> list[MitDrive]:
    """One MitDrive per joint of the layout, on the plant's joint ``indices[k]``."""
    return [MitDrive(j.drive_id, MappedJointPort(plant.q, plant.qd, plant.tau_cmd, int(i), j.direction, j.offset),
                     j.model, master_id=master_id, timeout_s=timeout_s)
            for j, i in zip(joints, indices)]


def emulated_cia402_drives(joints, indices, plant, *, eds=EDS) -> list[Cia402Drive]:
    """One Cia402Drive per joint of the layout (its scaling, its EDS), on the plant's joint ``indices[k]``."""
    return [Cia402Drive(j.node_id, MappedJointPort(plant.q, plant.qd, plant.tau_cmd, int(i), j.direction, j.offset),
                        rated_torque=j.rated_torque, counts_per_rev=j.counts_per_rev, eds=eds)
            for j, i in zip(joints, indices)]


def sim_layout(model, indices) -> tuple[MitJoint, ...]:
    """Drives for the embedded CAN simulator, ids 1…n: Katz firmware with its torque (and
    reported effort) range set to the joint's torque limit and its velocity range to twice
    the joint's speed limit, so the codec neither saturates below the robot's own limits nor
    wastes resolution; the position range grows only for joints beyond ±12.5."""
    joints = []
    for k, i in enumerate(indices):
        tau, v = model.tau_max[i], model.v_max[i]
        reach = max(abs(model.q_min[i]), abs(model.q_max[i]))
        changes = {}
        if math.isfinite(tau):
            changes["t"] = changes["effort"] = (-float(tau), float(tau))
        if math.isfinite(v):
            changes["v"] = (-2.0 * float(v), 2.0 * float(v))
        if math.isfinite(reach) and reach > KATZ.p[1]:
            changes["p"] = (-1.1 * float(reach), 1.1 * float(reach))
        joints.append(MitJoint(model.joint_names[i], k + 1, dataclasses.replace(KATZ, name="sim", **changes)))
    return tuple(joints)
