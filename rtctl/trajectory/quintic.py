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

PEAK_VELOCITY = 15.0 / 8.0  # max |q̇| · T / |Δ| of the rest-to-rest quintic
PEAK_ACCELERATION = 10.0 / np.sqrt(3.0)  # max |q̈| · T² / |Δ|
T_MIN = 1e-3  # s: the shortest segment planned (tiny moves would otherwise divide by T⁵ → 0)

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
    """Shortest common duration of a synchronised min-jerk move of ``delta`` within the limits
    (0 for no move, at least :data:`T_MIN` for any other)."""
    d = np.abs(np.asarray(delta, float))
    if not np.any(d):
        return 0.0
    t_v = PEAK_VELOCITY * d / v_max
    t_a = np.sqrt(PEAK_ACCELERATION * d / a_max)
    return max(float(np.max(np.maximum(t_v, t_a))), T_MIN)


def _critical_points(d, T):
    """(m, deg + 2) abscissae per row of ``d`` (m polynomials, ascending coefficients): 0, T and
    the real roots of the row in (0, T), NaN-padded. Roots are the eigenvalues of the companion
    matrices (as in :func:`numpy.polynomial.polynomial.polyroots`), batched per degree."""
    m, deg = d.shape[0], d.shape[1] - 1
    pts = np.full((m, deg + 2), np.nan)
    pts[:, 0], pts[:, 1] = 0.0, T
    big = np.abs(d) > 1e-13 * np.abs(d).max(axis=1, keepdims=True)
    lead = np.where(big.any(axis=1), deg - np.argmax(big[:, ::-1], axis=1), 0)  # effective degree
    for k in range(1, deg + 1):
        rows = np.flatnonzero(lead == k)
        if len(rows) == 0:
            continue
        comp = np.zeros((len(rows), k, k))
        comp[:, np.arange(1, k), np.arange(k - 1)] = 1.0
        comp[:, :, -1] = -d[rows, :k] / d[rows, k:k + 1]
        r = np.linalg.eigvals(comp)
        ok = (np.abs(r.imag) <= 1e-9 * (1.0 + np.abs(r.real))) & (r.real > 0.0) & (r.real < T)
        pts[rows, 2:2 + k] = np.where(ok, r.real, np.nan)
    return pts


def _values(c, x):
    """Row-wise values of the polynomials ``c`` (m, d+1) at the abscissae ``x`` (m, p), NaN kept."""
    return np.sum(c[:, None, :] * x[:, :, None] ** np.arange(c.shape[1]), axis=2)


def extrema(c, T):
    """Per joint of one segment (c: (n, 6)): (q_min, q_max, max |q̇|, max |q̈|) over [0, T], exactly.

    Extrema of each derivative lie at the ends or at real roots of the next one.
    """
    cv = c[:, 1:] * _D1
    ca = c[:, 2:] * _D2
    q = _values(c, _critical_points(cv, T))
    out = np.empty((4, c.shape[0]))
    out[0], out[1] = np.nanmin(q, axis=1), np.nanmax(q, axis=1)
    out[2] = np.nanmax(np.abs(_values(cv, _critical_points(ca, T))), axis=1)
    out[3] = np.nanmax(np.abs(_values(ca, _critical_points(ca[:, 1:] * _D1[:3], T))), axis=1)
    return out


def limit_ratio(c, T, v_max, a_max) -> float:
    """max over joints of max(peak |q̇| / v_max, √(peak |q̈| / a_max)): the time-scaling factor
    that would make the segment just fit the limits (velocity scales 1/λ, acceleration 1/λ²)."""
    e = extrema(c, T)
    return float(max(np.max(e[2] / v_max), np.sqrt(np.max(e[3] / a_max))))


# ---- shortest duration from an arbitrary start state ------------------------------------
_S_POW = np.linspace(0.0, 1.0, 65) ** np.arange(6.0)[:, None]  # (6, 65): s^k at normalised times s = τ/T
_COARSE, _SPAN = 1.25, 20  # coarse candidates: reference duration × 1.25^(−20…20) (≈ 1/90 … 90)
_FINE = 1.25 ** (np.arange(-11, 1) / 11)  # 12 refinements of one coarse step, about 2 % apart


def braking_target(q0, v0, a0, T):
    """Where a quintic from (q0, v0, a0) comes to rest in T when its velocity is the cubic
    Hermite decay v0(1−s)²(1+2s) + a0·T·s(1−s)² (s = τ/T): q0 + v0·T/2 + a0·T²/12. Its
    speed never exceeds |v0| + |a0|·T·4/27: a state near its velocity limit that still
    accelerates outward (v0 = 0.99, a0 = 1.9 against 1 and 2) cannot stop this way, and
    ``retarget`` says that no duration brings it to rest."""
    return q0 + v0 * T / 2.0 + a0 * T**2 / 12.0


def _sampled_fit(q0, v0, a0, q1, T, v_max, a_max, q_min, q_max):
    """Coefficients (K, n, 6) for the candidate durations T (K, 1) and whether each stays
    within the limits at 65 samples (necessary, not sufficient)."""
    target = braking_target(q0, v0, a0, T) if q1 is None else q1
    c = coefficients(q0, v0, a0, target, 0.0, 0.0, T)
    cs = c * (T[:, :, None] ** np.arange(6.0))  # coefficients in s = τ/T
    v = (cs[:, :, 1:] * _D1) @ _S_POW[:5] / T[:, :, None]
    a = (cs[:, :, 2:] * _D2) @ _S_POW[:4] / T[:, :, None] ** 2
    ok = (np.abs(v).max(axis=2) <= v_max).all(axis=1) & (np.abs(a).max(axis=2) <= a_max).all(axis=1)
    if q_min is not None:
        q = cs @ _S_POW
        ok &= (q.min(axis=2) >= q_min).all(axis=1) & (q.max(axis=2) <= q_max).all(axis=1)
    return c, ok


def shortest_duration(q0, v0, a0, q1, v_max, a_max, q_min=None, q_max=None) -> float | None:
    """Shortest duration T of a quintic from (q0, v0, a0) to rest at q1 — or, with ``q1=None``,
    at :func:`braking_target` — within the velocity, acceleration and (optional) position
    limits; None when none in the scanned range (≈ 1/90 … 90 × a reference duration) works.

    With a non-zero start state the peaks are not monotone in T (a large T lets an initial
    velocity carry the joint far past the target), so instead of bisection a geometric grid of
    candidates is checked at once by sampling; the first coarse step that passes is refined
    to about 2 %, and the result is confirmed with the exact :func:`extrema` (a sampled peak
    can miss the true one by a hair).
    """
    q0, v0, a0 = (np.asarray(x, float) for x in (q0, v0, a0))
    q1 = None if q1 is None else np.asarray(q1, float)
    lims = (v_max, a_max, q_min, q_max)
    t_ref = max(0.0 if q1 is None else rest_to_rest_duration(q1 - q0, v_max, a_max),
                float(np.max(np.abs(v0) / a_max)), T_MIN)
    coarse = t_ref * _COARSE ** np.arange(-_SPAN, _SPAN + 1)
    _, ok = _sampled_fit(q0, v0, a0, q1, np.maximum(coarse, T_MIN)[:, None], *lims)
    for k in np.flatnonzero(ok):
        T = np.maximum(coarse[k] * _FINE, T_MIN)[:, None]
        c, fine_ok = _sampled_fit(q0, v0, a0, q1, T, *lims)
        for i in np.flatnonzero(fine_ok):
            if fits(c[i], T[i, 0], *lims):
                return float(T[i, 0])
    return None


def fits(c, T, v_max, a_max, q_min=None, q_max=None, rtol=1e-9) -> bool:
    """Whether one segment stays within the limits (exact extrema, relative tolerance ``rtol``)."""
    e = extrema(c, T)
    ok = np.all(e[2] <= v_max * (1 + rtol)) and np.all(e[3] <= a_max * (1 + rtol))
    if q_min is not None:
        span = np.maximum(np.abs(q_min), np.abs(q_max))
        ok = ok and np.all(e[0] >= q_min - rtol * span) and np.all(e[1] <= q_max + rtol * span)
    return bool(ok)
