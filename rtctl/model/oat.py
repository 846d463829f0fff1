"""Tool orientation as (O, A, T) angles about the orientation reference frame (docs/kinematics.md).

The orientation reference frame O_R is the base frame rotated +90° about x₀ (eq. 8)::

    R_R = Rot(x, +90°) = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]

and a tool orientation R (in base coordinates) is written (eqs. 9, 11)::

    R = R_R · Rot(y, O) · Rot(x, A) · Rot(z, T)

(O about y, then A about the new x, then T about the new z). With M = R_Rᵀ R:

    M = [[cO cT + sO sA sT,  −cO sT + sO sA cT,  sO cA],
         [cA sT,              cA cT,              −sA  ],
         [−sO cT + cO sA sT,  sO sT + cO sA cT,   cO cA]]

so T = atan2(M₂₁, M₂₂) (1-based). Then N = M · Rot(z, T)ᵀ = Rot(y, O) · Rot(x, A), whose
first column is (cO, 0, −sO) and second row (0, cA, −sA): O and A come from N, which stays
exact however close A is to ±90° (any error in T is absorbed by O). When |A| = 90° the
second row of M vanishes, O and T turn about the same axis and only their difference (A = 90°)
or sum (A = −90°) is defined: there T = 0 (eqs. 12-15 of the paper). A is taken in
[−90°, 90°]; the other triple (O + π, π − A, T + π) gives the same R. Angles are in (−π, π].
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.model import checks
from rtctl.model.rotations import rot_x, rot_y, rot_z

R_REFERENCE = rot_x(np.pi / 2)
R_REFERENCE[np.abs(R_REFERENCE) < 1e-15] = 0.0  # exact 0/±1 entries, as in eq. (8)
R_REFERENCE.setflags(write=False)

# Below this, the second row of M is rounding noise: the orientation is at |A| = 90°.
SINGULAR_TOLERANCE = 1e-12


def _wrap(angle: float) -> float:
    """An angle in (−π, π]."""
    angle = math.remainder(angle, 2.0 * math.pi)
    return math.pi if angle <= -math.pi else angle


def from_oat(o: float, a: float, t: float) -> np.ndarray:
    """R = R_R · Rot(y, O) · Rot(x, A) · Rot(z, T)  (eqs. 9, 11)."""
    o, a, t = (checks.number(x, name) for x, name in ((o, "o"), (a, "a"), (t, "t")))
    return R_REFERENCE @ rot_y(o) @ rot_x(a) @ rot_z(t)


def to_oat(R) -> tuple[float, float, float]:
    """(O, A, T) of a rotation matrix, with A in [−π/2, π/2], T = 0 where |A| = 90°."""
    R = checks.matrix(R, (4, 4) if np.shape(R) == (4, 4) else (3, 3), "R (a rotation, or a 4×4 pose)")
    M = R_REFERENCE.T @ R[:3, :3]
    if math.hypot(M[1, 0], M[1, 1]) < SINGULAR_TOLERANCE:  # |A| = 90°: M = Rot(y, O) Rot(x, ±90°)
        return _wrap(math.atan2(-M[2, 0], M[0, 0])), math.copysign(math.pi / 2, -M[1, 2]), 0.0
    t = math.atan2(M[1, 0], M[1, 1])
    N = M @ rot_z(t).T
    o = math.atan2(-N[2, 0], N[0, 0])
    a = math.atan2(-N[1, 2], N[1, 1])
    return _wrap(o), a, _wrap(t)
