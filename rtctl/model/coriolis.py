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

Î is CRBA's composite inertia (:func:`~rtctl.model.recursions.composite_inertias`), and both
walks are the shared :func:`~rtctl.model.recursions.ancestor_products`.

Ḣ uses the same composites with D_k = dI_k/dt = crf(v_k) I_k − I_k crm(v_k):
ḣ_ij = Ṡ_iᵀ Î_j S_j + S_iᵀ (D̂_j S_j + Î_j Ṡ_j) for i ⪯ j — independent of C, so the test
Ḣ = C + Cᵀ (Proposition 2) compares two derivations.
"""
from __future__ import annotations

from rtctl.compiled import kernel, leaf
from rtctl.model.data import FRC, SUB, TMP, VEL
from rtctl.model.recursions import CHRISTOFFEL, COLUMN, CSTAR, ROW, SYMMETRIC, ancestor_products, \
    composite_inertias, forward_pass, update_joints
from rtctl.model.spatial_kernels import crm_mul, inertia_mul, zero_matrix

INERTIA_RATE = 2  # the third body term the composites can carry, after CHRISTOFFEL and CSTAR
SDOT = TMP + 3  # the slot of body holding Ṡ_i = v_i × S_i


@leaf
def inertia6(P, k, M):
    """M[k] = the 6×6 spatial inertia I(P[k]) (eq. 17 of docs/cstar_slotine_li.md)."""
    zero_matrix(M[k])
    M[k, 0, 0], M[k, 0, 1], M[k, 1, 1] = P[k, 4], P[k, 5], P[k, 6]
    M[k, 0, 2], M[k, 1, 2], M[k, 2, 2] = P[k, 7], P[k, 8], P[k, 9]
    M[k, 1, 0], M[k, 2, 0], M[k, 2, 1] = P[k, 5], P[k, 7], P[k, 8]
    h0, h1, h2 = P[k, 1], P[k, 2], P[k, 3]
    M[k, 0, 4], M[k, 0, 5], M[k, 1, 3], M[k, 1, 5], M[k, 2, 3], M[k, 2, 4] = -h2, h1, h2, -h0, -h1, h0  # h×
    for a in range(3):
        for b in range(3):
            M[k, 3 + b, a] = M[k, a, 3 + b]
        M[k, 3 + a, 3 + a] = P[k, 0]


@leaf
def _skew_into(V, k, s, lo, W, w, r0, c0, scale):
    """W[w, r0:r0+3, c0:c0+3] = scale · (V[k, s, lo:lo+3])×."""
    x0, x1, x2 = V[k, s, lo], V[k, s, lo + 1], V[k, s, lo + 2]
    W[w, r0, c0 + 1] = -scale * x2
    W[w, r0, c0 + 2] = scale * x1
    W[w, r0 + 1, c0] = scale * x2
    W[w, r0 + 1, c0 + 2] = -scale * x0
    W[w, r0 + 2, c0] = -scale * x1
    W[w, r0 + 2, c0 + 1] = scale * x0


@leaf
def body_term(params, k, body, kind, I, B, W):
    """I[k] = I(params[k]) and B[k] = link k's body term of ``kind`` at its velocity
    body[k, VEL]; W (2, 6, 6) and body[k, TMP] are scratch."""
    inertia6(params, k, I)
    zero_matrix(W[0])  # crm(v)
    _skew_into(body, k, VEL, 0, W, 0, 0, 0, 1.0)
    _skew_into(body, k, VEL, 3, W, 0, 3, 0, 1.0)
    _skew_into(body, k, VEL, 0, W, 0, 3, 3, 1.0)
    half = 0.5 if kind == CHRISTOFFEL else 1.0
    for a in range(6):
        for b in range(6):
            s = 0.0
            for c in range(6):
                s -= W[0, c, a] * I[k, c, b]  # crf(v) I = −crm(v)ᵀ I
            if kind != CSTAR:
                for c in range(6):
                    s -= I[k, a, c] * W[0, c, b]  # − I crm(v)
            B[k, a, b] = half * s
    if kind == CHRISTOFFEL:  # + ½ icrf(I v)
        inertia_mul(params, k, body, k, VEL, TMP)
        zero_matrix(W[1])
        _skew_into(body, k, TMP, 0, W, 1, 0, 0, -0.5)
        _skew_into(body, k, TMP, 3, W, 1, 0, 3, -0.5)
        _skew_into(body, k, TMP, 3, W, 1, 3, 0, -0.5)
        for a in range(6):
            for b in range(6):
                B[k, a, b] += W[1, a, b]


@leaf
def congruence_add(X, i, M, src, dst, W):
    """M[dst] += X_iᵀ M[src] X_i (6×6 congruence by the transform X[i] = (E, r)); W (2, 6, 6) scratch."""
    zero_matrix(W[0])
    for a in range(3):
        for b in range(3):
            W[0, a, b] = W[0, 3 + a, 3 + b] = X[i, a, b]
            # (−E r×)[a, b]
            W[0, 3 + a, b] = -(X[i, a, (b + 1) % 3] * X[i, 3, (b + 2) % 3] - X[i, a, (b + 2) % 3] * X[i, 3, (b + 1) % 3])
    for a in range(6):
        for b in range(6):
            s = 0.0
            for c in range(6):
                s += M[src, a, c] * W[0, c, b]
            W[1, a, b] = s
    for a in range(6):
        for b in range(6):
            s = 0.0
            for c in range(6):
                s += W[0, c, a] * W[1, c, b]
            M[dst, a, b] += s


@kernel
def composites(joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, kind):
    """Joint and velocity passes, Ṡ_i = v_i × S_i into body[:, SDOT], and the subtree sums
    Î_i into I6 (via Ic) and B̂_i (of ``kind``) into B6."""
    n = joint.shape[0]
    update_joints(joint, geom, q, X, body)
    forward_pass(joint, gravity, X, body, qd, qd, zero)  # v (u, w go unused)
    for k in range(n):
        crm_mul(body, k, VEL, SUB, 1.0, SDOT, False)
        body_term(params, k, body, kind, I6, B6, W)
    for i in range(n - 1, -1, -1):
        parent = joint[i, 1]
        if parent >= 0:
            congruence_add(X, i, B6, i, parent, W)
    composite_inertias(joint, params, X, Ic)
    for k in range(n):
        inertia6(Ic, k, I6)


@leaf
def _mat_vec(M, k, V, a, d, transpose):
    """V[k, d] = M[k] V[k, a], or M[k]ᵀ V[k, a]."""
    for r in range(6):
        s = 0.0
        for c in range(6):
            s += (M[k, c, r] if transpose else M[k, r, c]) * V[k, a, c]
        V[k, d, r] = s


@kernel
def coriolis_kernel(joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, kind, C):
    """C(q, q̇) of ``kind`` (CHRISTOFFEL or CSTAR) into ``C``; the rest is Data scratch."""
    n = joint.shape[0]
    composites(joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, kind)
    zero_matrix(C)
    for j in range(n):  # rows i ⪯ j: S_iᵀ (Î_j Ṡ_j + B̂_j S_j)
        _mat_vec(I6, j, body, SDOT, FRC, False)
        _mat_vec(B6, j, body, SUB, TMP, False)
        for k in range(6):
            body[j, FRC, k] += body[j, TMP, k]
    ancestor_products(joint, X, body, SUB, -1, True, COLUMN, C)
    for i in range(n):  # columns j ≺ i: (Î_i S_i)ᵀ Ṡ_j + (B̂_iᵀ S_i)ᵀ S_j
        _mat_vec(I6, i, body, SUB, FRC, False)
        _mat_vec(B6, i, body, SUB, TMP, True)
    ancestor_products(joint, X, body, SDOT, SUB, False, ROW, C)


@kernel
def mass_matrix_dot_kernel(joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, Hd):
    """Ḣ(q, q̇) into ``Hd``: ḣ_ij = Ṡ_iᵀ Î_j S_j + S_iᵀ (D̂_j S_j + Î_j Ṡ_j), i ⪯ j."""
    n = joint.shape[0]
    composites(joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, INERTIA_RATE)
    zero_matrix(Hd)
    for j in range(n):
        _mat_vec(I6, j, body, SUB, FRC, False)  # P
        _mat_vec(I6, j, body, SDOT, TMP, False)  # Q
        for a in range(6):
            for k in range(6):
                body[j, TMP, a] += B6[j, a, k] * body[j, SUB, k]
    ancestor_products(joint, X, body, SDOT, SUB, True, SYMMETRIC, Hd)
