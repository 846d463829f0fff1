"""Composite-rigid-body algorithm: the joint-space mass matrix H(q) (Featherstone 2008, Table 6.2).

    I^c_i = I_i + Σ_children X_cᵀ I^c_c X_c            (composite inertias, as 10 parameters)
    F = I^c_i S_i,  H_ii = S_iᵀ F;  for j = λ(i), λ(λ(i)), …:  F = X_jᵀ F (j's child side),
    H_ij = H_ji = S_jᵀ F

Composite inertias stay in the 10-parameter form: Xᵀ I X of a rigid-body inertia is again one
(:func:`~rtctl.model.spatial_kernels.inertia_to_parent_add`).
"""
from __future__ import annotations

from numba import njit

from rtctl.model.data import SUB, TMP, update_joints
from rtctl.model.spatial_kernels import dot6, inertia_mul, inertia_to_parent_add, xforce_T, zero_matrix


@njit(cache=True)
def crba_passes(joint, params, X, body, Ic, H):
    """H(q) into ``H`` over transforms already in X; Ic and body[:, TMP] are scratch."""
    n = joint.shape[0]
    zero_matrix(H)
    for i in range(n):
        for k in range(10):
            Ic[i, k] = params[i, k]
    for i in range(n - 1, -1, -1):
        parent = joint[i, 1]
        if parent >= 0:
            inertia_to_parent_add(X[i, :3], X[i, 3], Ic[i], Ic[parent])
    for i in range(n):
        F = body[i, TMP]
        inertia_mul(Ic[i], body[i, SUB], F)
        H[i, i] = dot6(body[i, SUB], F)
        j = i
        while joint[j, 1] >= 0:
            xforce_T(X[j, :3], X[j, 3], F, F)
            j = joint[j, 1]
            H[i, j] = dot6(body[j, SUB], F)
            H[j, i] = H[i, j]


@njit(cache=True)
def crba_kernel(joint, geom, params, X, body, Ic, q, H):
    """H(q) into ``H``; X, body and Ic are Data scratch."""
    update_joints(joint, geom, q, X, body)
    crba_passes(joint, params, X, body, Ic, H)
