"""Robots from a TOML D-H table (Paul's standard D-H, eq. 1 of docs/kinematics.md).

    ⁱ⁻¹Aᵢ = Rot(z, θᵢ) · Trans(0, 0, dᵢ) · Trans(aᵢ, 0, 0) · Rot(x, αᵢ)        (1)

Body ``i`` of the model is D-H frame ``i-1`` moved by joint ``i`` (Rot(z, qᵢ) or
Trans(z, qᵢ)); the fixed rest of Aᵢ, ``Fᵢ = Rot(z, θ0ᵢ) Trans(0,0,dᵢ) Trans(aᵢ,0,0) Rot(x, αᵢ)``,
becomes the tree placement of joint ``i+1`` (and the flange for the last link). Inertial data
is given as Corke's Robotics Toolbox gives it — mass, centre of mass and inertia about the
centre of mass, all in D-H frame ``i`` — and moved into body ``i`` here.

File layout (lengths in metres; angles in ``angle_unit``, "deg" or "rad")::

    name = "puma560"
    angle_unit = "deg"
    gravity = [0, 0, -9.81]            # optional
    reconstructed = "why"              # optional: the table is a reading of a garbled source
    [[joints]]
    name = "waist"   type = "revolute"  alpha = 90  a = 0  d = 0  theta0 = 0
    q_min = -160  q_max = 160  v_max = 8  tau_max = 97.6          # optional limits
    mass = 0  com = [0, 0, 0]  inertia = [Ixx, Iyy, Izz, Ixy, Iyz, Ixz]
    motor = { Jm = 200e-6, G = -62.61, B = 1.48e-3, Tc = [0.395, -0.435] }   # optional, motor side
    [tool]                             # optional tool frame in the flange (eq. 6)
    xyz = [0, 0, 0.1]  rpy = [0, 0, 0]
    [[guard.zones]]                    # optional interference zones (rtctl.guard.config)
"""
from __future__ import annotations

import numpy as np

from rtctl.model.robot import MAX_JOINTS, PRISMATIC, REVOLUTE, DHTable, Model, Motors
from rtctl.model.rotations import hrot_x, hrot_z, homogeneous, rpy_matrix, trans
from rtctl.tomltable import Table

_JOINT_TYPES = {"revolute": REVOLUTE, "prismatic": PRISMATIC}
# the range of every number (in the file's units): past these, products overflow or nothing is a robot
LENGTH, ANGLE, MASS, INERTIA, EFFORT, GEAR = 1e3, 1e4, 1e5, 1e5, 1e7, 1e5


def dh_fixed(alpha: float, a: float, d: float, theta0: float) -> np.ndarray:
    """Fᵢ: the part of ⁱ⁻¹Aᵢ that does not move with the joint variable."""
    return hrot_z(theta0) @ trans(0.0, 0.0, d) @ trans(a, 0.0, 0.0) @ hrot_x(alpha)


def inertial_params(mass: float, com, inertia_com) -> np.ndarray:
    """The 10 parameters (Pinocchio's order) from mass, centre of mass and the 3×3 inertia
    about the centre of mass, all in the same frame: J = I_c + m (cᵀc 1 − c cᵀ)."""
    c = np.asarray(com, dtype=float)
    J = np.asarray(inertia_com, dtype=float) + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([mass, *(mass * c), J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]])


def _inertia_matrix(v) -> np.ndarray:
    ixx, iyy, izz, ixy, iyz, ixz = v
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def from_table(t: Table) -> Model:
    """Build a Model from a parsed D-H TOML table (see module docstring)."""
    name = t.str("name")
    unit = t.str("angle_unit", "rad", choices=("deg", "rad"))
    ang = np.pi / 180.0 if unit == "deg" else 1.0
    gravity = t.vector("gravity", 3, [0.0, 0.0, -9.81], min=-1e3, max=1e3)
    reconstructed = t.str("reconstructed", None)
    t.str("source", "")
    t.str("convention", "dh", choices=("dh",))
    t.table("guard", None)  # the robot's interference zones: read by rtctl.guard.config
    joints = t.tables("joints")
    if not 1 <= len(joints) <= MAX_JOINTS:
        raise t.error("joints", f"1 to {MAX_JOINTS} [[joints]] tables (the robot size rtctl supports), "
                                f"got {len(joints)}")

    names, types, dh_rows, params, limits, motor_rows = [], [], [], [], [], []
    for j in joints:
        jtype = _JOINT_TYPES[j.str("type", "revolute", choices=tuple(_JOINT_TYPES))]
        lin = 1.0 if jtype == PRISMATIC else ang  # unit of this joint's variable
        names.append(j.str("name"))
        if not names[-1] or names[-1] in names[:-1]:
            raise j.error("name", f"a joint name used once; {names[-1]!r} is {'taken' if names[-1] else 'empty'}")
        types.append(jtype)
        row = (j.float("alpha", min=-ANGLE, max=ANGLE) * ang, j.float("a", min=-LENGTH, max=LENGTH),
               j.float("d", min=-LENGTH, max=LENGTH), j.float("theta0", 0.0, min=-ANGLE, max=ANGLE) * ang)
        dh_rows.append(row)
        F = dh_fixed(*row)
        mass = j.float("mass", 0.0, min=0.0, max=MASS)
        com = j.vector("com", 3, np.zeros(3), min=-LENGTH, max=LENGTH)
        Ic = _inertia_matrix(j.vector("inertia", 6, np.zeros(6), min=-INERTIA, max=INERTIA))
        if np.any(np.linalg.eigvalsh(Ic) < -1e-12):
            raise j.error("inertia", "a positive semi-definite inertia about the centre of mass")
        # Move from D-H frame i into body i: x_body = R_F x_dh + p_F.
        R, p = F[:3, :3], F[:3, 3]
        params.append(inertial_params(mass, R @ com + p, R @ Ic @ R.T))
        limits.append((j.float("q_min", -np.inf, min=-ANGLE, max=ANGLE) * lin,
                       j.float("q_max", np.inf, min=-ANGLE, max=ANGLE) * lin,
                       j.float("v_max", np.inf, positive=True, max=ANGLE) * lin,
                       j.float("tau_max", np.inf, positive=True, max=EFFORT)))
        if limits[-1][0] >= limits[-1][1]:
            raise j.error("q_max", f"greater than q_min ({limits[-1][0] / lin:g})")
        motor = j.table("motor", None)
        if motor is not None:
            Jm, B = motor.float("Jm", 0.0, min=0.0, max=1.0), motor.float("B", 0.0, min=0.0, max=1.0)
            G = motor.float("G", 1.0, min=-GEAR, max=GEAR)
            Tc = np.abs(motor.vector("Tc", 2, np.zeros(2), min=-EFFORT, max=EFFORT))
            motor.done()
            motor_rows.append((G * G * Jm, G * G * B, abs(G) * Tc.mean(), G))
        else:
            motor_rows.append((0.0, 0.0, 0.0, 1.0))
        j.done()

    n = len(names)
    fixed = [dh_fixed(*row) for row in dh_rows]
    R_tree, p_tree = np.zeros((n, 3, 3)), np.zeros((n, 3))
    R_tree[0] = np.eye(3)
    for i in range(1, n):
        R_tree[i], p_tree[i] = fixed[i - 1][:3, :3], fixed[i - 1][:3, 3]
    tool = np.eye(4)
    tool_t = t.table("tool", None)
    if tool_t is not None:
        tool = homogeneous(rpy_matrix(tool_t.vector("rpy", 3, np.zeros(3), min=-ANGLE, max=ANGLE) * ang),
                           tool_t.vector("xyz", 3, np.zeros(3), min=-LENGTH, max=LENGTH))
        tool_t.done()
    t.done()

    lim = np.array(limits)
    mot = np.array(motor_rows)
    return Model(
        name=name,
        joint_names=tuple(names),
        joint_types=np.array(types, dtype=np.int64),
        parent=np.arange(n, dtype=np.int64) - 1,
        axis=np.tile([0.0, 0.0, 1.0], (n, 1)),
        R_tree=R_tree,
        p_tree=p_tree,
        params=np.array(params),
        gravity=gravity,
        q_min=lim[:, 0], q_max=lim[:, 1], v_max=lim[:, 2], tau_max=lim[:, 3],
        flange=fixed[-1],
        tool=tool,
        dh=DHTable(*(np.array(col) for col in zip(*dh_rows))),
        motors=Motors(armature=mot[:, 0], viscous=mot[:, 1], coulomb=mot[:, 2], gear_ratio=mot[:, 3]),
        reconstructed=reconstructed,
    )
