"""Recursive Newton–Euler inverse dynamics (Featherstone 2008, Table 5.1; docs/cstar_slotine_li.md).

    v_i = X_i v_λ + S_i q̇_i                          v_0 = 0
    a_i = X_i a_λ + S_i q̈_i + v_i × S_i q̇_i          a_0 = −g   (gravity as base acceleration)
    f_i = I_i a_i + v_i ×* I_i v_i  (+ Σ children X_cᵀ f_c)
    τ_i = S_iᵀ f_i

τ = H(q) q̈ + C(q, q̇) q̇ + G(q); with q̇ = q̈ = 0 it is G(q), with q̈ = 0 it is C q̇ + G.
"""
from __future__ import annotations

from numba import njit

from rtctl.model.data import ACC, FRC, SUB, TMP, VEL, update_joints
from rtctl.model.spatial_kernels import crf_mul_add, crm_mul_add, dot6, inertia_mul, xforce_T_add, xmotion


@njit(cache=True)
def rnea_passes(joint, params, gravity, X, body, qd, qdd, tau):
    """The two passes of Table 5.1 over transforms already in X (see :func:`update_joints`)."""
    n = joint.shape[0]
    for i in range(n):
        parent = joint[i, 1]
        E, r = X[i, :3], X[i, 3]
        S, v, a, f, Iv = body[i, SUB], body[i, VEL], body[i, ACC], body[i, FRC], body[i, TMP]
        if parent < 0:
            for k in range(3):  # X_i [0; −g]
                v[k] = 0.0
                v[3 + k] = 0.0
                a[k] = 0.0
                a[3 + k] = -(E[k, 0] * gravity[0] + E[k, 1] * gravity[1] + E[k, 2] * gravity[2])
        else:
            xmotion(E, r, body[parent, VEL], v)
            xmotion(E, r, body[parent, ACC], a)
        for k in range(6):
            v[k] += S[k] * qd[i]
            a[k] += S[k] * qdd[i]
        crm_mul_add(v, S, qd[i], a)
        p = params[i]
        inertia_mul(p, a, f)
        inertia_mul(p, v, Iv)
        crf_mul_add(v, Iv, f)
    for i in range(n - 1, -1, -1):
        tau[i] = dot6(body[i, SUB], body[i, FRC])
        parent = joint[i, 1]
        if parent >= 0:
            xforce_T_add(X[i, :3], X[i, 3], body[i, FRC], body[parent, FRC])


@njit(cache=True)
def rnea_kernel(joint, geom, params, gravity, X, body, q, qd, qdd, tau):
    """τ = RNEA(q, q̇, q̈) into ``tau``; X and body are Data scratch."""
    update_joints(joint, geom, q, X, body)
    rnea_passes(joint, params, gravity, X, body, qd, qdd, tau)
