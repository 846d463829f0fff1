"""A robot description as a MuJoCo model (MJCF), for the independent plant (docs/mujoco.md).

The kinematic tree maps one to one: rtctl's body ``i`` (the frame joint ``i`` moves, placed in
body ``parent[i]`` by ``T_tree[i] · T_joint(q_i)``) is a MuJoCo body at ``pos``/``quat`` =
``T_tree[i]`` whose joint sits at its origin, about (or along) ``axis[i]`` in its own frame. The
inertial parameters π_i (m, m·c, J about the body origin) become MuJoCo's mass, centre of mass
and inertia about the centre of mass by the parallel-axis theorem, J_c = J − m (|c|² 1 − c cᵀ).

What the drive train adds, in MuJoCo's own terms: ``armature`` (reflected rotor inertia, added
to the diagonal of M exactly as rtctl's plant adds it), ``damping`` (viscous friction b q̇) and
``frictionloss`` (Coulomb friction τ_c, which MuJoCo solves as a dry-friction constraint where
rtctl's plant smooths it as τ_c tanh(q̇ / v_c)); ``range`` the joint limits. A payload is a body
of its own welded at the flange — MuJoCo adds it to the tree, independently of how rtctl would
fold it into the last link.
"""
from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np

from hil_sim.payload import Payload
from rtctl.model.robot import PRISMATIC

MIN_INERTIA = 1e-12  # MuJoCo refuses a moving body with no mass and no inertia (PUMA's waist link has no mass)


def inertial_about_com(params) -> tuple[float, np.ndarray, np.ndarray]:
    """(m, c, I_c) of the 10 parameters (m, m c, J_xx, J_xy, J_yy, J_xz, J_yz, J_zz about the origin)."""
    m = float(params[0])
    c = np.asarray(params[1:4], float) / m if m > 0 else np.zeros(3)
    Jxx, Jxy, Jyy, Jxz, Jyz, Jzz = params[4:10]
    J = np.array([[Jxx, Jxy, Jxz], [Jxy, Jyy, Jyz], [Jxz, Jyz, Jzz]], float)
    return m, c, J - m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))


def physical_inertia(I: np.ndarray) -> np.ndarray:
    """The nearest inertia a rigid body can have, as MuJoCo requires (each principal moment at most
    the sum of the other two): when the two smaller moments a ≤ b fall short of the largest c, both
    are raised by (c − a − b)/2 about their own principal axes. I itself when it is physical."""
    moments, V = np.linalg.eigh(I)
    moments = np.maximum(moments, 0.0)
    short = moments[2] - moments[0] - moments[1]
    if short <= 1e-12 * max(moments[2], 1.0):
        return I
    moments[:2] += 0.5 * short
    return V @ np.diag(moments) @ V.T


def physical_model(model):
    """``model`` with every link's inertia made physical (:func:`physical_inertia`), and the links
    changed: [(name, moments before, after)]. What MuJoCo simulates; for a massless link at the
    base on a revolute joint (the PUMA's waist) the change is across its axis and the dynamics are
    the same; elsewhere (the PUMA's elbow, 0.0125 + 0.066 < 0.086 kg·m² in the published data) the
    plant differs from the model by the change."""
    params, changed = np.array(model.params, float), []
    for i in range(model.nq):
        m, c, I = inertial_about_com(params[i])
        fixed = physical_inertia(I)
        if fixed is not I:
            J = fixed + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
            params[i, 4:] = J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]
            changed.append((model.joint_names[i], np.linalg.eigvalsh(I).round(6).tolist(),
                            np.linalg.eigvalsh(fixed).round(6).tolist()))
    return (model.with_params(params) if changed else model), changed


def _quat(R) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method, numerically safe)."""
    R = np.asarray(R, float)
    t = np.trace(R)
    if t > 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
        q = np.zeros(4)
        q[0] = (R[k, j] - R[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (R[j, i] + R[i, j]) / s
        q[1 + k] = (R[k, i] + R[i, k]) / s
    q = np.asarray(q, float)
    return q / np.linalg.norm(q)


def _v(x) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(x))


def _inertial(m: float, c, I) -> str:
    full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
    return f'<inertial pos="{_v(c)}" mass="{_v(max(m, MIN_INERTIA))}" fullinertia="{_v(full)}"/>'


def to_mjcf(model, *, timestep: float, integrator: str = "RK4", armature=None, damping=None, frictionloss=None,
            payload: Payload | None = None) -> str:
    """MJCF text of ``model`` (per-joint ``armature``, ``damping``, ``frictionloss``: arrays, default 0),
    its inertias made physical first (:func:`physical_model`)."""
    model, _ = physical_model(model)
    n = model.nq
    zero = np.zeros(n)
    armature, damping, frictionloss = (zero if a is None else np.asarray(a, float)
                                       for a in (armature, damping, frictionloss))
    children = {i: [j for j in range(n) if model.parent[j] == i] for i in range(-1, n)}

    def body(i: int, indent: str) -> list[str]:
        kind = "slide" if model.joint_types[i] == PRISMATIC else "hinge"
        limited = np.isfinite(model.q_min[i]) and np.isfinite(model.q_max[i])
        lines = [f'{indent}<body name={quoteattr("link_" + model.joint_names[i])} pos="{_v(model.p_tree[i])}" '
                 f'quat="{_v(_quat(model.R_tree[i]))}">',
                 f'{indent}  <joint name={quoteattr(model.joint_names[i])} type="{kind}" axis="{_v(model.axis[i])}" '
                 f'armature="{_v(armature[i])}" damping="{_v(damping[i])}" frictionloss="{_v(frictionloss[i])}"'
                 + (f' limited="true" range="{_v([model.q_min[i], model.q_max[i]])}"' if limited else ' limited="false"')
                 + "/>",
                 f"{indent}  {_inertial(*inertial_about_com(model.params[i]))}"]
        for j in children[i]:
            lines += body(j, indent + "  ")
        if payload is not None and not children[i] and i == n - 1:
            R, p = model.flange[:3, :3], model.flange[:3, 3]
            lines += [f'{indent}  <body name="payload" pos="{_v(p)}" quat="{_v(_quat(R))}">',
                      f"{indent}    {_inertial(payload.mass, payload.com, payload.inertia_matrix())}",
                      f"{indent}  </body>"]
        return lines + [f"{indent}</body>"]

    lines = [f"<mujoco model={quoteattr(model.name)}>",
             '  <compiler angle="radian" autolimits="false" boundmass="1e-12" boundinertia="1e-12"/>',
             f'  <option timestep="{_v(timestep)}" gravity="{_v(model.gravity)}" integrator="{integrator}"/>',
             "  <worldbody>"]
    for i in children[-1]:
        lines += body(i, "    ")
    return "\n".join(lines + ["  </worldbody>", "</mujoco>", ""])
