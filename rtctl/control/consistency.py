"""Keeping adapted inertial parameters physically consistent, without breaking the Lyapunov
argument of the adaptive law.

A link's 10 parameters π = (m, h = m c, J) (Pinocchio's order, J about the link origin) belong
to some mass distribution iff its 4×4 pseudo-inertia is positive semidefinite
(Wensing, Kim & Slotine, IEEE RA-L 2018):

    P(π) = [[Σ, h], [hᵀ, m]],   Σ = ½ tr(J) 1 − J   (the second moments ∫ x xᵀ dm)

P(π) ⪰ 0 implies m ≥ 0, J ⪰ 0 and the triangle inequalities. The set C = {π : P(π) ⪰ 0} is a
convex cone (a linear matrix inequality), and the true parameters lie in it.

**The correction.** If P(π̂) has an eigenvalue λ < 0 with unit eigenvector x, the half-space
H_x = {π : xᵀ P(π) x ≥ 0} = {π : a_x·π ≥ 0} contains C (a_x is linear in x xᵀ), and π̂ is
moved towards its P⁻¹-metric projection onto H_x (P the link's diagonal adaptation gain),
over-relaxed by ρ = ``RELAXATION`` ∈ (0, 2):

    π̂ ← π̂ − ρ (a_x·π̂ / a_xᵀ P a_x) P a_x

With d the unrelaxed step, every π in H_x (so the true parameters) satisfies
‖π̂⁺ − π‖²_{P⁻¹} ≤ ‖π̂ − π‖²_{P⁻¹} − ρ(2 − ρ) ‖d‖²_{P⁻¹} (a relaxed projection onto a convex
set containing π is Fejér-monotone). So a correction can
only lower the parameter part ½ π̃ᵀ P⁻¹ π̃ of V: the Lyapunov argument survives, whatever the
number of corrections, and whatever unit x with xᵀ P(π̂) x < 0 is used. They repeat, at most ``MAX_CORRECTIONS`` times per call, until
λ_min(P(π̂)) ≥ −TOLERANCE · |tr P(π̂)|. Over-relaxation lands inside the set: an Euler step's
small violation takes one to three corrections; a grossly inconsistent π̂ (tests: random factors
in [−1.5, 2.5] on every parameter) up to a few dozen, so a single call may stop short and the
next tick continues (sequences of half-space projections approach C without a finite bound).

**What a tick costs.** A Cholesky factorisation of P(π̂) + TOLERANCE·|tr|·1 decides first (some
40 flops): a consistent link needs nothing else. A link the adaptation pushes out of C is
usually pushed out the same way as on the previous tick, so the previous cut direction, kept
per link, is tried first: while it still gives xᵀ P(π̂) x < 0, H_x is a valid half-space and
no eigenvector is needed. Only when it does not is the Jacobi eigen-solver run (~1 µs; in the
C* job at 1 kHz the adaptation pushes several links out on most ticks).
"""
from __future__ import annotations

import math

from rtctl.compiled import kernel, leaf


MAX_CORRECTIONS = 16
TOLERANCE = 1e-9
RELAXATION = 1.9


@leaf
def pseudo_inertia(p, out):
    """out (4, 4) = P(π)."""
    half_trace = 0.5 * (p[4] + p[6] + p[9])
    out[0, 0], out[1, 1], out[2, 2] = half_trace - p[4], half_trace - p[6], half_trace - p[9]
    out[0, 1] = out[1, 0] = -p[5]
    out[0, 2] = out[2, 0] = -p[7]
    out[1, 2] = out[2, 1] = -p[8]
    for a in range(3):
        out[a, 3] = out[3, a] = p[1 + a]
    out[3, 3] = p[0]


@leaf
def quadratic_form_gradient(x, out):
    """out (10,) = a_x with xᵀ P(π) x = a_x·π."""
    x0, x1, x2, x3 = x[0], x[1], x[2], x[3]
    out[0] = x3 * x3
    out[1], out[2], out[3] = 2.0 * x3 * x0, 2.0 * x3 * x1, 2.0 * x3 * x2
    out[4] = 0.5 * (-x0 * x0 + x1 * x1 + x2 * x2)
    out[5] = -2.0 * x0 * x1
    out[6] = 0.5 * (x0 * x0 - x1 * x1 + x2 * x2)
    out[7] = -2.0 * x0 * x2
    out[8] = -2.0 * x1 * x2
    out[9] = 0.5 * (x0 * x0 + x1 * x1 - x2 * x2)


@leaf
def positive_definite4(A, shift, L):
    """Whether A + shift·1 (symmetric 4×4) is positive definite: a Cholesky factorisation into
    the scratch ``L`` that fails on a pivot that is not > 0 (or not a number). Some 40 flops
    against the Jacobi sweeps' thousands: the test every consistent link takes."""
    for j in range(4):
        d = A[j, j] + shift
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, 4):
            x = A[i, j]
            for k in range(j):
                x -= L[i, k] * L[j, k]
            L[i, j] = x / L[j, j]
    return True


@kernel
def symmetric_eigen4(A, V):
    """Cyclic Jacobi on the symmetric 4×4 ``A`` (destroyed): eigenvalues on its diagonal,
    eigenvectors in the columns of ``V``."""
    for a in range(4):
        for b in range(4):
            V[a, b] = 1.0 if a == b else 0.0
    for _ in range(50):
        off, scale = 0.0, 0.0
        for a in range(4):
            scale += A[a, a] * A[a, a]
            for b in range(a + 1, 4):
                off += A[a, b] * A[a, b]
        if off <= 1e-30 * scale or off == 0.0:
            return
        for p in range(3):
            for q in range(p + 1, 4):
                apq = A[p, q]
                if apq == 0.0:
                    continue
                theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(4):  # A ← A R, V ← V R
                    akp, akq = A[k, p], A[k, q]
                    A[k, p], A[k, q] = c * akp - s * akq, s * akp + c * akq
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p], V[k, q] = c * vkp - s * vkq, s * vkp + c * vkq
                for k in range(4):  # A ← Rᵀ A
                    apk, aqk = A[p, k], A[q, k]
                    A[p, k], A[q, k] = c * apk - s * aqk, s * apk + c * aqk


@kernel
def project_link(p, gamma, A, V, a, x):
    """Move one link's π̂ (``p``, in place) towards C by relaxed P⁻¹-metric half-space
    projections (module docstring). ``x`` (4,): the link's last cut direction, kept between
    calls (zeros: none yet) — tried before any eigenvector and replaced when it no longer cuts;
    A, V (4, 4) and a (10,) scratch. Returns the number of corrections made."""
    for count in range(MAX_CORRECTIONS):
        pseudo_inertia(p, A)
        bound = -TOLERANCE * abs(A[0, 0] + A[1, 1] + A[2, 2] + A[3, 3])
        if positive_definite4(A, -bound, V):  # λ_min > bound: nothing to correct
            return count
        quadratic_form_gradient(x, a)
        value = 0.0
        for k in range(10):
            value += a[k] * p[k]  # = xᵀ P(π̂) x
        if not value < bound:  # the last cut no longer cuts: the eigenvector of λ_min
            symmetric_eigen4(A, V)
            low = 0
            for k in range(1, 4):
                if A[k, k] < A[low, low]:
                    low = k
            if A[low, low] >= bound:
                return count
            for k in range(4):
                x[k] = V[k, low]
            quadratic_form_gradient(x, a)
            value = A[low, low]
        norm = 0.0
        for k in range(10):
            norm += a[k] * gamma[k] * a[k]
        if norm == 0.0:  # a zero gain freezes the link: nothing may move it
            return count
        for k in range(10):
            p[k] -= RELAXATION * value / norm * gamma[k] * a[k]
    return MAX_CORRECTIONS


@kernel
def project_consistent(params, gamma, A, V, a, cuts):
    """:func:`project_link` for every link (``cuts`` (n, 4): their last cut directions);
    returns the total number of corrections."""
    total = 0
    for i in range(params.shape[0]):
        total += project_link(params[i], gamma[i], A, V, a, cuts[i])
    return total
