"""Compiled spatial-algebra kernels: the products of :mod:`rtctl.model.spatial` on 3-vectors.

Each function writes into ``out`` and allocates nothing; each loads its inputs into locals
before storing, so ``out`` may alias an input. Transforms are kept as Featherstone's pair
``X = (E, r)`` (book §2.8, Table 2.8): ``E`` the 3×3 rotation from parent to child
coordinates, ``r`` the child origin in parent coordinates; inertias as the 10 parameters
``p = (m, h, J)`` with ``h = m c`` (Pinocchio's order). With ω, v the angular and linear parts:

* ``X m = [E ω; E (v − r × ω)]``                      (motion, parent → child)
* ``Xᵀ f = [Eᵀ n + r × Eᵀ f; Eᵀ f]``                  (force, child → parent)
* ``I m = [J ω + h × v; m v − h × ω]``
* ``v × m = [ω × m_ω; ω × m_v + v × m_ω]``,  ``v ×* f = [ω × n + v × f; ω × f]``
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rtctl.model.robot import REVOLUTE



@njit(cache=True, inline="always")
def joint_transform(jtype, axis, R_tree, p_tree, q, E, r):
    """ⁱX_λ(q) = X_J(q) X_T as (E, r): body placement R = R_tree Rot(axis, q) (revolute) or
    R_tree with origin p_tree + R_tree axis q (prismatic); E = Rᵀ (book Table 5.1: X_i = X_J X_T)."""
    x, y, z = axis[0], axis[1], axis[2]
    if jtype == REVOLUTE:
        c, s = np.cos(q), np.sin(q)
        t = 1.0 - c
        J00, J01, J02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
        J10, J11, J12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
        J20, J21, J22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
        for a in range(3):  # E[:, a] = (R_tree J)[a, :]
            R0, R1, R2 = R_tree[a, 0], R_tree[a, 1], R_tree[a, 2]
            E[0, a] = R0 * J00 + R1 * J10 + R2 * J20
            E[1, a] = R0 * J01 + R1 * J11 + R2 * J21
            E[2, a] = R0 * J02 + R1 * J12 + R2 * J22
            r[a] = p_tree[a]
    else:
        for a in range(3):
            for b in range(3):
                E[b, a] = R_tree[a, b]
            r[a] = p_tree[a] + (R_tree[a, 0] * x + R_tree[a, 1] * y + R_tree[a, 2] * z) * q


@njit(cache=True, inline="always")
def motion_subspace(jtype, axis, S):
    """S_i in body coordinates: [axis; 0] for a revolute joint, [0; axis] for a prismatic one."""
    for k in range(6):
        S[k] = 0.0
    off = 0 if jtype == REVOLUTE else 3
    for k in range(3):
        S[off + k] = axis[k]


@njit(cache=True, inline="always")
def xmotion(E, r, m, out):
    """out = X m."""
    w0, w1, w2, v0, v1, v2 = m[0], m[1], m[2], m[3], m[4], m[5]
    u0 = v0 - (r[1] * w2 - r[2] * w1)
    u1 = v1 - (r[2] * w0 - r[0] * w2)
    u2 = v2 - (r[0] * w1 - r[1] * w0)
    for a in range(3):
        out[a] = E[a, 0] * w0 + E[a, 1] * w1 + E[a, 2] * w2
        out[3 + a] = E[a, 0] * u0 + E[a, 1] * u1 + E[a, 2] * u2


@njit(cache=True, inline="always")
def xforce_T(E, r, f, out):
    """out = Xᵀ f (a child's force expressed in its parent's coordinates)."""
    n0, n1, n2, f0, f1, f2 = f[0], f[1], f[2], f[3], f[4], f[5]
    g0 = E[0, 0] * f0 + E[1, 0] * f1 + E[2, 0] * f2
    g1 = E[0, 1] * f0 + E[1, 1] * f1 + E[2, 1] * f2
    g2 = E[0, 2] * f0 + E[1, 2] * f1 + E[2, 2] * f2
    out[0] = E[0, 0] * n0 + E[1, 0] * n1 + E[2, 0] * n2 + r[1] * g2 - r[2] * g1
    out[1] = E[0, 1] * n0 + E[1, 1] * n1 + E[2, 1] * n2 + r[2] * g0 - r[0] * g2
    out[2] = E[0, 2] * n0 + E[1, 2] * n1 + E[2, 2] * n2 + r[0] * g1 - r[1] * g0
    out[3], out[4], out[5] = g0, g1, g2


@njit(cache=True, inline="always")
def xforce_T_add(E, r, f, out):
    """out += Xᵀ f."""
    n0, n1, n2, f0, f1, f2 = f[0], f[1], f[2], f[3], f[4], f[5]
    g0 = E[0, 0] * f0 + E[1, 0] * f1 + E[2, 0] * f2
    g1 = E[0, 1] * f0 + E[1, 1] * f1 + E[2, 1] * f2
    g2 = E[0, 2] * f0 + E[1, 2] * f1 + E[2, 2] * f2
    out[0] += E[0, 0] * n0 + E[1, 0] * n1 + E[2, 0] * n2 + r[1] * g2 - r[2] * g1
    out[1] += E[0, 1] * n0 + E[1, 1] * n1 + E[2, 1] * n2 + r[2] * g0 - r[0] * g2
    out[2] += E[0, 2] * n0 + E[1, 2] * n1 + E[2, 2] * n2 + r[0] * g1 - r[1] * g0
    out[3] += g0
    out[4] += g1
    out[5] += g2


@njit(cache=True, inline="always")
def crm_mul_add(v, m, scale, out):
    """out += scale · (v × m)."""
    w0, w1, w2, u0, u1, u2 = v[0], v[1], v[2], v[3], v[4], v[5]
    a0, a1, a2, b0, b1, b2 = m[0], m[1], m[2], m[3], m[4], m[5]
    out[0] += scale * (w1 * a2 - w2 * a1)
    out[1] += scale * (w2 * a0 - w0 * a2)
    out[2] += scale * (w0 * a1 - w1 * a0)
    out[3] += scale * (w1 * b2 - w2 * b1 + u1 * a2 - u2 * a1)
    out[4] += scale * (w2 * b0 - w0 * b2 + u2 * a0 - u0 * a2)
    out[5] += scale * (w0 * b1 - w1 * b0 + u0 * a1 - u1 * a0)


@njit(cache=True, inline="always")
def crf_mul_add(v, f, out):
    """out += v ×* f."""
    w0, w1, w2, u0, u1, u2 = v[0], v[1], v[2], v[3], v[4], v[5]
    n0, n1, n2, f0, f1, f2 = f[0], f[1], f[2], f[3], f[4], f[5]
    out[0] += w1 * n2 - w2 * n1 + u1 * f2 - u2 * f1
    out[1] += w2 * n0 - w0 * n2 + u2 * f0 - u0 * f2
    out[2] += w0 * n1 - w1 * n0 + u0 * f1 - u1 * f0
    out[3] += w1 * f2 - w2 * f1
    out[4] += w2 * f0 - w0 * f2
    out[5] += w0 * f1 - w1 * f0


@njit(cache=True, inline="always")
def inertia_mul(p, m, out):
    """out = I(p) m."""
    w0, w1, w2, v0, v1, v2 = m[0], m[1], m[2], m[3], m[4], m[5]
    mass, h0, h1, h2 = p[0], p[1], p[2], p[3]
    out[0] = p[4] * w0 + p[5] * w1 + p[7] * w2 + h1 * v2 - h2 * v1
    out[1] = p[5] * w0 + p[6] * w1 + p[8] * w2 + h2 * v0 - h0 * v2
    out[2] = p[7] * w0 + p[8] * w1 + p[9] * w2 + h0 * v1 - h1 * v0
    out[3] = mass * v0 - (h1 * w2 - h2 * w1)
    out[4] = mass * v1 - (h2 * w0 - h0 * w2)
    out[5] = mass * v2 - (h0 * w1 - h1 * w0)


@njit(cache=True, inline="always")
def inertia_to_parent_add(E, r, p, out):
    """out += parameters of Xᵀ I(p) X: the inertia moved into the parent frame (book Table 2.8):
    m' = m, h' = Eᵀh + m r, J' = EᵀJE + m(|r|² 1 − r rᵀ) + 2 (r·g) 1 − g rᵀ − r gᵀ, g = Eᵀh."""
    m = p[0]
    g0 = E[0, 0] * p[1] + E[1, 0] * p[2] + E[2, 0] * p[3]
    g1 = E[0, 1] * p[1] + E[1, 1] * p[2] + E[2, 1] * p[3]
    g2 = E[0, 2] * p[1] + E[1, 2] * p[2] + E[2, 2] * p[3]
    r0, r1, r2 = r[0], r[1], r[2]
    out[0] += m
    out[1] += g0 + m * r0
    out[2] += g1 + m * r1
    out[3] += g2 + m * r2
    diag = m * (r0 * r0 + r1 * r1 + r2 * r2) + 2.0 * (r0 * g0 + r1 * g1 + r2 * g2)
    J00, J01, J11, J02, J12, J22 = p[4], p[5], p[6], p[7], p[8], p[9]
    for b in range(3):
        M0 = J00 * E[0, b] + J01 * E[1, b] + J02 * E[2, b]  # (J E)[:, b]
        M1 = J01 * E[0, b] + J11 * E[1, b] + J12 * E[2, b]
        M2 = J02 * E[0, b] + J12 * E[1, b] + J22 * E[2, b]
        gb = E[0, b] * p[1] + E[1, b] * p[2] + E[2, b] * p[3]
        for a in range(b + 1):
            ga = E[0, a] * p[1] + E[1, a] * p[2] + E[2, a] * p[3]
            s = E[0, a] * M0 + E[1, a] * M1 + E[2, a] * M2 - m * r[a] * r[b] - ga * r[b] - r[a] * gb
            if a == b:
                s += diag
            out[4 + a + b * (b + 1) // 2] += s  # (0,0) (0,1) (1,1) (0,2) (1,2) (2,2): Pinocchio's order


@njit(cache=True, inline="always")
def zero_vector(x):
    """x = 0 (a plain loop: numba compiles slice assignment slowly, ~5 s a signature)."""
    for i in range(x.shape[0]):
        x[i] = 0.0


@njit(cache=True, inline="always")
def zero_matrix(M):
    """M = 0 for a 2-D array."""
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            M[i, j] = 0.0


@njit(cache=True, inline="always")
def dot6(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
