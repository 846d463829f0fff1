"""Forward, differential and inverse kinematics with a tool frame (docs/kinematics.md).

Frames follow :mod:`rtctl.model.robot`: body ``i`` sits in body ``parent[i]`` at
``T_tree[i] @ T_joint(q_i)``, and the tool pose is F = ⁰Tₙ(q) · flange · tool (eq. 7, the
paper's ⁰Tₙ · ⁿA_T with ⁿA_T = flange · tool). Twists are [v; ω]: the linear velocity of the
tool point and the angular velocity, both in base coordinates (eq. 25).

Public API: :func:`fk`, :func:`link_poses`, :func:`jacobian`, :func:`tool_twist`,
:func:`joint_rates`, :func:`to_oat` / :func:`from_oat` (orientation angles about the
orientation reference frame, :mod:`rtctl.model.oat`), :func:`ik` and :func:`ik_solutions`
(closed form for PUMA-type arms, :mod:`rtctl.model.ik_puma`, whose branches are
:class:`ArmConfig` and :func:`configuration`; damped Levenberg-Marquardt otherwise,
:mod:`rtctl.model.ik_numeric`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from rtctl.errors import KinematicsError
from rtctl.model import checks, ik_puma
from rtctl.model.ik_puma import Arm, ArmConfig, Elbow, IKSolution, Wrist, configuration
from rtctl.model.oat import from_oat, to_oat
from rtctl.model.robot import PRISMATIC, Model


@njit(cache=True)
def _body_frames_kernel(joint_types, parent, axis, R_tree, p_tree, q, R, p):
    """R[i], p[i] ← orientation and origin of body i in the base (eq. 3 over the tree)."""
    rot, Rj, t = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    for i in range(q.shape[0]):
        x, y, z = axis[i, 0], axis[i, 1], axis[i, 2]
        if joint_types[i] == PRISMATIC:  # T_tree · Trans(axis q)
            rot[:, :] = 0.0
            rot[0, 0] = rot[1, 1] = rot[2, 2] = 1.0
            slide = q[i]
        else:  # T_tree · Rot(axis, q), Rodrigues' formula
            c, s = np.cos(q[i]), np.sin(q[i])
            v = 1.0 - c
            rot[0, 0], rot[0, 1], rot[0, 2] = c + x * x * v, x * y * v - z * s, x * z * v + y * s
            rot[1, 0], rot[1, 1], rot[1, 2] = y * x * v + z * s, c + y * y * v, y * z * v - x * s
            rot[2, 0], rot[2, 1], rot[2, 2] = z * x * v - y * s, z * y * v + x * s, c + z * z * v
            slide = 0.0
        for r in range(3):
            a0, a1, a2 = R_tree[i, r, 0], R_tree[i, r, 1], R_tree[i, r, 2]
            t[r] = p_tree[i, r] + slide * (a0 * x + a1 * y + a2 * z)
            for col in range(3):
                Rj[r, col] = a0 * rot[0, col] + a1 * rot[1, col] + a2 * rot[2, col]
        k = parent[i]
        if k < 0:
            R[i] = Rj
            p[i] = t
        else:
            for r in range(3):
                b0, b1, b2 = R[k, r, 0], R[k, r, 1], R[k, r, 2]
                p[i, r] = p[k, r] + b0 * t[0] + b1 * t[1] + b2 * t[2]
                for col in range(3):
                    R[i, r, col] = b0 * Rj[0, col] + b1 * Rj[1, col] + b2 * Rj[2, col]


@njit(cache=True)
def _jacobian_kernel(joint_types, on_path, axis, R, p, tool_point, J):
    """Columns [zᵢ × (p − pᵢ); zᵢ] (revolute) or [zᵢ; 0] (prismatic), eqs. 20-26."""
    J[:, :] = 0.0
    z = np.empty(3)
    for i in range(R.shape[0]):
        if not on_path[i]:
            continue
        for r in range(3):
            z[r] = R[i, r, 0] * axis[i, 0] + R[i, r, 1] * axis[i, 1] + R[i, r, 2] * axis[i, 2]
        if joint_types[i] == PRISMATIC:
            J[0:3, i] = z
        else:
            d0, d1, d2 = tool_point[0] - p[i, 0], tool_point[1] - p[i, 1], tool_point[2] - p[i, 2]
            J[0, i] = z[1] * d2 - z[2] * d1
            J[1, i] = z[2] * d0 - z[0] * d2
            J[2, i] = z[0] * d1 - z[1] * d0
            J[3:6, i] = z


def _body_frames(model: Model, q) -> tuple[np.ndarray, np.ndarray]:
    """Orientations (n, 3, 3) and origins (n, 3) of every body in base coordinates; ``q`` is
    checked here, before the kernel reads n values from it."""
    n = model.nq
    R, p = np.empty((n, 3, 3)), np.empty((n, 3))
    _body_frames_kernel(model.joint_types, model.parent, model.axis, model.R_tree, model.p_tree,
                        checks.vector(q, n, "q"), R, p)
    return R, p


def _tool_from_last(model: Model, R_last, p_last) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_last, p_last
    return T @ (model.flange @ model.tool)


def link_poses(model: Model, q) -> np.ndarray:
    """Placements (n, 4, 4) of every body in base coordinates (body i moves with joint i)."""
    R, p = _body_frames(model, q)
    T = np.zeros((model.nq, 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, p, 1.0
    return T


def fk(model: Model, q) -> np.ndarray:
    """The tool pose F = ⁰Tₙ(q) · flange · tool (eqs. 3, 7) as a 4×4 homogeneous matrix."""
    R, p = _body_frames(model, q)
    return _tool_from_last(model, R[-1], p[-1])


def _chain_to_tool(model: Model) -> np.ndarray:
    """Mask of the joints that move the tool (the last body and its ancestors)."""
    on_path = np.zeros(model.nq, dtype=np.bool_)
    i = model.nq - 1
    while i >= 0:
        on_path[i] = True
        i = model.parent[i]
    return on_path


def jacobian(model: Model, q) -> np.ndarray:
    """Geometric Jacobian (6×n) of the tool point, rows [linear; angular] in base coordinates.

    Column i (eqs. 20-26) is [zᵢ × (p − pᵢ); zᵢ] for a revolute joint and [zᵢ; 0] for a
    prismatic one, zᵢ the joint axis and pᵢ a point on it (body i's origin), p the tool point.
    """
    R, p = _body_frames(model, q)
    tool_point = _tool_from_last(model, R[-1], p[-1])[:3, 3]
    J = np.empty((6, model.nq))
    _jacobian_kernel(model.joint_types, _chain_to_tool(model), model.axis, R, p, tool_point, J)
    return J


def tool_twist(model: Model, q, qd) -> np.ndarray:
    """Forward differential kinematics: the tool twist [v; ω] = J(q) q̇ (eq. 25)."""
    return jacobian(model, q) @ checks.vector(qd, model.nq, "qd")


@dataclass(frozen=True)
class RateInfo:
    """How well-conditioned an inverse differential kinematics solve was.

    ``sigma_min`` is J's smallest singular value (of min(6, n)); ``manipulability`` is
    Yoshikawa's product of the singular values; ``singular`` is true when ``sigma_min`` fell
    below the threshold and ``damping`` (λ) was used; ``residual`` = ‖J q̇ − twist‖, the part of
    the twist the damped (or, for n < 6, least-squares) solution does not deliver.
    """

    sigma_min: float
    manipulability: float
    damping: float
    singular: bool
    residual: float


def joint_rates(model: Model, q, twist, damping: float = 0.05, threshold: float = 0.02):
    """Inverse differential kinematics: q̇ for a desired tool twist [v; ω] → (q̇, RateInfo).

    Where J is regular (σ_min ≥ ``threshold``) this is the exact solve (the minimum-norm
    least-squares solution for n ≠ 6). Nearer a singularity it becomes damped least squares,
    q̇ = Σ σᵢ / (σᵢ² + λ²) vᵢ uᵢᵀ twist, with λ² = damping² (1 − (σ_min/threshold)²) growing
    smoothly from 0 at the threshold to ``damping``² at the singularity (Nakamura & Hanafusa
    1986; Chiaverini 1997), so joint rates stay bounded. σ mixes m/rad (linear rows) and
    rad/rad (angular rows); the defaults suit arms about a metre long.
    """
    J = jacobian(model, q)
    twist = checks.vector(twist, 6, "twist", "components [v; ω]")
    damping = checks.number(damping, "damping", positive=True)
    threshold = checks.number(threshold, "threshold", positive=True)
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    sigma_min = float(S[-1])
    singular = sigma_min < threshold
    lam2 = damping * damping * (1.0 - (sigma_min / threshold) ** 2) if singular else 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        gains = np.where(S * S + lam2 > 0.0, S / (S * S + lam2), 0.0)
    qd = Vt.T @ (gains * (U.T @ twist))
    info = RateInfo(
        sigma_min=sigma_min,
        manipulability=float(np.prod(S)),
        damping=math.sqrt(lam2),
        singular=bool(singular),
        residual=float(np.linalg.norm(J @ qd - twist)),
    )
    return qd, info


def ik_solutions(model: Model, pose, q_seed=None, within_limits: bool = False):
    """Every closed-form IK solution of a PUMA-type arm (up to 8), as IKSolution(q, config).

    ``q_seed`` fixes q4 at a wrist singularity (where only q4 + q6 is determined). With
    ``within_limits`` each angle is moved by multiples of 2π into the joint limits and
    solutions that cannot be are dropped. Raises KinematicsError for other arms or when the
    pose is out of reach.
    """
    pose = checks.matrix(pose, (4, 4), "pose")
    q_seed = None if q_seed is None else checks.vector(q_seed, model.nq, "q_seed")
    solutions = ik_puma.solutions(model, pose, q_seed)
    if within_limits:
        solutions = ik_puma.within_limits(model, solutions, q_seed)
    return solutions


def ik(model: Model, pose, q_seed=None, config=None, *, method: str = "auto",
       within_limits: bool = True, **numeric_options) -> np.ndarray:
    """Joint angles placing the tool at ``pose`` (4×4): F(ik(pose)) = pose.

    ``method``: "closed_form" (PUMA-type arms, :mod:`rtctl.model.ik_puma`), "numeric"
    (damped Levenberg-Marquardt, any chain, :mod:`rtctl.model.ik_numeric`; options
    ``tol``, ``max_iter``, ``restarts``, ``seed``) or "auto" (closed form where it applies).
    Closed form: ``config`` (an :class:`ArmConfig` or a code such as "run") selects the
    arm/elbow/wrist branch; otherwise the solution nearest ``q_seed`` (the first in the order
    right-up-noflip … when there is no seed). ``within_limits`` keeps to the joint limits
    (the numeric solver always does). Raises KinematicsError when unreachable or not converged.
    """
    from rtctl.model import ik_numeric  # it builds on fk and jacobian above

    pose = checks.matrix(pose, (4, 4), "pose")
    q_seed = None if q_seed is None else checks.vector(q_seed, model.nq, "q_seed")
    if method not in ("auto", "closed_form", "numeric"):
        raise ValueError(f"method must be 'auto', 'closed_form' or 'numeric', not {method!r}")
    closed = method == "closed_form" or (method == "auto" and ik_puma.is_puma_type(model))
    if not closed:
        if config is not None:
            raise KinematicsError(f"{model.name}: a configuration selects a closed-form branch; "
                                  "the numeric solver takes q_seed instead")
        return ik_numeric.solve(model, pose, q_seed, **numeric_options)
    if numeric_options:
        raise TypeError(f"options {sorted(numeric_options)} apply to the numeric solver only")
    solutions = ik_solutions(model, pose, q_seed, within_limits)
    return ik_puma.select(model, solutions, q_seed, config, near_seed=not within_limits)


__all__ = ["fk", "link_poses", "jacobian", "tool_twist", "joint_rates", "RateInfo",
           "to_oat", "from_oat", "ik", "ik_solutions", "configuration", "ArmConfig", "Arm", "Elbow", "Wrist",
           "IKSolution"]
