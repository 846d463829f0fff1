"""Compiled spatial-algebra kernels: the products of :mod:`rtctl.model.spatial` on 3-vectors.

Operands are addressed, not sliced: a 6-vector is ``V[k, s]`` of an (n, slots, 6) array (the
workspace's ``body``: link k, slot s), a transform ``X[i]`` of an (n, 4, 3) array, inertial
parameters ``P[k]`` of an (n, 10) array. Every function writes its result into ``V`` (or
``P``) and allocates nothing; each loads its inputs into locals before storing, so the result
may overwrite an input. Transforms are kept as Featherstone's pair ``X = (E, r)`` (book §2.8,
Table 2.8), rows 0–2 of X[i] holding ``E``, the 3×3 rotation from parent to child coordinates,
row 3 ``r``, the child origin in parent coordinates; inertias as the 10 parameters
``p = (m, h, J)`` with ``h = m c`` (Pinocchio's order). With ω, v the angular and linear parts:

* ``X m = [E ω; E (v − r × ω)]``                      (motion, parent → child)
* ``Xᵀ f = [Eᵀ n + r × Eᵀ f; Eᵀ f]``                  (force, child → parent)
* ``I m = [J ω + h × v; m v − h × ω]``
* ``v × m = [ω × m_ω; ω × m_v + v × m_ω]``,  ``v ×* f = [ω × n + v × f; ω × f]``

They are the leaves of the passes in :mod:`rtctl.model.recursions`: each is compiled once and
LLVM inlines it into every pass that calls it. Two things would cost more: numba's own
inlining (``inline="always"``) re-types the whole body at every call site (several times the
compile time, for the same machine code), and an array view handed to a compiled function is
reference-counted (an atomic add and subtract per call that survive LLVM's inlining: the
recursions ran 2–3× slower that way) — hence indices instead of views.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import leaf
from rtctl.model.robot import REVOLUTE


@leaf
def xmotion(X, i, V, src, s, dst, d):
    """V[dst, d] = X_i V[src, s]."""
    w0, w1, w2, v0, v1, v2 = V[src, s, 0], V[src, s, 1], V[src, s, 2], V[src, s, 3], V[src, s, 4], V[src, s, 5]
    r0, r1, r2 = X[i, 3, 0], X[i, 3, 1], X[i, 3, 2]
    u0 = v0 - (r1 * w2 - r2 * w1)
    u1 = v1 - (r2 * w0 - r0 * w2)
    u2 = v2 - (r0 * w1 - r1 * w0)
    for a in range(3):
        V[dst, d, a] = X[i, a, 0] * w0 + X[i, a, 1] * w1 + X[i, a, 2] * w2
        V[dst, d, 3 + a] = X[i, a, 0] * u0 + X[i, a, 1] * u1 + X[i, a, 2] * u2


@leaf
def xforce_T(X, i, V, src, s, dst, d, add):
    """V[dst, d] = X_iᵀ V[src, s], or += when ``add`` (a child's force in its parent's coordinates)."""
    n0, n1, n2, f0, f1, f2 = V[src, s, 0], V[src, s, 1], V[src, s, 2], V[src, s, 3], V[src, s, 4], V[src, s, 5]
    r0, r1, r2 = X[i, 3, 0], X[i, 3, 1], X[i, 3, 2]
    g0 = X[i, 0, 0] * f0 + X[i, 1, 0] * f1 + X[i, 2, 0] * f2
    g1 = X[i, 0, 1] * f0 + X[i, 1, 1] * f1 + X[i, 2, 1] * f2
    g2 = X[i, 0, 2] * f0 + X[i, 1, 2] * f1 + X[i, 2, 2] * f2
    m0 = X[i, 0, 0] * n0 + X[i, 1, 0] * n1 + X[i, 2, 0] * n2 + r1 * g2 - r2 * g1
    m1 = X[i, 0, 1] * n0 + X[i, 1, 1] * n1 + X[i, 2, 1] * n2 + r2 * g0 - r0 * g2
    m2 = X[i, 0, 2] * n0 + X[i, 1, 2] * n1 + X[i, 2, 2] * n2 + r0 * g1 - r1 * g0
    if add:
        m0, m1, m2 = m0 + V[dst, d, 0], m1 + V[dst, d, 1], m2 + V[dst, d, 2]
        g0, g1, g2 = g0 + V[dst, d, 3], g1 + V[dst, d, 4], g2 + V[dst, d, 5]
    V[dst, d, 0], V[dst, d, 1], V[dst, d, 2], V[dst, d, 3], V[dst, d, 4], V[dst, d, 5] = m0, m1, m2, g0, g1, g2


@leaf
def crm_mul(V, k, a, b, scale, d, add):
    """V[k, d] = scale · (V[k, a] × V[k, b]), or += when ``add`` (motion cross product)."""
    w0, w1, w2, u0, u1, u2 = V[k, a, 0], V[k, a, 1], V[k, a, 2], V[k, a, 3], V[k, a, 4], V[k, a, 5]
    a0, a1, a2, b0, b1, b2 = V[k, b, 0], V[k, b, 1], V[k, b, 2], V[k, b, 3], V[k, b, 4], V[k, b, 5]
    c0 = scale * (w1 * a2 - w2 * a1)
    c1 = scale * (w2 * a0 - w0 * a2)
    c2 = scale * (w0 * a1 - w1 * a0)
    c3 = scale * (w1 * b2 - w2 * b1 + u1 * a2 - u2 * a1)
    c4 = scale * (w2 * b0 - w0 * b2 + u2 * a0 - u0 * a2)
    c5 = scale * (w0 * b1 - w1 * b0 + u0 * a1 - u1 * a0)
    if add:
        c0, c1, c2 = c0 + V[k, d, 0], c1 + V[k, d, 1], c2 + V[k, d, 2]
        c3, c4, c5 = c3 + V[k, d, 3], c4 + V[k, d, 4], c5 + V[k, d, 5]
    V[k, d, 0], V[k, d, 1], V[k, d, 2], V[k, d, 3], V[k, d, 4], V[k, d, 5] = c0, c1, c2, c3, c4, c5


@leaf
def crf_mul_add(V, k, a, b, d):
    """V[k, d] += V[k, a] ×* V[k, b] (force cross product: a motion, b a force)."""
    w0, w1, w2, u0, u1, u2 = V[k, a, 0], V[k, a, 1], V[k, a, 2], V[k, a, 3], V[k, a, 4], V[k, a, 5]
    n0, n1, n2, f0, f1, f2 = V[k, b, 0], V[k, b, 1], V[k, b, 2], V[k, b, 3], V[k, b, 4], V[k, b, 5]
    V[k, d, 0] += w1 * n2 - w2 * n1 + u1 * f2 - u2 * f1
    V[k, d, 1] += w2 * n0 - w0 * n2 + u2 * f0 - u0 * f2
    V[k, d, 2] += w0 * n1 - w1 * n0 + u0 * f1 - u1 * f0
    V[k, d, 3] += w1 * f2 - w2 * f1
    V[k, d, 4] += w2 * f0 - w0 * f2
    V[k, d, 5] += w0 * f1 - w1 * f0


@leaf
def inertia_mul(P, p, V, k, a, d):
    """V[k, d] = I(P[p]) V[k, a]."""
    w0, w1, w2, v0, v1, v2 = V[k, a, 0], V[k, a, 1], V[k, a, 2], V[k, a, 3], V[k, a, 4], V[k, a, 5]
    mass, h0, h1, h2 = P[p, 0], P[p, 1], P[p, 2], P[p, 3]
    J00, J01, J11, J02, J12, J22 = P[p, 4], P[p, 5], P[p, 6], P[p, 7], P[p, 8], P[p, 9]
    V[k, d, 0] = J00 * w0 + J01 * w1 + J02 * w2 + h1 * v2 - h2 * v1
    V[k, d, 1] = J01 * w0 + J11 * w1 + J12 * w2 + h2 * v0 - h0 * v2
    V[k, d, 2] = J02 * w0 + J12 * w1 + J22 * w2 + h0 * v1 - h1 * v0
    V[k, d, 3] = mass * v0 - (h1 * w2 - h2 * w1)
    V[k, d, 4] = mass * v1 - (h2 * w0 - h0 * w2)
    V[k, d, 5] = mass * v2 - (h0 * w1 - h1 * w0)


@leaf
def inertia_to_parent_add(X, i, P, src, dst):
    """P[dst] += parameters of X_iᵀ I(P[src]) X_i: the inertia moved into the parent frame (book
    Table 2.8): m' = m, h' = Eᵀh + m r, J' = EᵀJE + m(|r|² 1 − r rᵀ) + 2 (r·g) 1 − g rᵀ − r gᵀ, g = Eᵀh."""
    m, h0, h1, h2 = P[src, 0], P[src, 1], P[src, 2], P[src, 3]
    J00, J01, J11, J02, J12, J22 = P[src, 4], P[src, 5], P[src, 6], P[src, 7], P[src, 8], P[src, 9]
    r0, r1, r2 = X[i, 3, 0], X[i, 3, 1], X[i, 3, 2]
    g0 = X[i, 0, 0] * h0 + X[i, 1, 0] * h1 + X[i, 2, 0] * h2
    g1 = X[i, 0, 1] * h0 + X[i, 1, 1] * h1 + X[i, 2, 1] * h2
    g2 = X[i, 0, 2] * h0 + X[i, 1, 2] * h1 + X[i, 2, 2] * h2
    P[dst, 0] += m
    P[dst, 1] += g0 + m * r0
    P[dst, 2] += g1 + m * r1
    P[dst, 3] += g2 + m * r2
    diag = m * (r0 * r0 + r1 * r1 + r2 * r2) + 2.0 * (r0 * g0 + r1 * g1 + r2 * g2)
    for b in range(3):
        Eb0, Eb1, Eb2 = X[i, 0, b], X[i, 1, b], X[i, 2, b]
        M0 = J00 * Eb0 + J01 * Eb1 + J02 * Eb2  # (J E)[:, b]
        M1 = J01 * Eb0 + J11 * Eb1 + J12 * Eb2
        M2 = J02 * Eb0 + J12 * Eb1 + J22 * Eb2
        gb = Eb0 * h0 + Eb1 * h1 + Eb2 * h2
        rb = X[i, 3, b]
        for a in range(b + 1):
            ga = X[i, 0, a] * h0 + X[i, 1, a] * h1 + X[i, 2, a] * h2
            ra = X[i, 3, a]
            s = X[i, 0, a] * M0 + X[i, 1, a] * M1 + X[i, 2, a] * M2 - m * ra * rb - ga * rb - ra * gb
            if a == b:
                s += diag
            P[dst, 4 + a + b * (b + 1) // 2] += s  # (0,0) (0,1) (1,1) (0,2) (1,2) (2,2): Pinocchio's order


@leaf
def dot6(V, j, a, k, b):
    """V[j, a] · V[k, b]."""
    return (V[j, a, 0] * V[k, b, 0] + V[j, a, 1] * V[k, b, 1] + V[j, a, 2] * V[k, b, 2]
            + V[j, a, 3] * V[k, b, 3] + V[j, a, 4] * V[k, b, 4] + V[j, a, 5] * V[k, b, 5])


@leaf
def zero_matrix(M):
    """M = 0 for a 2-D array (a plain loop: numba compiles slice assignment slowly, ~5 s a signature)."""
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            M[i, j] = 0.0
