"""Composite-rigid-body algorithm: the joint-space mass matrix H(q) (Featherstone 2008, Table 6.2).

    I^c_i = I_i + Σ_children X_cᵀ I^c_c X_c            (composite inertias, as 10 parameters)
    F = I^c_i S_i,  H_ii = S_iᵀ F;  for j = λ(i), λ(λ(i)), …:  F = X_jᵀ F (j's child side),
    H_ij = H_ji = S_jᵀ F

Both loops are the shared :func:`~rtctl.model.recursions.composite_inertias` and
:func:`~rtctl.model.recursions.ancestor_products`.
"""
from __future__ import annotations

from rtctl.compiled import kernel
from rtctl.model.data import FRC, SUB
from rtctl.model.recursions import SYMMETRIC, ancestor_products, composite_inertias, update_joints
from rtctl.model.spatial_kernels import inertia_mul, zero_matrix


@kernel
def crba_passes(joint, params, X, body, Ic, H):
    """H(q) into ``H`` over transforms already in X; Ic and body[:, FRC] are scratch."""
    zero_matrix(H)
    composite_inertias(joint, params, X, Ic)
    for i in range(joint.shape[0]):
        inertia_mul(Ic, i, body, i, SUB, FRC)
    ancestor_products(joint, X, body, SUB, -1, True, SYMMETRIC, H)


@kernel
def crba_kernel(joint, geom, params, X, body, Ic, q, H):
    """H(q) into ``H``; X, body and Ic are Data scratch."""
    update_joints(joint, geom, q, X, body)
    crba_passes(joint, params, X, body, Ic, H)
