"""Compiled tick of the Slotine–Li adaptive controller, both laws (docs/cstar_slotine_li.md;
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

The passes are the shared ones of :mod:`rtctl.model.recursions` (the forward pass is (34)-(35),
the link forces (36) or (23), the backward pass (37) = (24)); this module adds the reference signals,
the parameter rates (41)-(42) / (26)-(27) and the tick around them. The estimates π̂ are
integrated outside the recursion (explicit Euler, :func:`euler_step`) and optionally kept
physically consistent by :func:`project_consistent`.
"""
from __future__ import annotations

from rtctl.compiled import kernel, leaf
from rtctl.control.base import emit_owned
from rtctl.control.consistency import project_consistent
from rtctl.control.motor import motor_feedforward_add
from rtctl.model.data import ACC, REF, TMP, VEL
from rtctl.model.recursions import CHRISTOFFEL, CSTAR, backward_pass, forward_pass, link_forces, update_joints
from rtctl.model.spatial_kernels import crm_mul

CLASSIC = CHRISTOFFEL  # the classic law is the Christoffel factorisation's
PHI_VECTORS = 4  # φ scratch rows


@leaf
def phi_into(V, k, x, y, phi, row):
    """phi[row] = φ(V[k, x], V[k, y]), the 10-vector with xᵀ I(π) y = φ(x, y)·π (Pinocchio's
    parameter order): m: v_x·v_y;  h = m c: v_y × ω_x + v_x × ω_y;  J: the symmetric products ω_x,a ω_y,b."""
    a0, a1, a2, b0, b1, b2 = V[k, x, 0], V[k, x, 1], V[k, x, 2], V[k, x, 3], V[k, x, 4], V[k, x, 5]
    c0, c1, c2, d0, d1, d2 = V[k, y, 0], V[k, y, 1], V[k, y, 2], V[k, y, 3], V[k, y, 4], V[k, y, 5]
    phi[row, 0] = b0 * d0 + b1 * d1 + b2 * d2
    phi[row, 1] = (d1 * a2 - d2 * a1) + (b1 * c2 - b2 * c1)
    phi[row, 2] = (d2 * a0 - d0 * a2) + (b2 * c0 - b0 * c2)
    phi[row, 3] = (d0 * a1 - d1 * a0) + (b0 * c1 - b1 * c0)
    phi[row, 4] = a0 * c0
    phi[row, 5] = a0 * c1 + a1 * c0
    phi[row, 6] = a1 * c1
    phi[row, 7] = a0 * c2 + a2 * c0
    phi[row, 8] = a1 * c2 + a2 * c1
    phi[row, 9] = a2 * c2


@leaf
def reference_signals(q, qd, q_d, qd_d, qdd_d, lam, qdr, qddr, s):
    """q̃ = q − q_d, q̇_r = q̇_d − Λ q̃, q̈_r = q̈_d − Λ (q̇ − q̇_d), s = q̇ − q̇_r (Λ diagonal)."""
    for i in range(q.shape[0]):
        qdr[i] = qd_d[i] - lam[i] * (q[i] - q_d[i])
        qddr[i] = qdd_d[i] - lam[i] * (qd[i] - qd_d[i])
        s[i] = qd[i] - qdr[i]


@kernel
def parameter_rates(law, gamma, body, phi, params_dot):
    """dπ̂_i/dt = −P_i (Y_iᵀ s) of every link into ``params_dot`` (n, 10): (41)-(42) for CSTAR,
    (26)-(27) for CLASSIC, from v, u, w of the forward pass; with e_i = v_i − u_i (40) and, for
    CLASSIC, u × v where :func:`~rtctl.model.recursions.link_forces` left it (body[:, TMP+3]).
    Scratch: body[:, TMP .. TMP+2], phi (4, 10)."""
    E, VXE, UXE, UXV = TMP, TMP + 1, TMP + 2, TMP + 3
    for i in range(body.shape[0]):
        for k in range(6):
            body[i, E, k] = body[i, VEL, k] - body[i, REF, k]
        phi_into(body, i, E, ACC, phi, 0)
        crm_mul(body, i, VEL, E, 1.0, VXE, False)
        phi_into(body, i, VXE, REF, phi, 1)
        if law == CSTAR:
            for k in range(10):
                params_dot[i, k] = gamma[i, k] * (phi[1, k] - phi[0, k])
        else:
            crm_mul(body, i, REF, E, 1.0, UXE, False)
            phi_into(body, i, UXE, VEL, phi, 2)
            phi_into(body, i, E, UXV, phi, 3)
            for k in range(10):
                params_dot[i, k] = gamma[i, k] * (0.5 * (phi[1, k] + phi[2, k] - phi[3, k]) - phi[0, k])


@kernel
def slotine_li_kernel(law, joint, geom, params, gravity, X, body, phi, q, qd, q_d, qd_d, qdd_d, lam, kd, gamma,
                      dead_zone, qdr, qddr, s, tau, params_dot):
    """One tick of either law: τ (37)/(24) into ``tau`` and dπ̂/dt (42)/(27) into ``params_dot``
    (n, 10), with the estimates ``params`` (n, 10). q̇_r, q̈_r, s are written too. Adaptation
    stops (params_dot = 0) while ‖s‖ ≤ dead_zone."""
    n = joint.shape[0]
    reference_signals(q, qd, q_d, qd_d, qdd_d, lam, qdr, qddr, s)
    s2 = 0.0
    for i in range(n):
        s2 += s[i] * s[i]
    update_joints(joint, geom, q, X, body)
    forward_pass(joint, gravity, X, body, qd, qdr, qddr)
    link_forces(law, params, body)
    if s2 > dead_zone * dead_zone:
        parameter_rates(law, gamma, body, phi, params_dot)
    else:
        for i in range(n):
            for k in range(10):
                params_dot[i, k] = 0.0
    backward_pass(joint, X, body, tau)
    for i in range(n):
        tau[i] -= kd[i] * s[i]


@leaf
def euler_step(params, params_dot, h):
    """π̂ ← π̂ + h dπ̂/dt (explicit Euler over one controller period h)."""
    for i in range(params.shape[0]):
        for k in range(10):
            params[i, k] += h * params_dot[i, k]


# Packed arguments of the controller's tick (each array handed to numba from Python costs
# ~0.06-0.15 µs to unbox, so the tick takes 18 instead of 31):
LAW, STEP, PROJECT, MOTOR, COULOMB_VELOCITY, DEAD_ZONE = range(6)  # settings (6,) float
LAM, KD, ARMATURE, VISCOUS, COULOMB = range(5)  # gains (5, n)
QDR, QDDR, SLIDING, TAU = range(4)  # signals (4, n)
CUT_ROW = 13  # work (13 + n, 10): φ rows 0–3, a row 4, A rows 5–8, V rows 9–12, then per link its last cut (cols 0–3)


def work_rows(n: int) -> int:
    return CUT_ROW + n


@kernel
def slotine_li_update_kernel(settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, fresh, ref,
                             signals, params_dot, mask, tau_out):
    """The controller's tick in one call: π̂ += h · (the previous tick's dπ̂/dt) with h =
    settings[STEP], then the optional consistency projection, then :func:`slotine_li_kernel`
    with the new π̂ (overwriting ``params_dot`` for the next tick; zero when a joint's state is
    not ``fresh``: its s is older than its regressor), then the optional drive-train
    feed-forward, and the owned joints' τ into ``tau_out``. ``ref``: rows q_d, q̇_d, q̈_d."""
    h = settings[STEP]
    if h > 0.0:
        euler_step(params, params_dot, h)
        if settings[PROJECT] != 0.0:
            project_consistent(params, gamma, work[5:9, 0:4], work[9:13, 0:4], work[4], work[CUT_ROW:, 0:4])
    slotine_li_kernel(int(settings[LAW]), joint, geom, params, gravity, X, body, work[0:PHI_VECTORS], q, qd, ref[0],
                      ref[1], ref[2], gains[LAM], gains[KD], gamma, settings[DEAD_ZONE], signals[QDR], signals[QDDR],
                      signals[SLIDING], signals[TAU], params_dot)
    for j in range(fresh.shape[0]):
        if not fresh[j]:
            params_dot[:, :] = 0.0
            break
    if settings[MOTOR] != 0.0:
        motor_feedforward_add(qd, signals[QDDR], gains[ARMATURE], gains[VISCOUS], gains[COULOMB],
                              settings[COULOMB_VELOCITY], signals[TAU])
    emit_owned(mask, signals[TAU], tau_out)
