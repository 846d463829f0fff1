"""3×3 rotations and 4×4 homogeneous transforms (numpy, not on the hot path).

Featherstone's 6×6 Plücker transforms live in :mod:`rtctl.model.spatial`; these are the
plain matrices that descriptions, kinematics and tests speak.
"""
from __future__ import annotations

import numpy as np


def rot_x(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_axis(axis, t: float) -> np.ndarray:
    """Rotation by ``t`` about the unit vector ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float)
    K = skew(k)
    return np.eye(3) + np.sin(t) * K + (1.0 - np.cos(t)) * (K @ K)


def skew(p) -> np.ndarray:
    """The matrix p× such that (p×) y = p × y."""
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    return rot_z(y) @ rot_y(p) @ rot_x(r)


def matrix_rpy(R) -> np.ndarray:
    """Inverse of :func:`rpy_matrix` (pitch in [−π/2, π/2])."""
    pitch = np.arctan2(-R[2, 0], np.hypot(R[0, 0], R[1, 0]))
    if np.hypot(R[0, 0], R[1, 0]) < 1e-12:  # gimbal lock: put everything in yaw
        return np.array([0.0, pitch, np.arctan2(-R[0, 1], R[1, 1])])
    return np.array([np.arctan2(R[2, 1], R[2, 2]), pitch, np.arctan2(R[1, 0], R[0, 0])])


def homogeneous(R=None, p=None) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def trans(x: float, y: float, z: float) -> np.ndarray:
    return homogeneous(p=(x, y, z))


def hrot_x(t: float) -> np.ndarray:
    return homogeneous(rot_x(t))


def hrot_z(t: float) -> np.ndarray:
    return homogeneous(rot_z(t))
