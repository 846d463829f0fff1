"""Dynamic regressors, linear in the inertial parameters π (n × 10n, Pinocchio's column order:
link k's 10 parameters in columns 10k … 10k+9, eq. 17 of docs/cstar_slotine_li.md).

Both come from one recursion (eqs. 34–35 = 21–22 of docs/cstar_slotine_li.md), in link coordinates:

    v_i = X_i v_λ + S_i q̇_i,   u_i = X_i u_λ + S_i q̇_r,i,
    w_i = X_i w_λ + S_i q̈_r,i + v_i × S_i q̇_r,i,   w_0 = −g

and a body term linear in π_k, f_k = Y_k π_k with I(π) x = A(x) π
(:func:`~rtctl.model.spatial.inertia_regressor`):

* C* (eq. 36):       f_k = I w + v ×* I u              → Y_k = A(w) + crf(v) A(u)
* classic (eq. 23):  f_k = I w + ½ [v ×* I u + u ×* I v + I (u × v)]
                                                        → Y_k = A(w) + ½ [crf(v) A(u) + crf(u) A(v) + A(u × v)]

and τ_i = S_iᵀ Σ_{k ⪰ i} ᵏX_iᵀ f_k, so Y[i, 10k:10k+10] = S_iᵀ ᵏX_iᵀ Y_k. The result satisfies
Y π = H q̈_r + C q̇_r + G with C of the chosen factorisation. With q̇_r = q̇ and q̈_r = q̈ both
reduce to the standard regressor Y(q, q̇, q̈) π = RNEA(q, q̇, q̈) (Pinocchio's
``computeJointTorqueRegressor``). These are the O(n²) reference forms; the controllers run the
recursions with π̂ directly.
"""
from __future__ import annotations

import numpy as np

from rtctl.model import checks
from rtctl.model.robot import Model
from rtctl.model.spatial import crf, crm, inertia_regressor, jcalc, plucker

KINDS = ("cstar", "christoffel")


def _body_regressor(kind: str, v, u, w) -> np.ndarray:
    if kind == "cstar":
        return inertia_regressor(w) + crf(v) @ inertia_regressor(u)
    return inertia_regressor(w) + 0.5 * (crf(v) @ inertia_regressor(u) + crf(u) @ inertia_regressor(v)
                                         + inertia_regressor(crm(u) @ v))


def slotine_li_regressor(model: Model, q, qd, qdr, qddr, kind: str = "cstar") -> np.ndarray:
    """Y(q, q̇, q̇_r, q̈_r) with Y π = H q̈_r + C q̇_r + G, C of ``kind`` ("cstar" or "christoffel",
    the latter being Niemeyer–Slotine's classic law)."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    n = model.nq
    q, qd, qdr, qddr = (checks.vector(x, n, name) for x, name in ((q, "q"), (qd, "qd"), (qdr, "qdr"), (qddr, "qddr")))
    X, S = [], []
    v, u, w = np.zeros((n, 6)), np.zeros((n, 6)), np.zeros((n, 6))
    a0 = np.concatenate([np.zeros(3), -model.gravity])
    for i in range(n):
        XJ, Si = jcalc(model.joint_types[i], model.axis[i], q[i])
        Xi = XJ @ plucker(model.R_tree[i], model.p_tree[i])
        parent = model.parent[i]
        vp, up, wp = (np.zeros(6), np.zeros(6), a0) if parent < 0 else (v[parent], u[parent], w[parent])
        v[i] = Xi @ vp + Si * qd[i]
        u[i] = Xi @ up + Si * qdr[i]
        w[i] = Xi @ wp + Si * qddr[i] + crm(v[i]) @ Si * qdr[i]
        X.append(Xi)
        S.append(Si)
    Y = np.zeros((n, 10 * n))
    for k in range(n):
        M = _body_regressor(kind, v[k], u[k], w[k])
        j = k
        while True:
            Y[j, 10 * k:10 * k + 10] = S[j] @ M
            if model.parent[j] < 0:
                break
            M = X[j].T @ M
            j = model.parent[j]
    return Y


def regressor(model: Model, q, qd, qdd) -> np.ndarray:
    """The standard regressor Y(q, q̇, q̈): Y π = RNEA(q, q̇, q̈), π = model.params.ravel()."""
    return slotine_li_regressor(model, q, qd, qd, qdd, "cstar")


def regressor_mass_matrix(model: Model, q) -> np.ndarray:
    """H(q) column by column, H[:, j] = (Y(q, 0, e_j) − Y(q, 0, 0)) π: plain numpy, nothing to
    compile — for checks at configuration time, which must not wait for a kernel (O(n³))."""
    n = model.nq
    q, zero, pi = checks.vector(q, n, "q"), np.zeros(n), model.params.ravel()
    g = regressor(model, q, zero, zero) @ pi
    return np.stack([regressor(model, q, zero, e) @ pi - g for e in np.eye(n)], axis=1)
