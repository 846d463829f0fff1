"""Forward dynamics by CRBA + Cholesky (Featherstone 2008, §6.1 and §6.4; docs/cstar_slotine_li.md):

    (H(q) + diag(armature)) q̈ = τ − (C(q, q̇) q̇ + G(q))

The bias C q̇ + G is RNEA with q̈ = 0, H comes from the CRBA, and the armature (reflected rotor
inertia, as Pinocchio's ``model.armature``) is added to H's diagonal. For the chains rtctl runs
(n ≤ ~10) the dense O(n³) Cholesky costs less than the CRBA itself; ABA would be O(n) but does
more 6×6 work per body.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rtctl.model.crba import crba_passes
from rtctl.model.data import update_joints
from rtctl.model.rnea import rnea_passes
from rtctl.model.spatial_kernels import zero_vector


@njit(cache=True)
def cholesky_solve(H, b):
    """Overwrite H's lower triangle with L (H = L Lᵀ) and b with H⁻¹ b."""
    n = H.shape[0]
    for j in range(n):
        s = H[j, j]
        for k in range(j):
            s -= H[j, k] * H[j, k]
        H[j, j] = np.sqrt(s)  # NaN when H is not positive definite; the caller's NaN check sees it
        for i in range(j + 1, n):
            s = H[i, j]
            for k in range(j):
                s -= H[i, k] * H[j, k]
            H[i, j] = s / H[j, j]
    for i in range(n):  # L y = b
        s = b[i]
        for k in range(i):
            s -= H[i, k] * b[k]
        b[i] = s / H[i, i]
    for i in range(n - 1, -1, -1):  # Lᵀ x = y
        s = b[i]
        for k in range(i + 1, n):
            s -= H[k, i] * b[k]
        b[i] = s / H[i, i]


@njit(cache=True)
def forward_dynamics_kernel(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, armature, qdd):
    """q̈ into ``qdd``; X, body, Ic and H are Data scratch (H ends up holding the factor)."""
    update_joints(joint, geom, q, X, body)
    zero_vector(qdd)
    rnea_passes(joint, params, gravity, X, body, qd, qdd, qdd)  # reads q̈ = 0, then writes C q̇ + G
    crba_passes(joint, params, X, body, Ic, H)
    for i in range(qdd.shape[0]):
        qdd[i] = tau[i] - qdd[i]
        H[i, i] += armature[i]
    cholesky_solve(H, qdd)
