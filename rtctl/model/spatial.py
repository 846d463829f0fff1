"""Spatial algebra in Featherstone's Plücker convention (Rigid Body Dynamics Algorithms, 2008).

Motion vectors are ``[ω; v]``, force vectors ``[n; f]`` (angular part first). Names follow
the book and spatial_v2: ``crm``, ``crf``, ``mcI``, ``rotx``…, ``xlt``, ``jcalc``. These are
small numpy 6×6 functions for descriptions, tests and reference algorithms; the compiled
per-tick kernels (:mod:`rtctl.model.spatial_kernels`) compute the same products on 3-vectors
without forming 6×6 matrices.

A Plücker transform ``X = ᴮX_A`` maps motion vectors from A to B coordinates. With B's origin
at ``p`` and orientation ``R`` in A (x_A = R x_B + p), ``X = [[E, 0], [−E p×, E]]`` with
``E = Rᵀ`` (book eq. 2.24); force vectors transform with ``X* = X⁻ᵀ``.

The spatial inertia of a body about its frame origin, in its coordinates, is linear in the
10 inertial parameters in Pinocchio's order (docs/cstar_slotine_li.md)::

    π = (m, m c_x, m c_y, m c_z, J_xx, J_xy, J_yy, J_xz, J_yz, J_zz)
    I(π) = [[J, m ĉ], [m ĉᵀ, m 1₃]] = Σ_k R_k π_k                                     (17)
"""
from __future__ import annotations

import numpy as np

from rtctl.model.robot import PRISMATIC, REVOLUTE
from rtctl.model.rotations import rot_axis, skew

__all__ = [
    "skew", "crm", "crf", "icrf", "mcI", "inertia", "inertia_params", "inertia_basis",
    "inertia_regressor", "plucker", "plucker_inv", "force_transform", "xlt", "rot",
    "joint_axis", "jcalc",
]


def crm(v) -> np.ndarray:
    """Motion cross product matrix: ``crm(v) m = v × m`` (book eq. 2.31)."""
    w, u = skew(v[:3]), skew(v[3:])
    out = np.zeros((6, 6))
    out[:3, :3] = w
    out[3:, :3] = u
    out[3:, 3:] = w
    return out


def crf(v) -> np.ndarray:
    """Force cross product matrix: ``crf(v) f = v ×* f = −crm(v)ᵀ f`` (book eq. 2.32)."""
    return -crm(v).T


def icrf(f) -> np.ndarray:
    """The matrix with ``icrf(f) v = crf(v) f`` (v ×* f as a linear map of v)."""
    out = np.zeros((6, 6))
    out[:3, :3] = -skew(f[:3])
    out[:3, 3:] = -skew(f[3:])
    out[3:, :3] = -skew(f[3:])
    return out


def mcI(m: float, c, I_c) -> np.ndarray:
    """Spatial inertia from mass, centre of mass and rotational inertia about the centre of
    mass (book eq. 2.63): ``[[I_c + m ĉ ĉᵀ, m ĉ], [m ĉᵀ, m 1]]``."""
    C = skew(c)
    out = np.zeros((6, 6))
    out[:3, :3] = np.asarray(I_c, float) + m * C @ C.T
    out[:3, 3:] = m * C
    out[3:, :3] = m * C.T
    out[3:, 3:] = m * np.eye(3)
    return out


def inertia(params) -> np.ndarray:
    """Spatial inertia I(π) from the 10 parameters (Pinocchio's order; J about the origin)."""
    m, hx, hy, hz, jxx, jxy, jyy, jxz, jyz, jzz = params
    H = skew((hx, hy, hz))
    out = np.zeros((6, 6))
    out[:3, :3] = [[jxx, jxy, jxz], [jxy, jyy, jyz], [jxz, jyz, jzz]]
    out[:3, 3:] = H
    out[3:, :3] = H.T
    out[3:, 3:] = m * np.eye(3)
    return out


def inertia_params(I) -> np.ndarray:
    """Inverse of :func:`inertia`: the 10 parameters of a spatial inertia matrix."""
    I = np.asarray(I, float)
    J = I[:3, :3]
    h = np.array([-I[1, 5], I[0, 5], -I[0, 4]])  # the upper-right block is h×
    return np.array([I[3, 3], *h, J[0, 0], J[0, 1], J[1, 1], J[0, 2], J[1, 2], J[2, 2]])


def inertia_basis() -> np.ndarray:
    """The ten constant 6×6 matrices R_k with I(π) = Σ_k R_k π_k (eq. 17), shape (10, 6, 6)."""
    return np.array([inertia(e) for e in np.eye(10)])


def inertia_regressor(x) -> np.ndarray:
    """The 6×10 matrix A(x) with I(π) x = A(x) π, for a motion vector x = [ω; v]."""
    w, v = np.asarray(x[:3], float), np.asarray(x[3:], float)
    A = np.zeros((6, 10))
    A[3:, 0] = v
    A[:3, 1:4] = -skew(v)  # h × v = −v × h
    A[3:, 1:4] = skew(w)  # −h × ω = ω × h
    wx, wy, wz = w
    # J ω with J = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], columns (xx, xy, yy, xz, yz, zz)
    A[:3, 4:] = [[wx, wy, 0, wz, 0, 0], [0, wx, wy, 0, wz, 0], [0, 0, 0, wx, wy, wz]]
    return A


def plucker(R, p) -> np.ndarray:
    """ᴮX_A for frame B at origin ``p`` with orientation ``R`` in frame A (book eq. 2.24)."""
    E = np.asarray(R, float).T
    out = np.zeros((6, 6))
    out[:3, :3] = E
    out[3:, 3:] = E
    out[3:, :3] = -E @ skew(p)
    return out


def plucker_inv(X) -> np.ndarray:
    """ᴬX_B from ᴮX_A without a general inverse: [[Eᵀ, 0], [(−E p×)ᵀ, Eᵀ]]."""
    out = np.zeros((6, 6))
    out[:3, :3] = X[:3, :3].T
    out[3:, 3:] = X[3:, 3:].T
    out[3:, :3] = X[3:, :3].T
    return out


def force_transform(X) -> np.ndarray:
    """X* = X⁻ᵀ, the transform of force vectors that goes with the motion transform X."""
    return plucker_inv(X).T


def xlt(p) -> np.ndarray:
    """Pure translation by ``p`` (book ``xlt``)."""
    return plucker(np.eye(3), p)


def rot(R) -> np.ndarray:
    """Pure rotation: B's orientation ``R`` in A (note: book ``rotx(θ)`` is ``rot(rot_x(θ))``)."""
    return plucker(R, np.zeros(3))


def joint_axis(joint_type: int, axis) -> np.ndarray:
    """The motion subspace S of a 1-DoF joint in its own frame: [k; 0] or [0; k]."""
    S = np.zeros(6)
    if joint_type == REVOLUTE:
        S[:3] = axis
    elif joint_type == PRISMATIC:
        S[3:] = axis
    else:
        raise ValueError(f"unknown joint type {joint_type}")
    return S


def jcalc(joint_type: int, axis, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint transform X_J(q) and motion subspace S for a revolute or prismatic joint about
    the unit vector ``axis`` (book Table 4.1, generalised to any axis)."""
    S = joint_axis(joint_type, axis)
    if joint_type == REVOLUTE:
        return rot(rot_axis(axis, q)), S
    return xlt(np.asarray(axis, float) * q), S
