"""Sage–Husa adaptive Kalman filter for the coefficients of a per-channel ARX model
(Qu & Jiang, eqs. (16)-(27); see docs/arma_kalman.md).

Per channel (one robot joint), with the regressor h(k) of :mod:`rtctl.estimation.arx`::

    θ(k+1) = θ(k) + V(k),   V ~ N(q, Q)                (17)  random-walk coefficients
    y(k)   = h(k)ᵀ θ(k) + W(k),   W ~ N(r, R)          (16)  "virtual noise" W

and d_k = (1 − λ) / (1 − λ^(k+1)), 0 < λ < 1 (λ is the forgetting factor of the statistics)::

    θ̂(k+1|k) = θ̂(k|k) + q̂(k)                P(k+1|k) = P(k|k) + Q̂(k)         (19), (22)
    ε(k+1)   = y(k+1) − h(k+1)ᵀ θ̂(k+1|k) − r̂(k)                              (20)
    K(k+1)   = P(k+1|k) h / (hᵀ P(k+1|k) h + R̂(k))                              (21)
    θ̂(k+1|k+1) = θ̂(k+1|k) + K ε                                               (18)
    P(k+1|k+1) = (I − K hᵀ) P(k+1|k) (I − K hᵀ)ᵀ + R̂ K Kᵀ   (Joseph form of (23))
    r̂(k+1) = (1 − d_k) r̂(k) + d_k (y(k+1) − h(k+1)ᵀ θ̂(k+1|k))                (24)
    R̂(k+1) = (1 − d_k) R̂(k) + d_k (ε² − hᵀ P(k+1|k) h)                         (25)
    q̂(k+1) = (1 − d_k) q̂(k) + d_k (θ̂(k+1|k+1) − θ̂(k|k))                      (26)
    Q̂(k+1) = (1 − d_k) Q̂(k) + d_k (K ε² Kᵀ + P(k+1|k+1) − P(k|k))              (27)

``noise_form = "residual"`` (rtctl's variant, docs/arma_kalman.md) replaces (25) and (27) by::

    R̂(k+1) = (1 − d_k) R̂(k) + d_k ((y − hᵀθ̂(k+1|k+1) − r̂(k))² + hᵀ P(k+1|k+1) h)        (25′)
    Q̂(k+1) = (1 − d_k) Q̂(k) + d_k diag(K ε² Kᵀ + P(k+1|k+1) − P(k|k)), an entry that is
             negative taken from K ε² Kᵀ alone                                              (27′)

(residual-based covariance matching, Mohamed & Schwarz 1999, with the fading weight d_k; the
variational-Bayes noise update of Särkkä & Nummenmaa 2009; biased/unbiased switching for Q̂):
both samples are non-negative by construction. With R_gain the gain's R, the residual is
ε R_gain/S and hᵀP(k+1|k+1)h = s R_gain/S, S = s + R_gain, s = hᵀP(k+1|k)h.

Each of (24)-(27) is a switch (:data:`ADAPT_R` … :data:`ADAPT_QCOV`); q̂ is off by default
because it integrates Kε and diverges, in closed loop and in open loop alike (tests/estimation). Safeguards, which the
plain Sage–Husa equations lack: when ε² − hᵀP(k+1|k)h < 0 (always, while P is still large) (25)
uses ε² alone — flooring it instead lets R̂ collapse at the start and the coefficients chase the
noise — and R̂ is floored at ``R_min`` > 0; the gain uses max(R̂, 10⁻⁹ hᵀPh), so P never
collapses to exactly singular along h (rounding would then make it indefinite); Q̂ is kept
diagonal (only its diagonal is estimated) and floored at ``Q_min`` ≥ 0; P is updated in Joseph
form and symmetrised. Option ``forget_covariance``: P(k+1|k) = P(k|k)/λ + Q̂, the exponential
forgetting of recursive least squares, so that the coefficients themselves track a change within
≈ ln(tol)/ln(λ) samples (not in the paper; off by default).

Storage is channel-last (Pinocchio's model/data split: a :class:`SageHusa` owns everything
preallocated): θ̂ is (p, m), P is (m, p, p), q̂, Q̂ and Q_min are the rows of ``drift`` (3, p,
m), the statistics are rows of ``signals`` (4, m): r̂, R̂, ε, y − hᵀθ̂(k+1|k), and ``fade`` (m)
holds λᵏ — all views of one contiguous ``state`` array in that order (:func:`state_views`), so
that a compiled caller takes the whole filter as one argument. One compiled call updates one
channel (:func:`sage_husa_step`) and allocates nothing.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel, leaf

# switches (indices into the int64 ``switches`` array)
ADAPT_R, ADAPT_RCOV, ADAPT_Q, ADAPT_QCOV, FORGET_COV, RESIDUAL = range(6)
N_SWITCHES = 6
SWITCH_NAMES = ("r", "R", "q", "Q")
NOISE_FORMS = ("sage_husa", "residual")  # switches[RESIDUAL] = the index
# rows of ``signals``
R_HAT, RCOV_HAT, EPS, PRED_ERR = range(4)
R_REL = 1e-9  # the gain's R is at least R_REL · hᵀP(k+1|k)h


@kernel(error_model="numpy")  # 0/0 → NaN, caught by the caller
def sage_husa_step(i, theta, P, q_hat, Q_hat, signals, fade, h, y, lam, switches, R_min, Q_min, Ph, old_diag):
    """One filter step of channel ``i`` with regressor ``h`` and measurement ``y``; ``fade[i]`` =
    λᵏ, k the channel's steps since the start (1 at the start: d_0 = 1). ``Ph``, ``old_diag``:
    scratch (p,)."""
    p = h.shape[0]
    Pi = P[i]
    lam_k1 = fade[i] * lam  # λ^(k+1), kept as a product: pow() costs more than the whole update
    dk = (1.0 - lam) / (1.0 - lam_k1)
    fade[i] = lam_k1 if lam_k1 > 1e-200 else 0.0  # no subnormals
    for a in range(p):
        old_diag[a] = Pi[a, a]
    if switches[FORGET_COV]:
        for a in range(p):
            for b in range(p):
                Pi[a, b] /= lam
    for a in range(p):  # prediction (19), (22)
        theta[a, i] += q_hat[a, i]
        Pi[a, a] += Q_hat[a, i]
    s = 0.0
    pred = y
    for a in range(p):
        acc = 0.0
        for b in range(p):
            acc += Pi[a, b] * h[b]
        Ph[a] = acc
        s += h[a] * acc
        pred -= h[a] * theta[a, i]
    r_hat, R_hat = signals[R_HAT, i], signals[RCOV_HAT, i]
    eps = pred - r_hat  # (20)
    # the gain never trusts y more than 1/R_REL times the prediction: P keeps a sliver of
    # variance along h, so rounding cannot drive it indefinite (R̂ at its floor, P → 0)
    R_gain = R_hat if R_hat > R_REL * s else R_REL * s
    S = s + R_gain
    inv_S = 1.0 / S
    if s > 0.0:  # s ≤ 0: P has (numerically) no variance along h, y carries no news about θ
        # Joseph form, expanded: (I − K hᵀ) P (I − K hᵀ)ᵀ + R K Kᵀ = P − K Phᵀ − (Ph − s K) Kᵀ + R K Kᵀ
        for a in range(p):
            Ka = Ph[a] * inv_S
            theta[a, i] += Ka * eps  # (18)
            va = Ph[a] - s * Ka
            for b in range(a + 1):
                Kb = Ph[b] * inv_S
                vb = Ph[b] - s * Kb
                # symmetric by construction: the (a, b) and (b, a) terms averaged
                upd = Pi[a, b] - 0.5 * (Ka * Ph[b] + Kb * Ph[a]) - 0.5 * (va * Kb + vb * Ka) + R_gain * Ka * Kb
                Pi[a, b] = upd
                Pi[b, a] = upd
    else:
        S = R_gain if R_gain > R_min else R_min
        for a in range(p):
            Ph[a] = 0.0  # K = 0 for (26), (27)
    if switches[ADAPT_R]:  # (24)
        signals[R_HAT, i] = (1.0 - dk) * r_hat + dk * pred
    if switches[ADAPT_RCOV]:
        if switches[RESIDUAL]:  # (25) residual form: (y − hᵀθ̂(k+1|k+1) − r̂)² + hᵀP(k+1|k+1)h > 0
            if s > 0.0:
                res = eps * R_gain * inv_S
                sample = res * res + s * R_gain * inv_S
            else:
                sample = eps * eps
        else:  # (25), never from a negative sample
            sample = eps * eps - s
            if sample < 0.0:
                sample = eps * eps
        R_new = (1.0 - dk) * R_hat + dk * sample
        signals[RCOV_HAT, i] = R_new if R_new > R_min else R_min
    if switches[ADAPT_Q]:  # (26): θ̂(k+1|k+1) − θ̂(k|k) = q̂(k) + K ε
        for a in range(p):
            q_hat[a, i] = (1.0 - dk) * q_hat[a, i] + dk * (q_hat[a, i] + Ph[a] / S * eps)
    if switches[ADAPT_QCOV]:  # (27), diagonal, floored
        for a in range(p):
            Ka = Ph[a] / S
            sample = Ka * Ka * eps * eps + Pi[a, a] - old_diag[a]
            if sample < 0.0 and switches[RESIDUAL]:  # the biased K ε² Kᵀ instead: never negative
                sample = Ka * Ka * eps * eps
            Q_new = (1.0 - dk) * Q_hat[a, i] + dk * sample
            Q_hat[a, i] = Q_new if Q_new > Q_min[a, i] else Q_min[a, i]
    signals[EPS, i] = eps
    signals[PRED_ERR, i] = pred


@kernel
def first_nonfinite(i, theta, P, q_hat, Q_hat, signals) -> int:
    """−1 if channel ``i``'s estimates are all finite, else the index of the first bad quantity
    in :data:`QUANTITIES`. One sum on the normal path (NaN and ±inf propagate through it)."""
    p = theta.shape[0]
    total = signals[R_HAT, i] + signals[RCOV_HAT, i]
    for a in range(p):
        total += theta[a, i] + q_hat[a, i] + Q_hat[a, i]
        for b in range(p):
            total += P[i, a, b]
    if np.isfinite(total):
        return -1
    for a in range(p):
        if not np.isfinite(theta[a, i]):
            return 0
    for a in range(p):
        for b in range(p):
            if not np.isfinite(P[i, a, b]):
                return 1
    if not np.isfinite(signals[R_HAT, i]):
        return 2
    if not np.isfinite(signals[RCOV_HAT, i]):
        return 3
    for a in range(p):
        if not np.isfinite(q_hat[a, i]):
            return 4
    return 5  # Q̂, or finite values whose sum overflowed (≈ 1e308: diverged all the same)


QUANTITIES = ("coefficient estimate θ̂", "covariance P", "noise mean r̂", "noise variance R̂",
              "drift mean q̂", "drift covariance Q̂")


def state_size(m: int, p: int) -> int:
    """Length of the ``state`` array of ``m`` channels of ``p`` coefficients."""
    return p * m + m * p * p + 3 * p * m + 4 * m + m


@leaf
def state_views(state, m, p):
    """(θ̂, P, drift, signals, fade) as views of ``state`` (see the module docstring); also
    from Python."""
    a = p * m
    b = a + m * p * p
    c = b + 3 * p * m
    d = c + 4 * m
    return (state[:a].reshape((p, m)), state[a:b].reshape((m, p, p)), state[b:c].reshape((3, p, m)),
            state[c:d].reshape((4, m)), state[d:d + m])


def _per_channel(value, m: int, p: int | None, name: str) -> np.ndarray:
    """A number, p numbers (every channel) or m × p numbers → (p, m); without p: → (m,)."""
    a = np.asarray(value, dtype=float)
    if p is None:
        a = np.broadcast_to(a, (m,)) if a.ndim == 0 else a
        if a.shape != (m,):
            raise ValueError(f"{name} must be a number or {m} numbers, got shape {a.shape}")
        return np.array(a, dtype=float)
    if a.ndim == 0 or a.shape == (p,):
        return np.array(np.broadcast_to(a[..., None] if a.ndim else a, (p, m)), dtype=float)
    if a.shape == (m, p):
        return np.ascontiguousarray(a.T)
    raise ValueError(f"{name} must be a number, {p} numbers or {m} × {p} numbers, got shape {a.shape}")


class SageHusa:
    """The filter for ``m`` independent channels of ``p`` coefficients each.

    Initial values (a number, p numbers for every channel, or m × p): ``theta0``, ``P0``
    (the diagonal of P(0)), ``q0``, ``Q0`` (the diagonal of Q̂(0)), ``Q_min``; per channel (a
    number or m): ``r0``, ``R0``. ``adapt``: the set of switched-on adaptations among
    ``"r", "R", "q", "Q"`` (default r̂ and R̂). ``R_min`` > 0 floors R̂. ``noise_form``: the
    form of (25) and (27), ``"sage_husa"`` or ``"residual"`` (the module docstring).
    """

    def __init__(self, m: int, p: int, *, lam=0.98, theta0=0.0, P0=1.0, r0=0.0, R0=1e-6, q0=0.0, Q0=0.0,
                 adapt=("r", "R"), R_min=1e-12, Q_min=0.0, forget_covariance=False, noise_form="sage_husa"):
        if m < 1 or p < 1:
            raise ValueError(f"need at least one channel and one coefficient, got m={m}, p={p}")
        if not 0.0 < lam < 1.0:
            raise ValueError(f"lam must be in (0, 1), got {lam!r}")
        if not R_min > 0.0 or not np.isfinite(R_min):
            raise ValueError(f"R_min must be a finite number > 0, got {R_min!r}")
        unknown = set(adapt) - set(SWITCH_NAMES)
        if unknown:
            raise ValueError(f"adapt: unknown switches {sorted(unknown)}; known: {', '.join(SWITCH_NAMES)}")
        self.m, self.p, self.lam, self.R_min = m, p, float(lam), float(R_min)
        self.theta0 = _per_channel(theta0, m, p, "theta0")
        P0d = _per_channel(P0, m, p, "P0")
        self.q0, self.Q0 = _per_channel(q0, m, p, "q0"), _per_channel(Q0, m, p, "Q0")
        self.state = np.zeros(state_size(m, p))  # everything that changes, for compiled callers
        self.theta, self.P, self.drift, self.signals, self.fade = state_views(self.state, m, p)
        self.q_hat, self.Q_hat, self.Q_min = self.drift  # q̂, Q̂ (diagonal), Q_min
        self.Q_min[:] = _per_channel(Q_min, m, p, "Q_min")
        self.r0, self.R0 = _per_channel(r0, m, None, "r0"), _per_channel(R0, m, None, "R0")
        for name, arr in (("theta0", self.theta0), ("P0", P0d), ("q0", self.q0), ("Q0", self.Q0),
                          ("Q_min", self.Q_min), ("r0", self.r0), ("R0", self.R0)):
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be finite")
        for name, arr in (("P0", P0d), ("Q0", self.Q0), ("Q_min", self.Q_min), ("R0", self.R0)):
            if np.any(arr < 0):
                raise ValueError(f"{name} must be ≥ 0")
        self.P0 = np.zeros((m, p, p))
        for i in range(m):
            self.P0[i][np.diag_indices(p)] = P0d[:, i]
        if noise_form not in NOISE_FORMS:
            raise ValueError(f"noise_form must be one of {', '.join(NOISE_FORMS)}, got {noise_form!r}")
        self.noise_form = noise_form
        self.switches = np.zeros(N_SWITCHES, dtype=np.int64)
        for name in adapt:
            self.switches[SWITCH_NAMES.index(name)] = 1
        self.switches[FORGET_COV] = bool(forget_covariance)
        self.switches[RESIDUAL] = NOISE_FORMS.index(noise_form)
        self._Ph, self._old = np.zeros(p), np.zeros(p)
        self.reset()

    @property
    def r_hat(self):
        return self.signals[R_HAT]

    @property
    def R_hat(self):
        return self.signals[RCOV_HAT]

    @property
    def eps(self):
        return self.signals[EPS]

    def reset(self) -> None:
        """Back to the initial values (in place: views of the arrays stay valid)."""
        self.theta[:], self.P[:], self.q_hat[:], self.Q_hat[:] = self.theta0, self.P0, self.q0, self.Q0
        self.signals[:] = 0.0
        self.signals[R_HAT], self.signals[RCOV_HAT] = self.r0, self.R0
        np.maximum(self.signals[RCOV_HAT], self.R_min, out=self.signals[RCOV_HAT])
        self.fade[:] = 1.0

    def update(self, i: int, h, y: float) -> float:
        """One step of channel ``i``; returns ε. Checks its inputs (use the compiled
        :func:`sage_husa_step` directly in a loop)."""
        h = np.ascontiguousarray(h, dtype=float)
        if h.shape != (self.p,):
            raise ValueError(f"h must have {self.p} entries, got shape {h.shape}")
        if not 0 <= i < self.m:
            raise ValueError(f"channel {i} out of range 0..{self.m - 1}")
        if not (np.all(np.isfinite(h)) and np.isfinite(y)):
            raise ValueError("h and y must be finite")
        sage_husa_step(i, self.theta, self.P, self.q_hat, self.Q_hat, self.signals, self.fade, h, float(y),
                       self.lam, self.switches, self.R_min, self.Q_min, self._Ph, self._old)
        return float(self.signals[EPS, i])
