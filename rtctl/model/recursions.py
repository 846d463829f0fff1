"""The recursions every dynamics algorithm and controller here is assembled from, each written
once (Featherstone 2008, Tables 5.1 and 6.2; the reference-velocity forms are the adaptive
law's, Huo, Gao & Cheng eqs. (34)-(37) = (21)-(24)):

    joints     ⁱX_λ(q_i), S_i                                                  (jcalc)
    forward    v_i = X_i v_λ + S_i q̇_i,   u_i = X_i u_λ + S_i q̇_r,i,
               w_i = X_i w_λ + S_i q̈_r,i + v_i × S_i q̇_r,i,    v_0 = u_0 = 0, w_0 = −g
    links      C*:          f_i = I_i w_i + v_i ×* I_i u_i                      (36)
               Christoffel: f_i = I_i w_i + ½ [v_i ×* I_i u_i + u_i ×* I_i v_i + I_i (u_i × v_i)]   (23)
    backward   τ_i = S_iᵀ f_i,   f_λ += X_iᵀ f_i                                (37)
    composite  I^c_i = I_i + Σ_children X_cᵀ I^c_c X_c                          (Table 6.2)
    ancestors  a force F at link j carried to the root, F ← X_iᵀ F, with S-products
               taken at every link on the way (CRBA's column walk, and C's and Ḣ's)

With q̇_r = q̇ and q̈_r = q̈ (u = v, w = a) either link term is RNEA's I a + v ×* I v, so inverse
dynamics, G, the bias of forward dynamics and the adaptive controller's torque all run the
same forward, link and backward passes (:mod:`rtctl.model.rnea`,
:mod:`rtctl.control.slotine_li_kernels`).

Every pass loops over the whole chain, so a caller pays one call per pass, not per link, and
each is compiled once for the argument types it sees (C-contiguous float64 arrays; numba
compiles a separate copy for each distinct constant a caller passes as ``kind`` or to
:func:`ancestor_products`, with the branches on it removed) and shared by every kernel that
calls it. The per-link arithmetic is the leaves of :mod:`rtctl.model.spatial_kernels`, which
LLVM inlines into the passes; like them, the passes index ``body`` rather than slicing it. Slots of ``body`` as in
:mod:`rtctl.model.data`; who writes which is said per pass.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel, leaf
from rtctl.model.data import ACC, FRC, REF, SUB, TMP, VEL
from rtctl.model.robot import REVOLUTE
from rtctl.model.spatial_kernels import crf_mul_add, crm_mul, dot6, inertia_mul, inertia_to_parent_add, xforce_T, \
    xmotion

CHRISTOFFEL, CSTAR = 0, 1  # the two factorisations of C; the adaptive law's "classic" and "cstar"
COLUMN, ROW, SYMMETRIC = 0, 1, 2  # where ancestor_products writes: out[i, j], out[j, i], both


@kernel
def update_joints(joint, geom, q, X, body):
    """X[i] = ⁱX_λ(q_i) = X_J(q_i) X_T and body[i, SUB] = S_i for every joint (book Table 5.1,
    jcalc), from geom[i] = (axis, R_tree (3 rows), p_tree): body placement R = R_tree Rot(axis, q)
    (revolute) or R_tree with origin p_tree + R_tree axis q (prismatic); E = Rᵀ;
    S = [axis; 0] (revolute) or [0; axis] (prismatic)."""
    for i in range(joint.shape[0]):
        x, y, z = geom[i, 0, 0], geom[i, 0, 1], geom[i, 0, 2]
        T00, T01, T02 = geom[i, 1, 0], geom[i, 1, 1], geom[i, 1, 2]
        T10, T11, T12 = geom[i, 2, 0], geom[i, 2, 1], geom[i, 2, 2]
        T20, T21, T22 = geom[i, 3, 0], geom[i, 3, 1], geom[i, 3, 2]
        p0, p1, p2 = geom[i, 4, 0], geom[i, 4, 1], geom[i, 4, 2]
        for k in range(6):
            body[i, SUB, k] = 0.0
        if joint[i, 0] == REVOLUTE:
            body[i, SUB, 0], body[i, SUB, 1], body[i, SUB, 2] = x, y, z
            c, s = np.cos(q[i]), np.sin(q[i])
            t = 1.0 - c
            J00, J01, J02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
            J10, J11, J12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
            J20, J21, J22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
            # E = (R_tree J)ᵀ
            X[i, 0, 0] = T00 * J00 + T01 * J10 + T02 * J20
            X[i, 1, 0] = T00 * J01 + T01 * J11 + T02 * J21
            X[i, 2, 0] = T00 * J02 + T01 * J12 + T02 * J22
            X[i, 0, 1] = T10 * J00 + T11 * J10 + T12 * J20
            X[i, 1, 1] = T10 * J01 + T11 * J11 + T12 * J21
            X[i, 2, 1] = T10 * J02 + T11 * J12 + T12 * J22
            X[i, 0, 2] = T20 * J00 + T21 * J10 + T22 * J20
            X[i, 1, 2] = T20 * J01 + T21 * J11 + T22 * J21
            X[i, 2, 2] = T20 * J02 + T21 * J12 + T22 * J22
            X[i, 3, 0], X[i, 3, 1], X[i, 3, 2] = p0, p1, p2
        else:
            body[i, SUB, 3], body[i, SUB, 4], body[i, SUB, 5] = x, y, z
            X[i, 0, 0], X[i, 0, 1], X[i, 0, 2] = T00, T10, T20
            X[i, 1, 0], X[i, 1, 1], X[i, 1, 2] = T01, T11, T21
            X[i, 2, 0], X[i, 2, 1], X[i, 2, 2] = T02, T12, T22
            X[i, 3, 0] = p0 + (T00 * x + T01 * y + T02 * z) * q[i]
            X[i, 3, 1] = p1 + (T10 * x + T11 * y + T12 * z) * q[i]
            X[i, 3, 2] = p2 + (T20 * x + T21 * y + T22 * z) * q[i]


@kernel
def forward_pass(joint, gravity, X, body, qd, qdr, qddr):
    """v, u, w of every link into body[:, VEL], body[:, REF], body[:, ACC] (eqs. 34-35; book
    eq. 5.7 and Table 5.1 with q̇_r = q̇); X and S must be up to date (:func:`update_joints`).
    u is computed even when q̇_r = q̇: a flag to skip it would cost more in the loop than it saves."""
    for i in range(joint.shape[0]):
        parent = joint[i, 1]
        if parent < 0:  # v_0 = u_0 = 0, w_0 = −g, seen from link 1
            for k in range(3):
                body[i, VEL, k] = body[i, VEL, 3 + k] = 0.0
                body[i, REF, k] = body[i, REF, 3 + k] = 0.0
                body[i, ACC, k] = 0.0
                body[i, ACC, 3 + k] = -(X[i, k, 0] * gravity[0] + X[i, k, 1] * gravity[1] + X[i, k, 2] * gravity[2])
        else:
            xmotion(X, i, body, parent, VEL, i, VEL)
            xmotion(X, i, body, parent, REF, i, REF)
            xmotion(X, i, body, parent, ACC, i, ACC)
        for k in range(6):
            body[i, VEL, k] += body[i, SUB, k] * qd[i]
            body[i, REF, k] += body[i, SUB, k] * qdr[i]
            body[i, ACC, k] += body[i, SUB, k] * qddr[i]
        crm_mul(body, i, VEL, SUB, qdr[i], ACC, True)


@leaf
def link_forces(kind, params, body):
    """Every link's own force f_i into body[:, FRC] from its v, u, w: (36) for CSTAR, (23) for
    CHRISTOFFEL. Scratch body[:, TMP .. TMP+3]; CHRISTOFFEL leaves u × v in body[:, TMP+3]."""
    IU, IV, BRACKET, UXV = TMP, TMP + 1, TMP + 2, TMP + 3
    for i in range(body.shape[0]):
        inertia_mul(params, i, body, i, ACC, FRC)
        inertia_mul(params, i, body, i, REF, IU)
        if kind == CSTAR:
            crf_mul_add(body, i, VEL, IU, FRC)
        else:
            inertia_mul(params, i, body, i, VEL, IV)
            for k in range(6):
                body[i, BRACKET, k] = 0.0
            crf_mul_add(body, i, VEL, IU, BRACKET)
            crf_mul_add(body, i, REF, IV, BRACKET)
            crm_mul(body, i, REF, VEL, 1.0, UXV, False)
            inertia_mul(params, i, body, i, UXV, IU)
            for k in range(6):
                body[i, FRC, k] += 0.5 * (body[i, BRACKET, k] + body[i, IU, k])


@kernel
def backward_pass(joint, X, body, tau):
    """τ_i = S_iᵀ f_i into ``tau``, adding every f_i into its parent's on the way (eq. 37,
    Table 5.1); body[:, FRC] ends up holding the subtree forces."""
    for i in range(joint.shape[0] - 1, -1, -1):
        tau[i] = dot6(body, i, SUB, i, FRC)
        parent = joint[i, 1]
        if parent >= 0:
            xforce_T(X, i, body, i, FRC, parent, FRC, True)


@kernel
def composite_inertias(joint, params, X, Ic):
    """I^c_i = I_i + Σ_children X_cᵀ I^c_c X_c into ``Ic`` (n, 10), as inertial parameters:
    Xᵀ I X of a rigid-body inertia is again one (:func:`inertia_to_parent_add`)."""
    n = joint.shape[0]
    for i in range(n):
        for k in range(10):
            Ic[i, k] = params[i, k]
    for i in range(n - 1, -1, -1):
        parent = joint[i, 1]
        if parent >= 0:
            inertia_to_parent_add(X, i, Ic, i, parent)


@kernel
def ancestor_products(joint, X, body, slot_f, slot_g, include_j, mode, out):
    """For every link j, carry the forces F_j = body[j, FRC] and G_j = body[j, TMP] (both
    overwritten) to the root; at every link i on the way (j itself with ``include_j``) take
    x = body[i, slot_f]·F + body[i, slot_g]·G (no G when slot_g < 0) and write it to out[i, j]
    (COLUMN), out[j, i] (ROW) or both (SYMMETRIC). Callers pass constants, so numba compiles
    one copy per pattern with these branches gone."""
    for j in range(joint.shape[0]):
        i = j
        while True:
            if include_j or i != j:
                x = dot6(body, i, slot_f, j, FRC)
                if slot_g >= 0:
                    x += dot6(body, i, slot_g, j, TMP)
                if mode != ROW:
                    out[i, j] = x
                if mode != COLUMN:
                    out[j, i] = x
            parent = joint[i, 1]
            if parent < 0:
                break
            xforce_T(X, i, body, j, FRC, j, FRC, False)
            if slot_g >= 0:
                xforce_T(X, i, body, j, TMP, j, TMP, False)
            i = parent
