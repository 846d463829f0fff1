"""The Coriolis matrix in both factorisations, and Ḣ, from composite body terms (docs/cstar_slotine_li.md).

With body Jacobians J_k (columns S_j, j supporting k) and J̇_k (columns Ṡ_j = v_j × S_j),
any body-level factorisation v_k ×* I_k v_k = B_k v_k gives a joint-space one,
C = Σ_k J_kᵀ (I_k J̇_k + B_k J_k), i.e.

    c_ij = S_iᵀ Σ_{k ⪰ i, j} [ I_k (v_j × S_j) + B_k S_j ]                                 (9)

* C* (the paper's, eq. 9): B_k = crf(v_k) I_k;
* Christoffel (eq. 2; Niemeyer–Slotine, Pinocchio): B_k = ½ [crf(v) I + icrf(I v) − I crm(v)].

Summing over the subtree once (composites Î_i = Σ X*I_k X, B̂_i likewise, in link coordinates)
leaves O(n²) work: for j, c_ij = S_iᵀ (Î_j Ṡ_j + B̂_j S_j) for the ancestors i ⪯ j, and for the
descendants i ≻ j, c_ij = (Î_i S_i)ᵀ Ṡ_j + (B̂_iᵀ S_i)ᵀ S_j with both forces carried up to j.

Ḣ uses the same composites with D_k = dI_k/dt = crf(v_k) I_k − I_k crm(v_k):
ḣ_ij = Ṡ_iᵀ Î_j S_j + S_iᵀ (D̂_j S_j + Î_j Ṡ_j) for i ⪯ j — independent of C, so the test
Ḣ = C + Cᵀ (Proposition 2) compares two derivations.
"""
from __future__ import annotations

from numba import njit

from rtctl.model.data import ACC, FRC, SUB, TMP, VEL, update_joints, update_velocities
from rtctl.model.spatial_kernels import crm_mul_add, dot6, inertia_mul, xforce_T, zero_matrix, zero_vector

CHRISTOFFEL, CSTAR, INERTIA_RATE = 0, 1, 2  # which body term B_k the composites carry


@njit(cache=True)
def inertia6(p, out):
    """The 6×6 spatial inertia I(p) (eq. 17 of docs/cstar_slotine_li.md)."""
    zero_matrix(out)
    out[0, 0], out[0, 1], out[1, 1], out[0, 2], out[1, 2], out[2, 2] = p[4], p[5], p[6], p[7], p[8], p[9]
    out[1, 0], out[2, 0], out[2, 1] = p[5], p[7], p[8]
    h0, h1, h2 = p[1], p[2], p[3]
    out[0, 4], out[0, 5], out[1, 3], out[1, 5], out[2, 3], out[2, 4] = -h2, h1, h2, -h0, -h1, h0  # h×
    for a in range(3):
        for b in range(3):
            out[3 + b, a] = out[a, 3 + b]
        out[3 + a, 3 + a] = p[0]


@njit(cache=True)
def _skew_into(x, out, r0, c0, scale):
    out[r0, c0 + 1] = -scale * x[2]
    out[r0, c0 + 2] = scale * x[1]
    out[r0 + 1, c0] = scale * x[2]
    out[r0 + 1, c0 + 2] = -scale * x[0]
    out[r0 + 2, c0] = -scale * x[1]
    out[r0 + 2, c0 + 1] = scale * x[0]


@njit(cache=True)
def body_term(p, v, kind, I, B, W, f):
    """I = I(p) and B = the body term of ``kind``; W (2, 6, 6) and f (6,) are scratch."""
    inertia6(p, I)
    zero_matrix(W[0])  # crm(v)
    _skew_into(v[:3], W[0], 0, 0, 1.0)
    _skew_into(v[3:], W[0], 3, 0, 1.0)
    _skew_into(v[:3], W[0], 3, 3, 1.0)
    half = 0.5 if kind == CHRISTOFFEL else 1.0
    for a in range(6):
        for b in range(6):
            s = 0.0
            for k in range(6):
                s -= W[0, k, a] * I[k, b]  # crf(v) I = −crm(v)ᵀ I
            if kind != CSTAR:
                for k in range(6):
                    s -= I[a, k] * W[0, k, b]  # − I crm(v)
            B[a, b] = half * s
    if kind == CHRISTOFFEL:  # + ½ icrf(I v)
        inertia_mul(p, v, f)
        zero_matrix(W[1])
        _skew_into(f[:3], W[1], 0, 0, -0.5)
        _skew_into(f[3:], W[1], 0, 3, -0.5)
        _skew_into(f[3:], W[1], 3, 0, -0.5)
        for a in range(6):
            for b in range(6):
                B[a, b] += W[1, a, b]


@njit(cache=True)
def congruence_add(Xi, M, W, out):
    """out += Xᵀ M X for X = (E, r) stored as one (4, 3) row of Data.X; W (2, 6, 6) scratch."""
    E, r = Xi[:3], Xi[3]
    X = W[0]
    zero_matrix(X)
    for a in range(3):
        for b in range(3):
            X[a, b] = E[a, b]
            X[3 + a, 3 + b] = E[a, b]
            # (−E r×)[a, b]
            X[3 + a, b] = -(E[a, (b + 1) % 3] * r[(b + 2) % 3] - E[a, (b + 2) % 3] * r[(b + 1) % 3])
    for a in range(6):
        for b in range(6):
            s = 0.0
            for k in range(6):
                s += M[a, k] * X[k, b]
            W[1, a, b] = s
    for a in range(6):
        for b in range(6):
            s = 0.0
            for k in range(6):
                s += X[k, a] * W[1, k, b]
            out[a, b] += s


@njit(cache=True)
def composites(joint, geom, params, X, body, I6, B6, W, q, qd, kind):
    """Joint and velocity passes, Ṡ_i = v_i × S_i into body[:, ACC], and the subtree sums
    Î_i into I6 and B̂_i (of ``kind``) into B6."""
    n = joint.shape[0]
    update_joints(joint, geom, q, X, body)
    update_velocities(joint, X, body, qd)
    for k in range(n):
        zero_vector(body[k, ACC])
        crm_mul_add(body[k, VEL], body[k, SUB], 1.0, body[k, ACC])
        body_term(params[k], body[k, VEL], kind, I6[k], B6[k], W, body[k, TMP])
    for i in range(n - 1, -1, -1):
        parent = joint[i, 1]
        if parent >= 0:
            congruence_add(X[i], I6[i], W, I6[parent])
            congruence_add(X[i], B6[i], W, B6[parent])


@njit(cache=True)
def _mat_vec(M, x, out, transpose):
    for a in range(6):
        s = 0.0
        for k in range(6):
            s += (M[k, a] if transpose else M[a, k]) * x[k]
        out[a] = s


@njit(cache=True)
def coriolis_kernel(joint, geom, params, X, body, I6, B6, W, q, qd, kind, C):
    """C(q, q̇) of ``kind`` (CHRISTOFFEL or CSTAR) into ``C``; the rest is Data scratch."""
    n = joint.shape[0]
    composites(joint, geom, params, X, body, I6, B6, W, q, qd, kind)
    zero_matrix(C)
    for j in range(n):  # rows i ⪯ j: S_iᵀ (Î_j Ṡ_j + B̂_j S_j)
        F, G = body[j, FRC], body[j, TMP]
        _mat_vec(I6[j], body[j, ACC], F, False)
        _mat_vec(B6[j], body[j, SUB], G, False)
        for k in range(6):
            F[k] += G[k]
        C[j, j] = dot6(body[j, SUB], F)
        i = j
        while joint[i, 1] >= 0:
            xforce_T(X[i, :3], X[i, 3], F, F)
            i = joint[i, 1]
            C[i, j] = dot6(body[i, SUB], F)
    for i in range(n):  # columns j ≺ i: (Î_i S_i)ᵀ Ṡ_j + (B̂_iᵀ S_i)ᵀ S_j
        a, b = body[i, FRC], body[i, TMP]
        _mat_vec(I6[i], body[i, SUB], a, False)
        _mat_vec(B6[i], body[i, SUB], b, True)
        j = i
        while joint[j, 1] >= 0:
            xforce_T(X[j, :3], X[j, 3], a, a)
            xforce_T(X[j, :3], X[j, 3], b, b)
            j = joint[j, 1]
            C[i, j] = dot6(a, body[j, ACC]) + dot6(b, body[j, SUB])


@njit(cache=True)
def mass_matrix_dot_kernel(joint, geom, params, X, body, I6, B6, W, q, qd, Hd):
    """Ḣ(q, q̇) into ``Hd``: ḣ_ij = Ṡ_iᵀ Î_j S_j + S_iᵀ (D̂_j S_j + Î_j Ṡ_j), i ⪯ j."""
    n = joint.shape[0]
    composites(joint, geom, params, X, body, I6, B6, W, q, qd, INERTIA_RATE)
    zero_matrix(Hd)
    for j in range(n):
        P, Q = body[j, FRC], body[j, TMP]
        _mat_vec(I6[j], body[j, SUB], P, False)
        _mat_vec(I6[j], body[j, ACC], Q, False)
        for a in range(6):
            for k in range(6):
                Q[a] += B6[j, a, k] * body[j, SUB, k]
        i = j
        while True:
            Hd[i, j] = dot6(body[i, ACC], P) + dot6(body[i, SUB], Q)
            Hd[j, i] = Hd[i, j]
            if joint[i, 1] < 0:
                break
            xforce_T(X[i, :3], X[i, 3], P, P)
            xforce_T(X[i, :3], X[i, 3], Q, Q)
            i = joint[i, 1]
