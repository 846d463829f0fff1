"""Recursive Newton–Euler inverse dynamics (Featherstone 2008, Table 5.1; docs/cstar_slotine_li.md).

    v_i = X_i v_λ + S_i q̇_i                          v_0 = 0
    a_i = X_i a_λ + S_i q̈_i + v_i × S_i q̇_i          a_0 = −g   (gravity as base acceleration)
    f_i = I_i a_i + v_i ×* I_i v_i  (+ Σ children X_cᵀ f_c)
    τ_i = S_iᵀ f_i

τ = H(q) q̈ + C(q, q̇) q̇ + G(q); with q̇ = q̈ = 0 it is G(q), with q̈ = 0 it is C q̇ + G.
The passes are the shared ones of :mod:`rtctl.model.recursions` with q̇_r = q̇, q̈_r = q̈.
"""
from __future__ import annotations

from rtctl.compiled import kernel
from rtctl.model.recursions import CSTAR, backward_pass, forward_pass, link_forces, update_joints


@kernel
def rnea_passes(joint, params, gravity, X, body, qd, qdd, tau):
    """The passes of Table 5.1 over transforms already in X (see :func:`update_joints`);
    ``tau`` may be ``qdd`` (it is read before it is written)."""
    forward_pass(joint, gravity, X, body, qd, qd, qdd)  # u = v, w = a
    link_forces(CSTAR, params, body)  # with u = v either factorisation's term is I a + v ×* I v
    backward_pass(joint, X, body, tau)


@kernel
def rnea_kernel(joint, geom, params, gravity, X, body, q, qd, qdd, tau):
    """τ = RNEA(q, q̇, q̈) into ``tau``; X and body are Data scratch."""
    update_joints(joint, geom, q, X, body)
    rnea_passes(joint, params, gravity, X, body, qd, qdd, tau)
