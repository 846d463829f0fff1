"""Quintic joint-space segments: coefficients for any boundary state, extrema, minimum durations.

A segment is q(τ) = Σₖ cₖ τᵏ (k = 0…5, 0 ≤ τ ≤ T), one row of six ascending coefficients per
joint. Six coefficients fit position, velocity and acceleration at both ends (Biagiotti &
Melchiorri, *Trajectory Planning for Automatic Machines and Robots*, 2008, eq. 2.5). With zero
boundary velocity and acceleration it is the minimum-jerk profile (Flash & Hogan 1985)
q = q₀ + Δ(10s³ − 15s⁴ + 6s⁵), s = τ/T, whose peaks are |q̇| = 15/8·|Δ|/T at s = ½ and
|q̈| = 10/√3·|Δ|/T² at s = ½ ∓ √3/6 — hence the closed-form minimum duration below.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial import polynomial as P

PEAK_VELOCITY = 15.0 / 8.0  # max |q̇| · T / |Δ| of the rest-to-rest quintic
PEAK_ACCELERATION = 10.0 / np.sqrt(3.0)  # max |q̈| · T² / |Δ|

_D1 = np.arange(1.0, 6.0)  # d/dτ of the ascending coefficients
_D2 = np.array([2.0, 6.0, 12.0, 20.0])  # d²/dτ²


def coefficients(q0, v0, a0, q1, v1, a1, T):
    """Ascending coefficients (…, 6) of the quintic with the given boundary states; broadcasts."""
    q0, v0, a0, q1, v1, a1, T = np.broadcast_arrays(*(np.asarray(x, float) for x in (q0, v0, a0, q1, v1, a1, T)))
    h = q1 - q0
    c = np.empty(h.shape + (6,))
    c[..., 0] = q0
    c[..., 1] = v0
    c[..., 2] = a0 / 2.0
    c[..., 3] = (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T**2) / (2 * T**3)
    c[..., 4] = (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T**2) / (2 * T**4)
    c[..., 5] = (12 * h - 6 * (v1 + v0) * T + (a1 - a0) * T**2) / (2 * T**5)
    return c


def constant(q):
    """Coefficients of a segment that stays at ``q`` (dwell, hold)."""
    c = np.zeros(np.shape(q) + (6,))
    c[..., 0] = q
    return c


def rest_to_rest_duration(delta, v_max, a_max) -> float:
    """Shortest common duration of a synchronised min-jerk move of ``delta`` within the limits."""
    d = np.abs(np.asarray(delta, float))
    t_v = PEAK_VELOCITY * d / v_max
    t_a = np.sqrt(PEAK_ACCELERATION * d / a_max)
    return float(np.max(np.maximum(t_v, t_a), initial=0.0))


def _critical_points(d, T):
    """0, T and the real roots in (0, T) of the polynomial ``d`` (ascending coefficients)."""
    d = P.polytrim(d, tol=0.0)
    pts = [0.0, T]
    if len(d) > 1:
        r = P.polyroots(d)
        real = r.real[np.abs(r.imag) <= 1e-9 * (1.0 + np.abs(r.real))]
        pts.extend(real[(real > 0.0) & (real < T)])
    return np.asarray(pts)


def extrema(c, T):
    """Per joint of one segment (c: (n, 6)): (q_min, q_max, max |q̇|, max |q̈|) over [0, T], exactly.

    Extrema of each derivative lie at the ends or at real roots of the next one, found by
    :func:`numpy.polynomial.polynomial.polyroots`.
    """
    out = np.empty((4, c.shape[0]))
    for j, cq in enumerate(c):
        cv = cq[1:] * _D1
        ca = cq[2:] * _D2
        qs = P.polyval(_critical_points(cv, T), cq)
        out[0, j], out[1, j] = qs.min(), qs.max()
        out[2, j] = np.abs(P.polyval(_critical_points(ca, T), cv)).max()
        out[3, j] = np.abs(P.polyval(_critical_points(ca[1:] * _D1[:3], T), ca)).max()
    return out


def limit_ratio(c, T, v_max, a_max) -> float:
    """max over joints of max(peak |q̇| / v_max, √(peak |q̈| / a_max)): the time-scaling factor
    that would make the segment just fit the limits (velocity scales 1/λ, acceleration 1/λ²)."""
    e = extrema(c, T)
    return float(max(np.max(e[2] / v_max), np.sqrt(np.max(e[3] / a_max))))


# ---- shortest duration from an arbitrary start state ------------------------------------
_S = np.linspace(0.0, 1.0, 129)  # normalised time s = τ/T for the vectorised scan
_GROWTH = 1.02  # ratio between successive candidate durations
_SPAN = 350  # candidates each side of the reference duration (1.02³⁵⁰ ≈ 10³)


def shortest_duration(q0, v0, a0, q1, v_max, a_max, q_min=None, q_max=None) -> float | None:
    """Shortest duration T (to within 2 %) of a quintic from (q0, v0, a0) to rest at q1 within
    the velocity, acceleration and (optional) position limits; None when no T in the scanned
    range (10⁻³…10³ × a reference duration) works.

    With a non-zero start state the peaks are not monotone in T (a large T lets an initial
    velocity carry the joint far past the target), so instead of bisection a geometric grid of
    candidates is checked at once by sampling; the first that passes is confirmed with the
    exact :func:`extrema` (a sampled peak can miss the true one by a hair).
    """
    q0, v0, a0, q1 = (np.asarray(x, float) for x in (q0, v0, a0, q1))
    t_ref = max(rest_to_rest_duration(q1 - q0, v_max, a_max), float(np.max(np.abs(v0) / a_max)), 1e-3)
    T = t_ref * _GROWTH ** np.arange(-_SPAN, _SPAN + 1)
    c = coefficients(q0, v0, a0, q1, 0.0, 0.0, T[:, None])  # (K, n, 6)
    tau = _S[None, :] * T[:, None]  # (K, S)
    pw = tau[:, :, None] ** np.arange(6.0)  # (K, S, 6)
    q = np.einsum("kjc,ksc->kjs", c, pw)
    v = np.einsum("kjc,ksc->kjs", c[:, :, 1:] * _D1, pw[:, :, :5])
    a = np.einsum("kjc,ksc->kjs", c[:, :, 2:] * _D2, pw[:, :, :4])
    ok = (np.abs(v).max(axis=2) <= v_max).all(axis=1) & (np.abs(a).max(axis=2) <= a_max).all(axis=1)
    if q_min is not None:
        ok &= (q.min(axis=2) >= q_min).all(axis=1) & (q.max(axis=2) <= q_max).all(axis=1)
    for k in np.flatnonzero(ok):
        if fits(c[k], T[k], v_max, a_max, q_min, q_max):
            return float(T[k])
    return None


def fits(c, T, v_max, a_max, q_min=None, q_max=None, rtol=1e-9) -> bool:
    """Whether one segment stays within the limits (exact extrema, relative tolerance ``rtol``)."""
    e = extrema(c, T)
    ok = np.all(e[2] <= v_max * (1 + rtol)) and np.all(e[3] <= a_max * (1 + rtol))
    if q_min is not None:
        span = np.maximum(np.abs(q_min), np.abs(q_max))
        ok = ok and np.all(e[0] >= q_min - rtol * span) and np.all(e[1] <= q_max + rtol * span)
    return bool(ok)
