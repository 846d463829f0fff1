"""Compiled recursions of the Slotine–Li adaptive controller, both laws (docs/cstar_slotine_li.md;
equation numbers are Huo, Gao & Cheng's).

Link-local coordinates, Featherstone's convention; X_i = ⁱX_λ(i), S_i joint i's
motion subspace, ×/×* the motion/force cross products. One tick, for i = 1..n:

    v_i = X_i v_λ + S_i q̇_i,  u_i = X_i u_λ + S_i q̇_r,i                         (34) = (21)
    w_i = X_i w_λ + S_i q̈_r,i + v_i × S_i q̇_r,i,   v_0 = u_0 = 0, w_0 = −g       (35) = (22)
    e_i = v_i − u_i  (= Σ_{j ⪯ i} S_j s_j)                                        (40) = (25)

  C* (the paper's law):
    f_i = Î_i w_i + v_i ×* Î_i u_i  (+ Σ children X_cᵀ f_c)                      (36)
    dπ̂_i/dt = −P_i [φ(e_i, w_i) − φ(v_i × e_i, u_i)]                            (41)-(42)
  classic (Niemeyer–Slotine):
    f_i = Î_i w_i + ½ [v_i ×* Î_i u_i + u_i ×* Î_i v_i + Î_i (u_i × v_i)]  (+ children)   (23)
    dπ̂_i/dt = −P_i [φ(e_i, w_i) + ½ (φ(e_i, u_i × v_i) − φ(v_i × e_i, u_i) − φ(u_i × e_i, v_i))]  (26)-(27)
  both:
    τ_i = S_iᵀ f_i − k_i s_i                                                      (37) = (24)

φ is the linearity of the inertia in π: xᵀ I(π) y = φ(x, y)·π for motion vectors x, y, so each of the paper's
10 scalar updates e_iᵀ f̂_i^k (42) becomes one component of φ, and eᵀ (v ×* R_k u) =
−φ_k(v × e, u): the C* bracket is one φ, the classic one three.

The estimates π̂ are integrated outside the recursion (explicit Euler, :func:`euler_step`)
and optionally kept physically consistent by :func:`project_consistent`.
"""
from __future__ import annotations

from numba import njit

from rtctl.control.motor import motor_feedforward_add
from rtctl.control.consistency import project_consistent
from rtctl.model.data import SUB, update_joints
from rtctl.model.spatial_kernels import crf_mul_add, crm_mul_add, dot6, inertia_mul, xforce_T_add, xmotion, \
    zero_vector

CLASSIC, CSTAR = 0, 1  # the law; CSTAR/CHRISTOFFEL of rtctl.model.coriolis name the same two factorisations
VEL, REF, ACC, FRC, ERR = 1, 2, 3, 4, 5  # slots of the body workspace after SUB: v, u, w, f, e
BODY_SLOTS = 6
TMP_VECTORS, PHI_VECTORS = 4, 4  # per-link scratch: 6-vectors and φ 10-vectors


@njit(cache=True, inline="always")
def phi_into(x, y, out):
    """out = φ(x, y), the 10-vector with xᵀ I(π) y = φ(x, y)·π (Pinocchio's parameter order):
    m: v_x·v_y;  h = m c: v_y × ω_x + v_x × ω_y;  J: the symmetric products ω_x,a ω_y,b."""
    a0, a1, a2, b0, b1, b2 = x[0], x[1], x[2], x[3], x[4], x[5]
    c0, c1, c2, d0, d1, d2 = y[0], y[1], y[2], y[3], y[4], y[5]
    out[0] = b0 * d0 + b1 * d1 + b2 * d2
    out[1] = (d1 * a2 - d2 * a1) + (b1 * c2 - b2 * c1)
    out[2] = (d2 * a0 - d0 * a2) + (b2 * c0 - b0 * c2)
    out[3] = (d0 * a1 - d1 * a0) + (b0 * c1 - b1 * c0)
    out[4] = a0 * c0
    out[5] = a0 * c1 + a1 * c0
    out[6] = a1 * c1
    out[7] = a0 * c2 + a2 * c0
    out[8] = a1 * c2 + a2 * c1
    out[9] = a2 * c2


@njit(cache=True, inline="always")
def cross_motion(x, y, out):
    """out = x × y (two motion vectors)."""
    zero_vector(out)
    crm_mul_add(x, y, 1.0, out)


@njit(cache=True, inline="always")
def reference_signals(q, qd, q_d, qd_d, qdd_d, lam, qdr, qddr, s):
    """q̃ = q − q_d, q̇_r = q̇_d − Λ q̃, q̈_r = q̈_d − Λ (q̇ − q̇_d), s = q̇ − q̇_r (Λ diagonal)."""
    for i in range(q.shape[0]):
        qdr[i] = qd_d[i] - lam[i] * (q[i] - q_d[i])
        qddr[i] = qdd_d[i] - lam[i] * (qd[i] - qd_d[i])
        s[i] = qd[i] - qdr[i]


@njit(cache=True, inline="always")
def forward_pass(joint, gravity, X, body, qd, qdr, qddr, i):
    """v_i, u_i, w_i (34)-(35) into body[i]; X must hold the joint transforms."""
    E, r = X[i, :3], X[i, 3]
    S, v, u, w = body[i, SUB], body[i, VEL], body[i, REF], body[i, ACC]
    parent = joint[i, 1]
    if parent < 0:
        for k in range(3):  # v_0 = u_0 = 0, w_0 = −g, seen from link 1
            v[k] = 0.0
            v[3 + k] = 0.0
            u[k] = 0.0
            u[3 + k] = 0.0
            w[k] = 0.0
            w[3 + k] = -(E[k, 0] * gravity[0] + E[k, 1] * gravity[1] + E[k, 2] * gravity[2])
    else:
        xmotion(E, r, body[parent, VEL], v)
        xmotion(E, r, body[parent, REF], u)
        xmotion(E, r, body[parent, ACC], w)
    for k in range(6):
        v[k] += S[k] * qd[i]
        u[k] += S[k] * qdr[i]
        w[k] += S[k] * qddr[i]
    crm_mul_add(v, S, qdr[i], w)


@njit(cache=True, inline="always")
def body_force(law, p, v, u, w, f, tmp):
    """The link's own term of f_i: (36) for CSTAR, (23) for CLASSIC; tmp (4, 6) scratch,
    leaves u × v in tmp[3] for the classic update."""
    inertia_mul(p, w, f)
    inertia_mul(p, u, tmp[0])
    if law == CSTAR:
        crf_mul_add(v, tmp[0], f)
    else:
        inertia_mul(p, v, tmp[1])
        zero_vector(tmp[2])
        crf_mul_add(v, tmp[0], tmp[2])
        crf_mul_add(u, tmp[1], tmp[2])
        cross_motion(u, v, tmp[3])
        inertia_mul(p, tmp[3], tmp[0])
        for k in range(6):
            f[k] += 0.5 * (tmp[2][k] + tmp[0][k])


@njit(cache=True, inline="always")
def parameter_rate(law, gamma, v, u, w, e, tmp, phi, out):
    """out = dπ̂_i/dt = −P_i (Y_iᵀ s) for one link: (41)-(42) for CSTAR, (26)-(27) for CLASSIC.
    ``tmp[3]`` must hold u × v (classic; :func:`body_force` leaves it there)."""
    phi_into(e, w, phi[0])
    cross_motion(v, e, tmp[1])
    phi_into(tmp[1], u, phi[1])
    if law == CSTAR:
        for k in range(10):
            out[k] = gamma[k] * (phi[1][k] - phi[0][k])
    else:
        cross_motion(u, e, tmp[2])
        phi_into(tmp[2], v, phi[2])
        phi_into(e, tmp[3], phi[3])
        for k in range(10):
            out[k] = gamma[k] * (0.5 * (phi[1][k] + phi[2][k] - phi[3][k]) - phi[0][k])


@njit(cache=True, inline="always")
def slotine_li_kernel(law, joint, geom, params, gravity, X, body, tmp, phi, q, qd, q_d, qd_d, qdd_d, lam, kd,
                      gamma, dead_zone, qdr, qddr, s, tau, params_dot):
    """One tick of either law: τ (37)/(24) into ``tau`` and dπ̂/dt (42)/(27) into ``params_dot``
    (n, 10), with the estimates ``params`` (n, 10). q̇_r, q̈_r, s are written too. Adaptation
    stops (params_dot = 0) while ‖s‖ ≤ dead_zone."""
    n = joint.shape[0]
    reference_signals(q, qd, q_d, qd_d, qdd_d, lam, qdr, qddr, s)
    s2 = 0.0
    for i in range(n):
        s2 += s[i] * s[i]
    adapt = s2 > dead_zone * dead_zone
    update_joints(joint, geom, q, X, body)
    for i in range(n):
        forward_pass(joint, gravity, X, body, qd, qdr, qddr, i)
        v, u, w = body[i, VEL], body[i, REF], body[i, ACC]
        body_force(law, params[i], v, u, w, body[i, FRC], tmp)
        if adapt:
            e = body[i, ERR]
            for k in range(6):
                e[k] = v[k] - u[k]
            parameter_rate(law, gamma[i], v, u, w, e, tmp, phi, params_dot[i])
        else:
            zero_vector(params_dot[i])
    for i in range(n - 1, -1, -1):
        tau[i] = dot6(body[i, SUB], body[i, FRC]) - kd[i] * s[i]
        parent = joint[i, 1]
        if parent >= 0:
            xforce_T_add(X[i, :3], X[i, 3], body[i, FRC], body[parent, FRC])


@njit(cache=True, inline="always")
def euler_step(params, params_dot, h):
    """π̂ ← π̂ + h dπ̂/dt (explicit Euler over one controller period h)."""
    for i in range(params.shape[0]):
        for k in range(10):
            params[i, k] += h * params_dot[i, k]


# Packed arguments of the controller's tick (each array handed to numba from Python costs
# ~0.15 µs to unbox, so the tick takes 17 instead of 31):
LAW, STEP, PROJECT, MOTOR, COULOMB_VELOCITY, DEAD_ZONE = range(6)  # settings (6,) float
LAM, KD, ARMATURE, VISCOUS, COULOMB = range(5)  # gains (5, n)
QDR, QDDR, SLIDING, TAU = range(4)  # signals (4, n)
WORK_ROWS = 17  # work (17, 10): 6-vectors in rows 0–3, φ rows 4–7, a row 8, A rows 9–12, V rows 13–16


@njit(cache=True, inline="always")
def _law_kernel(law, settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, q_d, qd_d, qdd_d,
                signals, params_dot):
    slotine_li_kernel(law, joint, geom, params, gravity, X, body, work[0:4, 0:6], work[4:8], q, qd, q_d, qd_d,
                      qdd_d, gains[LAM], gains[KD], gamma, settings[DEAD_ZONE], signals[QDR], signals[QDDR],
                      signals[SLIDING], signals[TAU], params_dot)


@njit(cache=True)
def slotine_li_update_kernel(settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, q_d, qd_d,
                             qdd_d, signals, params_dot):
    """The controller's tick in one call: π̂ += h · (the previous tick's dπ̂/dt) with h =
    settings[STEP], then the optional consistency projection, then :func:`slotine_li_kernel`
    with the new π̂ (overwriting ``params_dot`` for the next tick), then the optional
    drive-train feed-forward. The law is a compile-time constant in each branch."""
    h = settings[STEP]
    if h > 0.0:
        euler_step(params, params_dot, h)
        if settings[PROJECT] != 0.0:
            project_consistent(params, gamma, work[9:13, 0:4], work[13:17, 0:4], work[8])
    if settings[LAW] == CSTAR:
        _law_kernel(CSTAR, settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, q_d, qd_d,
                    qdd_d, signals, params_dot)
    else:
        _law_kernel(CLASSIC, settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, q_d, qd_d,
                    qdd_d, signals, params_dot)
    if settings[MOTOR] != 0.0:
        motor_feedforward_add(qd, signals[QDDR], gains[ARMATURE], gains[VISCOUS], gains[COULOMB],
                              settings[COULOMB_VELOCITY], signals[TAU])
